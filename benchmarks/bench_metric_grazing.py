"""The path metric's two estimates on a grazing path, against the Monte Carlo simulation of the same model.

A task no table uses: on se2-through-passage, the L-block goes from the start (0.2375, 0.12) up through the passage
to (0.245, 0.42), drifting 7.5 mm to the right on the way, so that it enters the passage 2.5 mm from its right edge
and, going up, grazes that edge.  In each cell the Simulation (baseline) -- the kinematic simulator run
``--simulations`` times from the start ball, an independent Monte Carlo of the model the metric bounds -- is the
reference; ``reachable-volume`` is evaluated with its default ``distribution = "propagated"`` and with the thesis's
``distribution = "uniform"`` (the density of the task's tables: 250 samples in the largest volume of the lowest
cell).  Seed 0.

    pliant bench metric_grazing [-- --quick] [-- --simulations 2000] [-- --cells 0 4 8]

Quick mode: cell (0.125, 0.125) only, 500 simulations.  Writes out/bench/metric-grazing.json.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

from pliant_reachability.evaluation import evaluate, task_density  # noqa: E402
from pliant_reachability.tasks import TASKS, MetricTask, cells  # noqa: E402

NAME = "se2-grazing-edge"


def task() -> MetricTask:
    base = TASKS["se2-through-passage"]
    return MetricTask(NAME, "se2-through-passage", ((0.2375, 0.12, 0.0), (0.245, 0.42, 0.0)), base.simulator,
                      simulations=2000, largest_volume_samples=base.largest_volume_samples, world=base.world,
                      world_options=base.world_options, metric_options=base.metric_options)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one cell, 500 simulations")
    parser.add_argument("--simulations", type=int, default=None, help="baseline runs (default 2000; quick 500)")
    parser.add_argument("--cells", type=int, nargs="*", default=None,
                        help="cells of the thesis's grid, 0-8 in the tables' order (default 1 4 8; quick 1)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    TASKS[NAME] = task()
    simulations = args.simulations or (500 if args.quick else 2000)
    chosen = args.cells if args.cells is not None else ([1] if args.quick else [1, 4, 8])
    density = task_density(TASKS[NAME])
    records, rows = [], []
    for k in chosen:
        eps, alpha = cells()[k]
        base = evaluate(NAME, "simulation", eps, alpha, args.seed, density, simulations)
        propagated = evaluate(NAME, "reachable-volume", eps, alpha, args.seed, density, simulations)
        uniform = evaluate(NAME, "reachable-volume", eps, alpha, args.seed, density, simulations,
                           distribution="uniform")
        records.append({"cell": k, "epsilon": eps, "alpha": alpha, "simulation": base, "propagated": propagated,
                        "uniform": uniform})
        rows.append((f"{eps:g}/{alpha:g}", f"{base['p_exec']:.3f}",
                     f"{propagated['p_exec']:.3f} ({propagated['p_exec'] - base['p_exec']:+.3f})",
                     f"{uniform['p_exec']:.3f} ({uniform['p_exec'] - base['p_exec']:+.3f})"))
    print_table(f"{NAME}: P_exec, Simulation (baseline, {simulations} runs) against the metric's two estimates "
                f"(error in parentheses), seed {args.seed}",
                ("eps/alpha", "simulation", "propagated (default)", "uniform (thesis)"), rows)
    write_json("metric-grazing" + ("-quick" if args.quick else ""),
               {"task": NAME, "waypoints": TASKS[NAME].waypoints, "simulations": simulations, "seed": args.seed,
                "records": records})
    return 0


if __name__ == "__main__":
    sys.exit(main())
