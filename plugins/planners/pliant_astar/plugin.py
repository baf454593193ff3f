"""Entry point of the A* plugin: planners, the ``pliant experiment pareto`` command and the sweep's report figures."""

from __future__ import annotations

from pliant.api import Alias, Command, hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``astar`` planner and ``astar-pareto``, its sweep over p."""
    registrar.add("planner", "astar", "pliant_astar.planner:AStarPlanner",
                  description="exact A* over 3-D translations, f = (1-p)(g+h) + p*DEFORM (thesis Alg. 1)")
    registrar.add("planner", "astar-pareto", "pliant_astar.planner:ParetoPlanner",
                  description="sweep of A* over p: the distinct Pareto-optimal paths (thesis 3.3.1)")


@hookimpl
def pliant_report(run, directory):
    """``pareto_front.png`` and ``pareto_paths.png`` for an ``astar-pareto`` run with a Pareto front; None for any other
    run."""
    if run.result is None or run.result.planner != "astar-pareto" or not run.result.statistics.get("pareto"):
        return None
    from pliant_astar.figures import draw_pareto

    return draw_pareto(run, directory)


@hookimpl
def pliant_commands():
    """``pliant experiment pareto`` (old spelling: ``pliant pareto``): sweep A* over p on a scene and print the
    Pareto-optimal paths."""
    return [Command("experiment", "pareto", "sweep A* over p on a scene: Pareto table and figures",
                    run=_pareto_command, arguments=_pareto_arguments,
                    description="Run A* for evenly spaced values of p on a translation scene (cost model: voxel), "
                                "print the distinct Pareto-optimal paths and write the front and the path classes "
                                "as pictures."),
            Alias("pareto", "experiment pareto")]


def _pareto_arguments(parser):
    parser.add_argument("scene", help="bundled scene name or TOML file (e.g. triple-wall)")
    parser.add_argument("--variant", help="scene variant (e.g. soft-robot-soft-walls)")
    parser.add_argument("--values", type=int, default=101, help="number of p values in [0, 1] (default 101)")
    parser.add_argument("--output", help="report directory (default out/pareto-<scene>)")


def _pareto_command(args) -> int:
    from pliant.api import Pipeline

    name = f"pareto-{args.scene}" + (f"-{args.variant}" if args.variant else "")
    pipeline = Pipeline({"name": args.scene, "variant": args.variant} if args.variant else args.scene,
                        name=name, output=args.output, cost="voxel",
                        planner={"name": "astar-pareto", "values": args.values})
    record = pipeline.run()
    result = record.result
    print(f"{'p values':<14}{'length (voxels)':>16}{'deformation':>14}")
    for pt in result.statistics.get("pareto", []):
        ps = pt["p_values"]
        span = f"{min(ps):.2f}-{max(ps):.2f}"
        print(f"{span:<14}{pt['length_voxels']:>16.2f}{pt['deformation']:>14.4g}")
    print(f"\n{result.statistics.get('values_done', 0)} values of p in {result.statistics.get('time', 0):.2f} s; "
          f"report: {record.output / 'report.md'}")
    return 0 if result.solved else 1


@hookimpl
def pliant_reproductions():
    """The thesis's Figure 3.5 (``pliant experiment figure-3.5``): A* path classes on the triple-wall over p."""
    from pliant.api import Reproduction

    return [Reproduction("figure-3.5", "Figure 3.5: A* path classes on the triple-wall over p",
                         "pliant_astar.reproduce:figure_35",
                         modes={"full": "101 values of p in [0, 1], as the thesis", "quick": "the same (seconds)",
                                "ci": "21 values of p"},
                         minutes={"full": 0.1, "quick": 0.1, "ci": 0.1})]
