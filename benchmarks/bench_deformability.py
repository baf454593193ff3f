"""Deformability from presses (thesis appendix A): development objects against held-out ones, side by side.

The ``press-deformability`` learner's settings (the automatic force's target, the press's steps and averaged
window, the damping, the response curve's points) were chosen on the development world only: 10 cm cubes of the
learner's default material (mu0 90 Pa, lambda0 300 Pa, 4 cells), known object 0.5, the thesis's Table 8.1 values.
The held-out worlds are objects of other sizes, shapes (boxes of other proportions), mesh resolutions and materials
(mu0 40-250 Pa, other lambda0 / mu0 ratios), with other known deformabilities, and hidden values spread over
0.05-0.95 (the issue's 0.85, 0.30, 0.60, 0.15, 0.45 among them).  In each world the known object is of the same
kind as the unknown ones (the appendix's comparison), and the press force is chosen by the learner from it.
Figures to reach (issue 33): every estimate in [0, 1]; mean absolute error at most 0.04 on the held-out worlds.

    pliant bench deformability [-- --quick] [-- --jobs 2] [-- --repetitions 5]

Quick mode: the development world and one held-out world, one press per object and per curve point.
Writes out/bench/deformability.json.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402

#: world -> (set, learner options, hidden deformabilities)
WORLDS = {
    "development": ("development", {}, (0.75, 0.625, 0.5, 0.375, 0.25)),
    "held-out A: 7 cm box 1.4 x 0.8, soft (mu0 40, lambda0 200), 3 cells, known 0.5":
        ("held-out", {"size": 0.07, "shape": (1.4, 0.8), "cells": 3, "mu0": 40.0, "lambda0": 200.0},
         (0.05, 0.30, 0.60, 0.85, 0.95)),
    "held-out B: 14 cm box 0.7 x 1, stiff (mu0 250, lambda0 600), known 0.8":
        ("held-out", {"size": 0.14, "shape": (0.7, 1.0), "mu0": 250.0, "lambda0": 600.0, "known": 0.8},
         (0.10, 0.15, 0.45, 0.70, 0.90)),
    "held-out C: 10 cm cube, mu0 150, lambda0 1000, known 0.3":
        ("held-out", {"mu0": 150.0, "lambda0": 1000.0, "known": 0.3}, (0.85, 0.30, 0.60, 0.15, 0.45)),
}
QUICK = ("development", "held-out C: 10 cm cube, mu0 150, lambda0 1000, known 0.3")


def run_world(name: str, options: dict, truth: tuple, seed: int) -> dict:
    import pliant
    from pliant.interfaces import Context

    started = time.perf_counter()
    learner = pliant.registry.create("learner", "press-deformability",
                                     Context(scene=pliant.load_scene("hollow-cube")), **options)
    data = {f"d={d:g}": d for d in truth}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fitted = learner.fit(data, np.random.default_rng(seed))
    estimates = fitted["deformability"]
    return {"world": name, "options": options, "truth": data, "estimate": estimates,
            "error": {k: estimates[k] - data[k] for k in data}, "force": fitted["force"],
            "force_probes": fitted["force_probes"], "curve": fitted["curve"], "above_range": fitted["above_range"],
            "warnings": [str(w.message) for w in caught], "seconds": time.perf_counter() - started}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two worlds, one press per object and curve point")
    parser.add_argument("--repetitions", type=int, default=None, help="presses per unknown object (default 5; "
                        "quick 1)")
    parser.add_argument("--jobs", type=int, default=1, help="worlds at a time")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", default=None, help="the worlds whose name starts with this (e.g. development)")
    args = parser.parse_args(argv)
    reps = args.repetitions or (1 if args.quick else 5)
    names = QUICK if args.quick else tuple(WORLDS)
    if args.only:
        names = tuple(n for n in WORLDS if n.startswith(args.only))
    extra = {"repetitions": reps, **({"calibration_repetitions": 1} if args.quick else {})}
    jobs = [(n, {**WORLDS[n][1], **extra}, WORLDS[n][2], args.seed + k) for k, n in enumerate(names)]
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        results = list(pool.map(run_world, *zip(*jobs)))
    rows = []
    for r in results:
        for k in r["truth"]:
            rows.append((r["world"][:40], f"{r['truth'][k]:.2f}", f"{r['estimate'][k]:.3f}", f"{r['error'][k]:+.3f}",
                         f"{r['above_range'][k]:.3f}" if k in r["above_range"] else "-", f"{r['force']:.3g}"))
    print_table(f"press-deformability, {reps} presses per object (seed {args.seed})",
                ("world", "truth", "estimate", "error", "data say (>1)", "force N"), rows)
    summary = {}
    for kind in ("development", "held-out"):
        mine = [r for r in results if WORLDS[r["world"]][0] == kind]
        errors = [abs(e) for r in mine for e in r["error"].values()]
        estimates = [v for r in mine for v in r["estimate"].values()]
        if errors:
            summary[kind] = {"objects": len(errors), "mean_absolute_error": float(np.mean(errors)),
                             "largest_error": float(np.max(errors)),
                             "in_range": bool(all(0.0 <= v <= 1.0 for v in estimates)),
                             "above_range": sum(len(r["above_range"]) for r in mine)}
    print_table("development against held-out", ("set", "objects", "mean |error|", "largest", "all in [0, 1]",
                                                  "flagged > 1"),
                [(k, s["objects"], f"{s['mean_absolute_error']:.3f}", f"{s['largest_error']:.3f}", s["in_range"],
                  s["above_range"]) for k, s in summary.items()])
    print("seconds per world: " + ", ".join(f"{r['seconds']:.0f}" for r in results))
    write_json("deformability" + ("-quick" if args.quick else ""),
               {"repetitions": reps, "seed": args.seed, "quick": args.quick, "worlds": results, "summary": summary})
    return 0


if __name__ == "__main__":
    sys.exit(main())
