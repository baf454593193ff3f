"""Thesis Table 3.1 on cube-wall: T-RRT and GradienT-RRT, 30 runs each at nFailMax 10 and 20 (thesis 3.3.3).

Every run plans the bundled pipeline ``cube-wall-trrt`` (its options are the planners' settings) with
another seed, on one core.  Reported per planner and nFailMax, as mean (std) over the runs: planning
time (s, to the returned path), the planned cost, and which hole the path used ("blue", the larger
one, or "grey").  Costs are in the thesis's unit: the sum of the state cost (eq. 3.1) over the path's
states one voxel (0.02 m) apart, i.e. ``PlanningProblem.path_cost / resolution``; the straight,
upright passage through the centre of the blue hole costs 380 in this unit, through the grey one 740.

Reference (thesis Table 3.1): T-RRT 112 s / 515 (nFailMax 10), 736 s / 478 (20); GradienT-RRT
20.6 s / 714 (10), 175 s / 563 (20).  Figures to reach (BENCHMARKS.md): nFailMax 10, T-RRT <= 10 s and
GradienT-RRT <= 3 s mean planning time, with mean cost no higher than the thesis's.

Runs go through the core's executor (:func:`pliant.experiments.runs.run_tasks`): written to
``out/bench/trrt/runs.jsonl`` as they finish (fsynced); a second invocation resumes (skips the runs already there)
unless ``--fresh``.  ``--jobs 2`` runs two at a time (each on its own core); ``--executor ray --address ...`` runs
them on a Ray cluster.

    pliant bench trrt [--runs 30] [--jobs 1] [--fresh] [--executor local|ray]    (or: python benchmarks/bench_trrt.py)
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402

PLANNERS = ("trrt", "gradient-trrt")
N_FAIL_MAX = (10, 20)
THESIS = {("trrt", 10): (112.0, 45.6, 515.0, 82.3), ("trrt", 20): (736.0, 260.0, 478.0, 56.9),
          ("gradient-trrt", 10): (20.6, 10.7, 714.0, 326.0), ("gradient-trrt", 20): (175.0, 69.4, 563.0, 164.0)}
TARGET_TIME = {("trrt", 10): 10.0, ("gradient-trrt", 10): 3.0}
BLUE_HOLE_X, GREY_HOLE_X = 0.71, 0.30


def which_hole(problem, configurations) -> str:
    """The hole a path passes: the one nearest (in x) to its states inside the wall's slab."""
    dense = problem.densify(configurations, problem.scene.resolution)
    inside = dense[np.abs(dense[:, 1] - 0.5) <= 0.03]
    if not len(inside):
        return "none"
    x = float(np.mean(inside[:, 0]))
    return "blue" if abs(x - BLUE_HOLE_X) < abs(x - GREY_HOLE_X) else "grey"


def run_one(planner: str, n_fail_max: int, seed: int, max_time: float, overrides: tuple[str, ...] = ()) -> dict:
    """Plan once; the record of the run (JSON-ready)."""
    single_core()
    import pliant
    from pliant.interfaces import PlanningProblem

    pipeline = pliant.Pipeline.from_file("cube-wall-trrt", overrides=[
        f'planner.name="{planner}"', f"planner.n_fail_max={n_fail_max}", f"planner.max_time={max_time}",
        "planner.progress=false", f"seed={seed}", *overrides])
    context = pipeline.build()
    problem = PlanningProblem.from_context(context)
    result = context.extras["planner"].plan(problem, np.random.default_rng(seed))
    res = problem.scene.resolution
    stats = result.statistics
    record = {"planner": planner, "n_fail_max": n_fail_max, "seed": seed, "status": result.status.value,
              "time": stats["time"], "time_to_first": stats.get("time_to_first"), "iterations": stats["iterations"],
              "nodes": stats["nodes"], "cost": None, "tree_cost": None, "hole": None}
    if result.path is not None:
        record.update(cost=result.cost / res, tree_cost=stats.get("tree_cost", result.cost) / res,
                      hole=which_hole(problem, result.path.configurations))
    return record


def summarise(runs: list[dict], planner: str, n_fail_max: int) -> dict:
    mine = [r for r in runs if r["planner"] == planner and r["n_fail_max"] == n_fail_max]
    solved = [r for r in mine if r["cost"] is not None]
    times = np.array([r["time"] for r in solved]) if solved else np.array([np.nan])
    costs = np.array([r["cost"] for r in solved]) if solved else np.array([np.nan])
    tree = np.array([r["tree_cost"] for r in solved]) if solved else np.array([np.nan])
    return {"planner": planner, "n_fail_max": n_fail_max, "runs": len(mine), "solved": len(solved),
            "time_mean": float(np.mean(times)), "time_std": float(np.std(times)),
            "cost_mean": float(np.mean(costs)), "cost_std": float(np.std(costs)),
            "tree_cost_mean": float(np.mean(tree)),
            "blue": sum(r["hole"] == "blue" for r in solved), "grey": sum(r["hole"] == "grey" for r in solved)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=30, help="runs per planner and nFailMax (default 30)")
    parser.add_argument("--jobs", type=int, default=1, help="runs at a time, one core each (default 1)")
    parser.add_argument("--max-time", type=float, default=120.0, help="budget of one run (s, default 120)")
    parser.add_argument("--fresh", action="store_true", help="forget the runs already written")
    parser.add_argument("--planners", nargs="+", default=list(PLANNERS), choices=PLANNERS)
    parser.add_argument("--n-fail-max", nargs="+", type=int, default=list(N_FAIL_MAX))
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override the pipeline (e.g. planner.anytime=restart); use with --tag")
    parser.add_argument("--tag", default="", help="name of this variant: its runs go to trrt<-tag>/runs.jsonl")
    from pliant.experiments.executor import add_executor_arguments

    add_executor_arguments(parser)
    args = parser.parse_args(argv)
    if args.runs < 1 or args.jobs < 1 or not args.max_time > 0:
        parser.error("--runs and --jobs must be >= 1 and --max-time > 0")
    from pliant.experiments import executor as executors
    from pliant.experiments.runs import open_log, run_tasks

    out = Path(os.environ.get("PLIANT_BENCH_OUT", "out/bench"))
    name = "trrt" + (f"-{args.tag}" if args.tag else "")
    log, runs = open_log(out / name, "PLIANT_BENCH_OUT")
    if args.fresh and runs:
        log.unlink()
        runs = []
    done = {(r["planner"], r["n_fail_max"], r["seed"]) for r in runs}
    todo = [(p, n, s, args.max_time, tuple(args.set)) for p in args.planners for n in args.n_fail_max
            for s in range(args.runs) if (p, n, s) not in done]
    print(f"{len(runs)} runs on file, {len(todo)} to go ({args.jobs} at a time)", flush=True)

    def describe(record: dict) -> str:
        cost = "-" if record["cost"] is None else f"{record['cost']:.0f}"
        return (f"{record['planner']} nFailMax {record['n_fail_max']} seed {record['seed']}: {record['status']}, "
                f"{record['time']:.2f} s, cost {cost}, {record['hole']}")

    try:
        with executors.using(executors.from_args(args)):
            run_tasks(run_one, todo, jobs=args.jobs, log=log, records=runs, describe=describe,
                      echo=lambda text: print(text, flush=True))
    except KeyboardInterrupt:
        print("the summary below is of the runs finished so far", flush=True)
    rows, summary = [], []
    for planner in args.planners:
        for n in args.n_fail_max:
            s = summarise(runs, planner, n)
            summary.append(s)
            ref = THESIS.get((planner, n))
            target = TARGET_TIME.get((planner, n))
            met = "-"
            if target is not None and s["solved"]:
                met = "yes" if (s["time_mean"] <= target and s["cost_mean"] <= ref[2]) else "NO"
            rows.append((planner, n, f"{s['solved']}/{s['runs']}", f"{s['time_mean']:.2f} ({s['time_std']:.2f})",
                         f"{s['cost_mean']:.0f} ({s['cost_std']:.0f})", f"{s['tree_cost_mean']:.0f}",
                         f"{s['blue']}/{s['grey']}", f"{ref[0]:g} ({ref[1]:g})" if ref else "-",
                         f"{ref[2]:g} ({ref[3]:g})" if ref else "-", f"<= {target:g} s" if target else "-", met))
    print_table(f"Thesis Table 3.1 on cube-wall{' (' + ', '.join(args.set) + ')' if args.set else ''}: mean (std) over "
                "the solved runs; cost = sum of state costs per voxel step",
                ("planner", "nFailMax", "solved", "time (s)", "cost", "tree cost", "blue/grey", "thesis time",
                 "thesis cost", "target", "met"), rows)
    write_json(name, {"summary": summary, "runs": runs, "pipeline": "cube-wall-trrt", "overrides": args.set})
    return 0


if __name__ == "__main__":
    sys.exit(main())
