"""Budgets hold (issue 31, item 4): every planner's wall time against its ``max_time``.

For each planner on a bundled pipeline where it plans, and each budget ``max_time`` (s), the pipeline is built (not
timed), its learner fitted when it has one (not timed: the pipeline fits it before planning), and ``plan`` called once
with the run's seed.  Reported: the status, the wall time of the whole ``plan`` call (``statistics["planning_time"]``,
recorded by the core around every planner) and ``used / max_time``; a run over ``max_time`` by more than 10 % is
flagged ``OVER``.  The straight and waypoint planners have no budget (one bounded pass over the motion); they are
listed with their time.  The belief planner also runs on ``iiwa-policy`` with ``scene=baxter-reach`` (issue 31's
46 s for a 15 s budget) in the full mode.

Every run is a fresh process, as ``pliant run`` is: what a planner loads on its first call (numba caches, collision
models) counts against its budget.  A timing benchmark, never a test: it depends on the machine and its load (runs
go one at a time).

    python benchmarks/bench_budgets.py [--quick] [--budgets 2,5,15] [--planners belief,trrt] [--seed 0]

``--quick``: one budget of 2 s and no Baxter case.  Writes ``out/bench/budgets.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402

#: (label, planner, pipeline, overrides): the planner's own pipeline, or a bundled scene it plans in
CASES = [
    ("astar", "astar", "triple-wall-pareto", ['planner={name="astar", p=0.5}']),
    ("astar-pareto", "astar-pareto", "triple-wall-pareto", []),
    ("trrt", "trrt", "cube-wall-trrt", []),
    ("gradient-trrt", "gradient-trrt", "cube-wall-trrt", ['planner.name="gradient-trrt"']),
    # where T-RRT solves within seconds, so that a solution's shortcut (1000 iterations) runs inside the budget
    ("trrt triple-wall", "trrt", "triple-wall-pareto", ['planner={name="trrt", shortcut_iterations=1000}']),
    ("gradient-trrt triple-wall", "gradient-trrt", "triple-wall-pareto",
     ['planner={name="gradient-trrt", shortcut_iterations=1000}']),
    ("rrtstar", "rrtstar", "passage-select", ["planner.stop_on_first=false"]),
    ("straight", "straight", "straight-demo", []),
    ("waypoints", "waypoints", "maze-slide", []),
    ("belief", "belief", "maze-policy", []),
    ("tsrrt", "tsrrt", "tsrrt-demo", []),
]
BAXTER = ("belief baxter-reach", "belief", "iiwa-policy", ["scene=baxter-reach"])
UNBUDGETED = {"straight", "waypoints"}
PROGRESS = {"belief", "trrt", "gradient-trrt", "rrtstar"}      # planners with a progress line to switch off
TOLERANCE = 0.10


def run_one(case: tuple, max_time: float | None, seed: int) -> dict:
    """Plan once under ``max_time``; the record (JSON-ready)."""
    import pliant
    from pliant.interfaces import PlanningProblem

    label, planner, pipeline, overrides = case
    extra = [] if planner in UNBUDGETED else [f"planner.max_time={max_time}"]
    if planner in PROGRESS:
        extra.append("planner.progress=false")
    pipe = pliant.Pipeline.from_file(pipeline, overrides=[*overrides, *extra, f"seed={seed}"])
    context = pipe.build()
    rng = np.random.default_rng(seed)
    learner = context.extras.get("learner")
    if learner is not None:
        learner.fit(None, rng)
    problem = PlanningProblem.from_context(context)
    t = time.perf_counter()
    result = context.extras["planner"].plan(problem, rng)
    wall = time.perf_counter() - t
    stats = result.statistics
    used = float(stats.get("planning_time", wall))
    cap = stats.get("budget", {}).get("max_time")
    ratio = used / cap if cap else None
    return {"case": label, "planner": planner, "pipeline": pipeline, "overrides": overrides, "seed": seed,
            "max_time": cap, "status": result.status.value, "used": used, "wall": wall, "ratio": ratio,
            "over": bool(ratio is not None and ratio > 1.0 + TOLERANCE),
            "extension_cut": stats.get("extension_cut"), "iterations": stats.get("iterations")}


def run_fresh(case: tuple, max_time: float | None, seed: int) -> dict:
    """:func:`run_one` in a new Python process (its last output line is the record)."""
    job = json.dumps({"case": list(case), "max_time": max_time, "seed": seed})
    done = subprocess.run([sys.executable, __file__, "--one", job], capture_output=True, text=True, check=False)
    if done.returncode != 0:            # reported as a row (the error's last line), the other runs go on
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return {"case": case[0], "planner": case[1], "pipeline": case[2], "overrides": case[3], "seed": seed,
                "max_time": max_time, "status": f"error: {last[:100]}", "used": float("nan"), "wall": float("nan"),
                "ratio": None, "over": False, "extension_cut": None, "iterations": None}
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument("--quick", action="store_true", help="one budget of 2 s, no Baxter case")
    parser.add_argument("--budgets", default="2,5,15", help="max_time values (s), comma-separated")
    parser.add_argument("--planners", default="", help="only these cases (labels, comma-separated)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--baxter", choices=("auto", "yes", "no"), default="auto",
                        help="the belief planner on iiwa-policy/baxter-reach at 15 s (auto: in the full mode)")
    args = parser.parse_args(argv)
    if args.one:
        job = json.loads(args.one)
        print(json.dumps(run_one(tuple(job["case"]), job["max_time"], job["seed"])))
        return 0
    budgets = [2.0] if args.quick else [float(b) for b in args.budgets.split(",")]
    cases = [c for c in CASES if not args.planners or c[0] in args.planners.split(",")]
    runs = []
    for case in cases:
        for max_time in ([None] if case[1] in UNBUDGETED else budgets):
            record = run_fresh(case, max_time, args.seed)
            runs.append(record)
            print(f"{record['case']:<26} max_time {record['max_time']!s:<5} used {record['used']:.2f} s "
                  f"({record['status']})", flush=True)
    if args.baxter == "yes" or (args.baxter == "auto" and not args.quick and not args.planners):
        record = run_fresh(BAXTER, 15.0, args.seed)
        runs.append(record)
        print(f"{record['case']:<26} max_time 15    used {record['used']:.2f} s ({record['status']})", flush=True)
    rows = [(r["case"], r["pipeline"], "-" if r["max_time"] is None else f"{r['max_time']:g}", f"{r['used']:.2f}",
             "-" if r["ratio"] is None else f"{r['ratio']:.2f}", r["status"][:60],
             "OVER" if r["over"] else ("-" if r["ratio"] is None and r["max_time"] is not None else "ok"))
            for r in runs]
    print_table("Budgets: wall time of plan() against max_time (flag: more than 10 % over)",
                ("planner", "pipeline", "max_time (s)", "used (s)", "used / max_time", "status", "budget"), rows)
    over = [r for r in runs if r["over"]]
    measured = sum(r["ratio"] is not None for r in runs)
    failed = sum(r["status"].startswith("error") for r in runs)
    print(f"\n{len(over)} of {measured} budgeted runs more than 10 % over" + (f"; {failed} failed" if failed else ""))
    write_json("budgets", {"quick": args.quick, "seed": args.seed, "tolerance": TOLERANCE, "runs": runs})
    return 0


if __name__ == "__main__":
    sys.exit(main())
