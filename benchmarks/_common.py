"""Shared helpers of the benchmark scripts: timing, tables, JSON output."""

from __future__ import annotations

import os
import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path


def best_of(fn: Callable[[], object], repeats: int = 7, warmup: int = 2) -> dict:
    """Run ``fn`` ``warmup`` times, then time ``repeats`` runs; median and min in seconds."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return {"median": statistics.median(times), "min": min(times), "repeats": repeats}


def print_table(title: str, header: tuple, rows: list[tuple]) -> None:
    rows = [tuple(str(c) for c in r) for r in rows]
    widths = [max(len(str(h)), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print(f"\n{title}")
    print("  ".join(f"{h:<{w}}" for h, w in zip(header, widths)))
    print("  ".join("-" * w for w in widths))
    for r in rows:
        print("  ".join(f"{c:<{w}}" for c, w in zip(r, widths)))


def write_json(name: str, data: dict) -> Path:
    """Write ``out/bench/<name>.json`` with the machine description; returns the path."""
    out = Path(os.environ.get("PLIANT_BENCH_OUT", "out/bench"))
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{name}.json"
    data = {"machine": {"python": platform.python_version(), "processor": platform.processor() or platform.machine(),
                        "cpus": os.cpu_count()}, **data}
    from pliant.files import write_json as write_strict_json

    write_strict_json(path, data)            # atomic, strict JSON (NaN as null)
    print(f"\nwrote {path}")
    return path


def single_core() -> None:
    """Pin numba and BLAS to one thread, as the figures to reach are per core."""
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
