"""``pliant experiment table-3.1``: T-RRT and GradienT-RRT on the cube-wall (thesis Table 3.1), as seeded, resumable
tasks through :func:`pliant.experiments.runs.run_tasks` (so ``--executor ray`` spreads them over a cluster).

Every run plans the bundled pipeline ``cube-wall-trrt`` with seed = run index; costs are in the thesis's unit, the
sum of the state cost over the path's states one voxel apart (``path_cost / resolution``), as
``benchmarks/bench_trrt.py`` reports them (docs/plugins/trrt.md).
"""

from __future__ import annotations

import numpy as np
from pliant.api import Headline, ReproductionRun, Row
from pliant.api import ReproductionOutcome as Outcome

#: thesis Table 3.1: (planner, nFailMax) -> time mean, std (s), cost mean, std
THESIS = {("trrt", 10): (112.0, 45.6, 515.0, 82.3), ("trrt", 20): (736.0, 260.0, 478.0, 56.9),
          ("gradient-trrt", 10): (20.6, 10.7, 714.0, 326.0), ("gradient-trrt", 20): (175.0, 69.4, 563.0, 164.0)}
#: mode -> (runs per row, nFailMax values, budget of one run in s).  Both planners stop at their first solution
#: (8-10 s at nFailMax 10 even at a load average of 24 on 2 cores), so a run's record depends on its seed alone as
#: long as the budget does not bind: the ci budget is a generous safety cap, so that a slow CI machine checks the
#: same numbers.
MODES = {"full": (30, (10, 20), 1200.0), "quick": (4, (10, 20), 120.0), "ci": (2, (10,), 600.0)}


def plan_once(planner: str, n_fail_max: int, seed: int, max_time: float) -> dict:
    """One seeded run of the ``cube-wall-trrt`` pipeline: a JSON-ready record (status, time, cost, nodes)."""
    import os

    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    from pliant import api
    from pliant.api import PlanningProblem

    pipeline = api.Pipeline.from_file("cube-wall-trrt", overrides=[
        f'planner.name="{planner}"', f"planner.n_fail_max={n_fail_max}", f"planning.max_time={max_time}",
        "planner.progress=false", f"seed={seed}"])
    context = pipeline.build()
    # run `seed` of the pipeline: its [planning] budget and its planning stream (pliant.seeds), as `pliant run` plans
    problem = PlanningProblem.from_context(context, budget=pipeline.budget)
    result = context.extras["planner"].plan(problem, api.stream(seed, "planning"))
    stats = result.statistics
    record = {"planner": planner, "n_fail_max": n_fail_max, "seed": seed, "status": result.status.value,
              "time": stats["time"], "iterations": stats["iterations"], "nodes": stats["nodes"], "cost": None,
              "binding": stats.get("budget", {}).get("binding")}
    if result.path is not None:
        record["cost"] = result.cost / problem.scene.resolution
    return record


def _row_stats(records: list[dict], planner: str, n_fail_max: int) -> dict:
    mine = [r for r in records if r["planner"] == planner and r["n_fail_max"] == n_fail_max]
    solved = [r for r in mine if r["cost"] is not None]
    return {"runs": len(mine), "solved": len(solved),
            "time": float(np.mean([r["time"] for r in solved])) if solved else float("nan"),
            "time_std": float(np.std([r["time"] for r in solved])) if solved else float("nan"),
            "cost": float(np.mean([r["cost"] for r in solved])) if solved else float("nan"),
            "cost_std": float(np.std([r["cost"] for r in solved])) if solved else float("nan")}


def table_31(run: ReproductionRun) -> Outcome:
    """Plan every (planner, nFailMax) row ``runs`` times; compare means with the thesis's."""
    from pliant.api import check_settings, open_log, run_tasks

    runs, fails, max_time = MODES[run.mode]
    settings = {"pipeline": "cube-wall-trrt", "runs": runs, "n_fail_max": list(fails), "max_time": max_time,
                "seeds": f"0..{runs - 1}"}
    log, records = open_log(run.output, "--output", run.echo)
    if run.fresh:
        from pliant.api import rewrite_jsonl

        records.clear()
        rewrite_jsonl(log, records)
    check_settings(run.output, settings, ["max_time"], replace=not records)
    done = {(r["planner"], r["n_fail_max"], r["seed"]) for r in records}
    todo = [(p, f, s, max_time) for p in ("trrt", "gradient-trrt") for f in fails for s in range(runs)
            if (p, f, s) not in done]
    run_tasks(plan_once, todo, jobs=2, log=log, records=records, echo=run.echo,
              describe=lambda r: f"{r['planner']} nFailMax {r['n_fail_max']} seed {r['seed']}: {r['status']}, "
                                 f"{r['time']:.1f} s, cost {r['cost'] if r['cost'] is None else round(r['cost'])}")
    rows, stats = [], {}
    for (planner, n_fail_max), (t, t_std, c, c_std) in THESIS.items():
        if n_fail_max not in fails:
            continue
        s = stats[planner, n_fail_max] = _row_stats(records, planner, n_fail_max)
        label = f"{planner} nFailMax {n_fail_max}"
        rows += [Row(f"{label}: solved", None, f"{s['solved']}/{s['runs']}"),
                 Row(f"{label}: time (mean; tolerance: the thesis's std)", t, s["time"], tolerance=t_std, unit="s"),
                 Row(f"{label}: cost (mean; tolerance: the thesis's std)", c, s["cost"], tolerance=c_std)]
    g, t = stats["gradient-trrt", 10], stats["trrt", 10]
    headlines = [
        Headline("nFailMax 10 runs solved (fraction)", (g["solved"] + t["solved"]) / (g["runs"] + t["runs"]),
                 1.0, 1.0, 1.0, "both planners solved 30 of 30 in the thesis and in ours (docs/plugins/trrt.md)"),
        Headline("GradienT-RRT nFailMax 10 mean cost", g["cost"], 250.0, 950.0, 714.0,
                 "ours 543 (136) over 30 runs; a mean of a few runs within about 2.5 std of it"),
        Headline("T-RRT nFailMax 10 mean cost", t["cost"], 350.0, 1300.0, 515.0,
                 "ours 785 (203) over 30 runs; a mean of a few runs within about 2.5 std of it"),
    ]
    # wall time depends on the machine: reported beside the thesis's, never a checked headline
    rows.append(Row("GradienT-RRT nFailMax 10 mean time (ours 2.09 s on an idle core; not checked)", 20.6, g["time"],
                    unit="s"))
    notes = ("Times are not comparable with the thesis's (other hardware, and our planners stop at the first "
             "solution, then shortcut): differences beyond the thesis's std are expected there and marked. "
             "T-RRT's cost is above the thesis's at nFailMax 10; docs/plugins/trrt.md shows the anytime and "
             "perturbation variants that meet it.")
    ompl_log, ompl_db = _ompl(run, records, fails, max_time)
    return Outcome(rows, headlines, settings, records=[log, ompl_log, ompl_db], notes=notes)


def _ompl(run: ReproductionRun, records: list[dict], fails, max_time: float):
    """The runs in OMPL's benchmark log and database (Planner Arena reads ``benchmark.db``)."""
    from pliant.api import PlannerRuns, ompl_database, run_properties, write_ompl_log

    planners = [PlannerRuns(f"{planner} nFailMax {n}", {"pipeline": "cube-wall-trrt", "n_fail_max": n},
                            [run_properties(r) for r in records if r["planner"] == planner and r["n_fail_max"] == n])
                for planner in ("trrt", "gradient-trrt") for n in fails]
    log = write_ompl_log(run.output / "benchmark.log", "cube-wall table 3.1", planners, time_limit=max_time,
                         total_time=sum(r["time"] for r in records), setup="pliant pipeline cube-wall-trrt; "
                         "costs in the thesis's unit (path_cost / resolution)")
    return log, ompl_database(run.output / "benchmark.db", [log])
