"""A* per p on triple-wall and multi-cost, and the 101-p Pareto sweep (thesis 3.3.1).

Reference (thesis): 14.4 s (triple-wall) and 2.3 s (multi-cost) per p on average.  Figures to reach
(BENCHMARKS.md): <= 1.0 s and <= 0.5 s per p; the 101-p sweep <= 30 s.

    pliant bench astar            (or: python benchmarks/bench_astar.py)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402
import pliant  # noqa: E402
from pliant.interfaces import Context, PlanningProblem  # noqa: E402

TARGETS = {"triple-wall": (14.4, 1.0), "multi-cost": (2.3, 0.5)}


def bench_scene(name: str, variant: str | None = None) -> dict:
    scene = pliant.load_scene(name, variant=variant)
    ctx = Context(scene=scene)
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    ctx.cost = pliant.registry.create("cost", "voxel", ctx)
    problem = PlanningProblem.from_context(ctx)
    rng = np.random.default_rng(0)
    pliant.registry.create("planner", "astar", ctx, p=0.5).plan(problem, rng)   # compile / warm caches
    per_p = []
    for p in np.linspace(0.0, 1.0, 101):
        planner = pliant.registry.create("planner", "astar", ctx, p=float(p))
        t = time.perf_counter()
        result = planner.plan(problem, rng)
        per_p.append((float(p), time.perf_counter() - t, result.statistics.get("length_voxels"),
                      result.statistics.get("deformation")))
    sweep_planner = pliant.registry.create("planner", "astar-pareto", ctx, values=101)
    t = time.perf_counter()
    sweep = sweep_planner.plan(problem, rng)
    sweep_time = time.perf_counter() - t
    times = np.array([r[1] for r in per_p])
    return {"scene": name + (f":{variant}" if variant else ""), "mean_per_p": float(times.mean()),
            "max_per_p": float(times.max()), "sweep_time": sweep_time,
            "pareto_size": sweep.statistics["pareto_size"], "per_p": per_p,
            "pareto": sweep.statistics["pareto"]}


def main() -> None:
    results, rows = [], []
    for name in ("triple-wall", "multi-cost"):
        for variant in (None, "soft-robot-soft-walls"):
            r = bench_scene(name, variant)
            results.append(r)
            thesis, target = TARGETS[name]
            rows.append((r["scene"], f"{r['mean_per_p']:.4f}", f"{r['max_per_p']:.4f}", f"{thesis}", f"<= {target}",
                         f"{r['sweep_time']:.2f}", "<= 30", str(r["pareto_size"]),
                         "yes" if r["max_per_p"] <= target and r["sweep_time"] <= 30 else "NO"))
    print_table("A* per p and the 101-p Pareto sweep (one core; times in s; per-p time includes the cost field)",
                ("scene", "mean/p", "max/p", "thesis/p", "target/p", "sweep", "target", "Pareto paths", "met"), rows)
    write_json("astar", {"results": results, "targets": TARGETS})


if __name__ == "__main__":
    main()
