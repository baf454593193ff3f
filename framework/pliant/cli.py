"""The ``pliant`` command.

    pliant plugins [--kind KIND] [--options KIND NAME]   what is installed, and each component's options
    pliant scenes [NAME]                                 bundled scenes (and one scene's details)
    pliant run PIPELINE [--set key=value ...]            run a pipeline file or bundled pipeline
    pliant driver [NAME --check] [--set option=value]    robot drivers; inspect a robot without moving it
    pliant bench [NAME] [-- ARGS]                        run a benchmark script from benchmarks/
    pliant reproduce [LIST | NAME] [--quick | --ci]      reproduce a thesis table or figure, with its report

Plugins add their own sub-commands through the ``pliant_add_commands`` hook.  Errors in input are
reported as one line naming the file, field and value, with exit status 2.

``pliant run`` exits with its run's outcome (docs/outcomes.md): 0 planned (and, if asked, executed to the goal),
1 not planned, 2 bad input, 3 planned but the execution failed or got stuck, 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import runpy
import sys
from pathlib import Path

from pliant import __version__
from pliant.errors import PliantError

EXAMPLES = """examples:
  pliant plugins                                 list plugins and their components
  pliant plugins --options planner straight      options of one component (units, defaults)
  pliant scenes                                  list bundled scenes
  pliant run demo                                run the bundled demo pipeline
  pliant run my.toml --set planner.max_time=5 --set simulator=pybullet
  pliant driver baxter-ros --check --set side=right   inspect a robot (state, limits, rates)
  pliant bench                                   list the benchmarks
  pliant reproduce list                          thesis tables and figures: available or waiting
  pliant reproduce figure-3.5 --quick            one of them, report in out/reproduce/figure-3.5/quick/
"""


def _table(rows: list[tuple], header: tuple) -> str:
    rows = [tuple(str(c) for c in r) for r in rows]
    widths = [max(len(str(h)), *(len(r[i]) for r in rows)) if rows else len(str(h)) for i, h in enumerate(header)]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    lines = [fmt.format(*header), fmt.format(*("-" * w for w in widths))]
    lines += [fmt.format(*r) for r in rows]
    return "\n".join(lines)


def cmd_plugins(args) -> int:
    from pliant import registry
    from pliant.options import describe_options

    reg = registry.default_registry()
    if args.options:
        kind, name = args.options
        entry = reg.entry(kind, name)
        cls = entry.load()
        print(f"{kind} '{name}' from plugin '{entry.plugin}': {entry.description}")
        doc = (cls.__doc__ or "").strip()
        if doc:
            print("\n" + doc + "\n")
        opts = getattr(cls, "Options", None)
        rows = []
        for row in describe_options(opts) if opts is not None else []:
            rng = ""
            if row["minimum"] is not None or row["maximum"] is not None:
                rng = f"[{row['minimum'] if row['minimum'] is not None else '-inf'}, " \
                      f"{row['maximum'] if row['maximum'] is not None else 'inf'}]"
            if row["choices"]:
                rng = "|".join(map(str, row["choices"]))
            rows.append((row["name"], row["type"], row["default"], rng, row["doc"]))
        print(_table(rows, ("option", "type", "default", "range", "meaning")) if rows else "(no options)")
        return 0
    if args.kind is not None:
        from pliant.interfaces import KINDS

        if args.kind not in KINDS:
            raise PliantError(f"unknown component kind (kinds: {', '.join(KINDS)})", field="--kind", value=args.kind)
    plugins = reg.plugins()
    print(_table([(p.name, p.distribution, p.status, p.error) for p in plugins],
                 ("plugin", "distribution", "status", "error")))
    print()
    entries = [e for e in reg.entries() if args.kind is None or e.kind == args.kind]
    print(_table([(e.kind, e.name, e.plugin, e.description) for e in entries],
                 ("kind", "name", "plugin", "description")))
    return 0


def cmd_scenes(args) -> int:
    from pliant.pipeline import available_pipelines, check_scene
    from pliant.scene import available_scenes, load_scene

    if args.name:
        scene = check_scene(args.name)      # as `run` would check it (variants, robot model), without planning
        print(f"{scene.name}: {scene.description}")
        print(f"  file        {scene.source}")
        print(f"  bounds      {scene.lower.tolist()} .. {scene.upper.tolist()} m, resolution {scene.resolution} m,"
              f" grid {scene.shape}")
        print(f"  robot       {scene.robot.kind} '{scene.robot.name}'"
              + (f" in {scene.robot.space}" if scene.robot.space else f" model {scene.robot.model}"))
        objects = [o.name + (f" (movable, {o.mass:g} kg)" if o.movable else "") for o in scene.objects]
        print(f"  objects     {', '.join(objects) or 'none'}")
        print(f"  regions     {len(scene.regions)}")
        print(f"  start       {scene.start.tolist()}")
        print(f"  goal        {scene.goal.tolist()}")
        print(f"  variants    {', '.join(scene.variants) or 'none'}")
        return 0
    rows = []
    invalid = 0
    for name in available_scenes():
        try:
            s = load_scene(name)
            rows.append((name, ",".join(s.variants) or "-", s.description))
        except PliantError as exc:
            invalid += 1
            rows.append((name, "?", f"INVALID: {exc}"))
    print(_table(rows, ("scene", "variants", "description")))
    print("\npipelines: " + (", ".join(available_pipelines()) or "none"))
    if invalid:
        print(f"error: {invalid} scene(s) invalid (see above)", file=sys.stderr)
        return 2
    return 0


def cmd_run(args) -> int:
    from pliant.pipeline import Pipeline, RunInterrupted

    overrides = list(args.set or [])
    if args.output is not None:
        overrides.append(f"output={json.dumps(args.output)}")     # a JSON string is a TOML basic string
    pipeline = Pipeline.from_file(args.pipeline, overrides=overrides)
    try:
        record = pipeline.run(on_step=getattr(args, "on_step", None))     # a plugin's listener (pliant run --view)
    except RunInterrupted as stopped:
        print_run(stopped.record)
        return stopped.record.exit_status                 # 130, with what was planned so far on file
    print_run(record)
    return record.exit_status


def print_run(record) -> None:
    """Print a run's summary table, where its report is, and (unless it planned / reached) one line on stderr saying
    why (``record``: a :class:`~pliant.pipeline.RunRecord`)."""
    rows = record.summary_rows()
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")
    report = record.output / "report.md"
    print(f"\nreport: {report}" if report in record.files else "\nnothing written", flush=True)
    if not record.outcome.success:
        print(f"{record.outcome.value}: {record.error} (exit status {record.exit_status})", file=sys.stderr)


def cmd_driver(args) -> int:
    from pliant import registry
    from pliant.errors import DriverError, RobotDisabled
    from pliant.pipeline import parse_override

    reg = registry.default_registry()
    if not args.name:
        print(_table([(e.name, e.plugin, e.description) for e in reg.entries() if e.kind == "driver"],
                     ("driver", "plugin", "description")))
        return 0
    options = dict(parse_override(text, "--set") for text in (args.set or []))
    driver = reg.create("driver", args.name, source="--set", **options)
    if not args.check:
        print(f"driver '{args.name}': joints {', '.join(driver.joint_names())}; limits {driver.limits.source}")
        print("add --check to connect and inspect the robot")
        return 0
    try:
        report = driver.check(enable=args.enable)
    except DriverError as exc:
        if getattr(exc, "report", None):
            _print_report(args.name, exc.report)
        if not args.enable and isinstance(exc, RobotDisabled):
            print(f"error: {exc} (--enable enables it)", file=sys.stderr)
            return 2
        raise
    _print_report(args.name, report)
    print("\nok: the robot answers, its joints match, it is ready")
    return 0


def _print_report(name: str, report: dict) -> None:
    status = "enabled" if report["enabled"] else "DISABLED"
    status += ", E-STOP" if report["estop"] else ""
    status += f", fault: {report['fault']}" if report["fault"] else ""
    status += f", LOST: {report['lost']}" if report["lost"] else ""
    print(f"{name}: {status}{' (' + report['detail'] + ')' if report['detail'] else ''}")
    timeout = report["command_timeout"]
    print(f"  command rate {report['command_rate']:g} Hz; joint states measured at {report['measured_state_rate']:.1f}"
          f" Hz; robot command timeout {'none' if timeout is None else f'{timeout:g} s'}; state watchdog "
          f"{report['state_timeout']:g} s")
    rows = [(n, f"{p:+.4f}", f"{v:+.4f}", *limits[1:]) for n, p, v, limits in
            zip(report["joints"], report["positions"], report["velocities"], report["limits"])]
    print(_table(rows, ("joint", "position", "velocity", "lower", "upper", "vel max", "acc max", "jerk max")))
    print("limits from: " + "; ".join(report["sources"]))


def _benchmarks_dir() -> Path:
    env = os.environ.get("PLIANT_BENCHMARKS")
    candidates = [Path(env)] if env else []
    candidates += [Path.cwd() / "benchmarks", Path(__file__).resolve().parents[2] / "benchmarks"]
    for c in candidates:
        if c.is_dir():
            return c
    raise PliantError("no benchmarks directory found (run from a pliant checkout or set PLIANT_BENCHMARKS)",
                      field="PLIANT_BENCHMARKS", value=env)


def cmd_bench(args) -> int:
    directory = _benchmarks_dir()
    scripts = sorted(p.stem.removeprefix("bench_") for p in directory.glob("bench_*.py"))
    if not args.name:
        print("benchmarks: " + (", ".join(scripts) or "none"))
        return 0
    if args.name not in scripts:
        raise PliantError(f"unknown benchmark (available: {', '.join(scripts)})", field="NAME", value=args.name)
    sys.argv = [f"bench_{args.name}.py", *args.args]
    runpy.run_path(str(directory / f"bench_{args.name}.py"), run_name="__main__")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pliant", description="Plan and execute robot motion where contact, deformation and uncertainty matter.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"pliant {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv for debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("plugins", help="list plugins, components and their options")
    p.add_argument("--kind", help="only components of this kind")
    p.add_argument("--options", nargs=2, metavar=("KIND", "NAME"), help="show one component's options")
    p.set_defaults(handler=cmd_plugins)

    p = sub.add_parser("scenes", help="list bundled scenes, or describe one")
    p.add_argument("name", nargs="?", help="a scene name or TOML file to describe")
    p.set_defaults(handler=cmd_scenes)

    p = sub.add_parser("run", help="run a pipeline and write its report",
                       description="Run a pipeline file (or a bundled pipeline by name) and write its report.")
    p.add_argument("pipeline", help="pipeline TOML file or bundled pipeline name")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override one value, e.g. planner.max_time=5, simulator=pybullet, scene.variant=soft")
    p.add_argument("--output", help="report directory (default out/<pipeline name>)")
    p.set_defaults(handler=cmd_run)

    p = sub.add_parser("driver", help="list robot drivers, or inspect a robot (--check)",
                       description="Inspect a robot through its driver without moving it: connect, read its joint "
                                   "states and status, print state, limits and rates; any problem is one line and "
                                   "exit status 2.")
    p.add_argument("name", nargs="?", help="driver name (pliant driver lists them)")
    p.add_argument("--check", action="store_true", help="connect and inspect the robot (no command is sent)")
    p.add_argument("--enable", action="store_true", help="with --check: enable a disabled robot (its motors hold)")
    p.add_argument("--set", action="append", metavar="OPTION=VALUE",
                   help="a driver option, e.g. side=left or master_uri=http://127.0.0.1:11311")
    p.set_defaults(handler=cmd_driver)

    p = sub.add_parser("bench", help="run a benchmark script (prints a table, writes JSON)")
    p.add_argument("name", nargs="?", help="benchmark name; omit to list them")
    p.add_argument("args", nargs=argparse.REMAINDER, help="arguments passed to the benchmark")
    p.set_defaults(handler=cmd_bench)

    from pliant.experiments.reproduce import add_command as add_reproduce

    add_reproduce(sub)

    from pliant.registry import default_registry

    # each plugin's commands are added on their own: one that raises is reported (`pliant plugins`) and skipped,
    # the core's and the other plugins' commands stay
    default_registry().call_isolated("pliant_add_commands", subparsers=sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=[logging.WARNING, logging.INFO, logging.DEBUG][min(args.verbose, 2)],
                        format="%(levelname)s %(name)s: %(message)s")
    if not getattr(args, "handler", None):
        parser.print_help()
        return 0
    try:
        from pliant.experiments.executor import from_args, using
        from pliant.files import check_path_name

        if isinstance(getattr(args, "output", None), str):      # any command's --output: "" is not "here"
            check_path_name(args.output, "--output")
        # a command given add_executor_arguments: its tasks run with the executor asked for (--executor ray)
        executor = from_args(args) if hasattr(args, "executor") else None
        with using(executor):
            return int(args.handler(args) or 0)
    except PliantError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:       # `pliant plugins | head`: the reader left; say nothing more
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
