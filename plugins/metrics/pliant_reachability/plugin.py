"""Entry point of the reachable-volume path-quality metrics (thesis ch. 6)."""

from pliant.api import Alias, Command, add_common_arguments, hookimpl

_MODULE = "pliant_reachability.metrics"


@hookimpl
def pliant_register(registrar):
    """Register the four path-quality metrics: ``reachable-volume``, ``sampling-driven``, ``simulation`` and
    ``simulation-scaled``."""
    registrar.add("metric", "reachable-volume", f"{_MODULE}:ReachableVolumeMetric",
                  description="P_exec of a path from reachable-volume sampling and sample images (thesis 6.4)")
    registrar.add("metric", "sampling-driven", f"{_MODULE}:SamplingDrivenMetric",
                  description="P_exec simulated only past the last reachable volume with a stuck sample (thesis 6.5)")
    registrar.add("metric", "simulation", f"{_MODULE}:SimulationMetric",
                  description="P_exec from many kinematic-simulator executions (thesis 6.5's Simulation baseline)")
    registrar.add("metric", "simulation-scaled", f"{_MODULE}:ScaledSimulationMetric",
                  description="P_exec from as many executions as the largest reachable volume has samples (6.5)")


@hookimpl
def pliant_commands():
    """``pliant experiment metric-tables`` (the grid of every ch. 6 metric on chosen tasks; the thesis's Tables
    6.1-6.4 are ``pliant experiment table-6.1`` ...) and ``pliant experiment metric-select``."""
    return [Command("experiment", "metric-tables",
                    "the path-quality metrics in every cell of the thesis's grid, on chosen tasks",
                    run=_table_command, arguments=_table_arguments,
                    description="Evaluate every ch. 6 metric --runs times in every cell (epsilon_reached, alpha) of "
                                "each task; evaluations are written as they finish and resumed on a second call; "
                                "tables.md, summary.json and a figure per task are written beside them.  The "
                                "thesis's Tables 6.1-6.4, checked against its numbers, are pliant experiment "
                                "table-6.1 ... table-6.4."),
            Command("experiment", "metric-select",
                    "plan candidate paths, score them with the metric, execute the best and the worst",
                    run=_select_command, arguments=_select_arguments,
                    description="Run the pipeline's planner with seeds 0..N-1, score every path with the pipeline's "
                                "metric, execute the best and the worst (or all) in the pipeline's execution world, "
                                "and report whether the metric's choice matched execution success (verdict: matched, "
                                "reversed, metric does not separate, execution does not separate)."),
            Alias("metric-table", "experiment metric-tables"),
            Alias("metric-select", "experiment metric-select")]


def _table_arguments(parser):
    # the default is the thesis's two tasks (pliant_reachability.tasks.THESIS_TASKS), unchanged: runs on file resume
    parser.add_argument("tasks", nargs="*", default=["se3-peg-tight", "se2-through-passage"],
                        help="se3-peg-tight, se2-through-passage and/or se3-peg-in-hole (ours: no thesis numbers) "
                             "(default: the thesis's two, se3-peg-tight and se2-through-passage)")
    parser.add_argument("--runs", type=int, default=30, help="evaluations per method and cell (default 30)")
    parser.add_argument("--methods", nargs="*", help="methods to run (default all four)")
    add_common_arguments(parser, jobs="evaluations", quick="2 runs, 500 / 300 baseline simulations",
                         fresh="the evaluations of these tasks", output="out",
                         overrides="a metric option for every method (e.g. contact_horizon=12)", executor=True)


def _select_arguments(parser):
    parser.add_argument("pipeline", help="a pipeline with a planner, a metric, a controller and an execution world")
    parser.add_argument("--candidates", type=int, default=8, help="candidate paths (default 8)")
    parser.add_argument("--executions", type=int, default=30, help="executions per executed candidate (default 30)")
    parser.add_argument("--all", action="store_true", help="execute every candidate, not only the best and worst")
    add_common_arguments(parser, output="out", overrides="pipeline override")


def _table_command(args) -> int:
    from pathlib import Path

    from pliant.api import build_options, parse_override

    from pliant_reachability.metrics import ReachabilityOptions
    from pliant_reachability.tables import QUICK, run_tables

    options = dict(parse_override(item, "--set") for item in args.set)
    build_options(ReachabilityOptions, options, source="--set", prefix="metric")     # unknown or bad: an error now
    runs = QUICK["runs"] if args.quick and args.runs == 30 else args.runs
    run_tables(args.tasks, runs=runs, jobs=args.jobs, output=Path(args.output), fresh=args.fresh, quick=args.quick,
               methods=args.methods, options=options)
    directory = Path(args.output) / ("metric-tables-quick" if args.quick else "metric-tables")
    print((directory / "tables.md").read_text())
    print(f"written: {directory}/runs.jsonl, summary.json, tables.md and a figure per task")
    return 0


def _select_command(args) -> int:
    from pliant_reachability.selection import render, select

    report = select(args.pipeline, candidates=args.candidates, executions=args.executions, execute_all=args.all,
                    overrides=args.set, output=args.output)
    print(render(report))
    return 0


@hookimpl
def pliant_reproductions():
    """The thesis's Tables 6.1-6.4 (``pliant experiment table-6.1`` ... ``table-6.4``)."""
    from pliant_reachability.reproduce import declarations

    return declarations()
