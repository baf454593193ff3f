"""The executors of pliant.experiments.executor: overhead per task and throughput scaling, local pool and Ray.

1. Overhead per task: ``--noop`` tasks that do nothing (return a small record), ``--repeats`` times, through
   :func:`pliant.experiments.runs.run_tasks` (records appended and fsynced to a ``runs.jsonl``, as experiments do), with
   the local pool of 1 and 2 workers and with Ray on a loopback cluster of 2 nodes x 1 CPU
   (:class:`pliant.experiments.executor.LoopbackCluster`).  Overhead = wall time / tasks.  Figure to reach:
   <= 5 ms a task for Ray on loopback.
2. Throughput scaling: ``--tasks`` real tasks (the path metric's Simulation evaluations of
   ``pliant experiment metric-tables``,
   se2-through-passage, ``--simulations`` each: about 0.7 s with 800 on an idle core) with the local pool of 1 and 2
   workers and Ray on the same cluster; tasks per second and the speed-up over one local worker.  Records are
   checked equal across executors (but for their wall time).
3. The estimate for a 100-node cluster on the full Table 5.1 (docs/experiments.md): printed from the measured
   overhead and ``--task-seconds`` (one Table 5.1 task: planning plus 8 pybullet executions).

    pliant bench executor [-- --noop 400 --tasks 18 --simulations 800 --no-ray]

The machine's other load counts: run it on an idle machine for figures to compare.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, write_json
from pliant.experiments.executor import LocalExecutor, LoopbackCluster, RayExecutor
from pliant.experiments.runs import open_log, run_tasks

TASK = "se2-through-passage"


def noop(k: int) -> dict:
    """A task that does nothing."""
    return {"k": k}


def _run(executor, work, tasks: list[tuple]) -> tuple[float, list[dict]]:
    with tempfile.TemporaryDirectory() as tmp:
        log, records = open_log(Path(tmp), "--output", echo=lambda _: None)
        t0 = time.perf_counter()
        run_tasks(work, tasks, jobs=1, log=log, records=records, describe=str, echo=lambda _: None,
                  executor=executor)
        return time.perf_counter() - t0, records


def _metric_tasks(n: int, simulations: int) -> list[tuple]:
    from pliant_reachability.evaluation import task_density
    from pliant_reachability.tasks import TASKS

    density = task_density(TASKS[TASK])
    return [(TASK, "simulation", k % 9, k // 9, density, simulations, {}, 5) for k in range(n)]


def _timeless(records: list[dict]) -> dict:
    return {(r["cell"], r["run"]): {k: v for k, v in r.items() if k != "seconds"} for r in records}


def table51_estimate(task_seconds: float, overhead: float, nodes: int = 100, cpus_per_node: int = 16,
                     rows: int = 8, plans: int = 30) -> dict:
    """The full Table 5.1 (``rows`` variants x ``plans`` policies, one task each) on ``nodes`` x ``cpus_per_node``:
    waves of tasks, the wall time, and the CPUs beyond which it stops scaling (one task per CPU)."""
    tasks = rows * plans
    slots = nodes * cpus_per_node
    waves = math.ceil(tasks / slots)
    return {"tasks": tasks, "slots": slots, "waves": waves, "task_seconds": task_seconds,
            "wall_seconds": waves * task_seconds + tasks * overhead, "cpu_hours": tasks * task_seconds / 3600,
            "scaling_stops_at_cpus": tasks, "two_core_hours": math.ceil(tasks / 2) * task_seconds / 3600}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--noop", type=int, default=400, help="no-op tasks for the overhead (default 400)")
    parser.add_argument("--tasks", type=int, default=18, help="real tasks for the scaling (default 18)")
    parser.add_argument("--simulations", type=int, default=800,
                        help="simulations per real task (default 800: about 0.7 s)")
    parser.add_argument("--task-seconds", type=float, default=480.0,
                        help="one full-protocol Table 5.1 task (s) for the estimate (default 480: the thesis's 300 s "
                             "of planning + 40 pybullet executions at the 4.5 s each measured for a WCR 0.75 policy)")
    parser.add_argument("--repeats", type=int, default=3, help="overhead runs per executor; the median is shown")
    parser.add_argument("--no-ray", action="store_true", help="only the local pool")
    args = parser.parse_args()

    from pliant_reachability.tables import _evaluate


    results = {"overhead": {}, "scaling": {}, "load_average_before": os.getloadavg()[0]}
    noops = [(k,) for k in range(args.noop)]
    real = _metric_tasks(args.tasks, args.simulations)
    reference = None
    executors = [("local, 1 worker", lambda: LocalExecutor(1)), ("local, 2 workers", lambda: LocalExecutor(2))]
    cluster = None
    if not args.no_ray:
        t0 = time.perf_counter()
        cluster = LoopbackCluster(nodes=2, cpus=1).start()
        ray_executor = RayExecutor(cluster.address)
        ray_executor.wait_for_cpus(2)
        results["ray_cluster_start_seconds"] = time.perf_counter() - t0
        executors.append(("ray, 2 nodes x 1 CPU", lambda: ray_executor))
    try:
        for label, make in executors:
            executor = make()
            _run(executor, noop, noops[:20])                            # warm-up: workers started, code shipped
            walls = sorted(_run(executor, noop, noops)[0] for _ in range(args.repeats))
            wall = walls[len(walls) // 2]
            results["overhead"][label] = {"tasks": len(noops), "wall": wall, "per_task_ms": 1000 * wall / len(noops),
                                          "per_task_ms_min": 1000 * walls[0] / len(noops), "repeats": len(walls)}
            wall, records = _run(executor, _evaluate, real)
            same = None
            if reference is None:
                reference = _timeless(records)
            else:
                same = _timeless(records) == reference
            results["scaling"][label] = {"tasks": len(real), "wall": wall, "tasks_per_second": len(real) / wall,
                                         "records_equal_local": same}
    finally:
        if cluster is not None:
            ray_executor.close()
            cluster.stop()
    base = results["scaling"]["local, 1 worker"]["tasks_per_second"]
    print_table(f"overhead per task (no-op tasks through run_tasks, records fsynced; median of {args.repeats})",
                ("executor", "tasks", "wall (s)", "per task (ms)", "min (ms)", "target"),
                [(k, v["tasks"], f"{v['wall']:.2f}", f"{v['per_task_ms']:.2f}", f"{v['per_task_ms_min']:.2f}",
                  "<= 5 ms" if k.startswith("ray") else "") for k, v in results["overhead"].items()])
    print_table(f"throughput: {args.tasks} metric evaluations ({TASK}, Simulation, {args.simulations} simulations)",
                ("executor", "wall (s)", "tasks/s", "speed-up", "records = local 1"),
                [(k, f"{v['wall']:.2f}", f"{v['tasks_per_second']:.2f}", f"{v['tasks_per_second'] / base:.2f}x",
                  "-" if v["records_equal_local"] is None else str(v["records_equal_local"]))
                 for k, v in results["scaling"].items()])
    overhead = results["overhead"].get("ray, 2 nodes x 1 CPU", results["overhead"]["local, 2 workers"])
    estimate = table51_estimate(args.task_seconds, overhead["per_task_ms"] / 1000)
    results["table51_estimate_100_nodes"] = estimate
    print(f"\nTable 5.1, full protocol (8 rows x 30 plans = {estimate['tasks']} tasks of ~{args.task_seconds:.0f} s): "
          f"{estimate['cpu_hours']:.1f} CPU-hours; on 2 cores {estimate['two_core_hours']:.1f} h; on 100 nodes x 16 "
          f"CPUs ({estimate['slots']} slots) {estimate['waves']} wave, {estimate['wall_seconds'] / 60:.1f} min; "
          f"more than {estimate['scaling_stops_at_cpus']} CPUs add nothing (one task per plan)")
    results["load_average_after"] = os.getloadavg()[0]
    print(f"machine: {os.cpu_count()} CPUs, load average {results['load_average_before']:.2f} before, "
          f"{results['load_average_after']:.2f} after (other work on the machine skews the scaling)")
    if "ray_cluster_start_seconds" in results:
        print(f"loopback cluster (2 nodes) up in {results['ray_cluster_start_seconds']:.1f} s")
    write_json("executor", results)


if __name__ == "__main__":
    main()
