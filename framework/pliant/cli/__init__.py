"""The ``pliant`` command: eight top-level commands, grouped as a user thinks (docs/cli.md).

    pliant run PIPELINE [--set key=value ...] [--view]   run a pipeline file or bundled pipeline (--view: watch it)
    pliant scenes [NAME]                                 bundled scenes (and one scene's details)
    pliant plugins [--kind KIND] [--options KIND NAME]   what is installed, and each component's options
    pliant view TARGET                                   a 3-D view of a scene, a run folder or a policy (a plugin's)
    pliant experiment [list | NAME ...]                  every thesis table, figure and experiment, each in one place
    pliant learn COMMAND ...                             record and import demonstrations
    pliant robot [list | check NAME | PEER ...]          robot drivers; inspect a robot; emulated robots
    pliant bench [NAME] [-- ARGS]                        run a benchmark script from benchmarks/
    pliant bench FILE.toml [--jobs N] [--fresh] ...      run a benchmark file (planners x problems x seeds)

Plugins add sub-commands to ``experiment``, ``learn`` and ``robot`` (and provide ``view``) through the
``pliant_commands`` hook (:class:`pliant.cli.commands.Command`); an old spelling keeps working through an
:class:`~pliant.cli.commands.Alias`, with one deprecation line on stderr.  Errors in input are reported as one line
naming the file, field and value, with exit status 2.

``pliant run`` exits with its run's outcome (docs/outcomes.md): 0 planned (and, if asked, executed to the goal),
1 not planned, 2 bad input, 3 planned but the execution failed or got stuck, 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from pathlib import Path

from pliant import __version__
from pliant.cli.commands import GROUPS, PLUGIN_GROUPS, Alias, Command, add_page_arguments, load
from pliant.errors import PliantError

log = logging.getLogger(__name__)

EXAMPLES = """examples:
  pliant plugins                                 list plugins and their components
  pliant plugins --options planner straight      options of one component (units, defaults)
  pliant scenes                                  list bundled scenes
  pliant run demo                                run the bundled demo pipeline
  pliant run my.toml --set planning.max_iterations=500 --set simulator=pybullet
  pliant run demo --view                         the same, watched live in a 3-D page
  pliant experiment list                         thesis tables, figures and experiments: available or waiting
  pliant experiment figure-3.5 --quick           one of them, report in out/reproduce/figure-3.5/quick/
  pliant robot check baxter-ros --set side=right   inspect a robot (state, limits, rates)
  pliant bench                                   list the benchmarks
  pliant bench benchmarks/files/planners-triple-wall-cube-wall-maze.toml   planners x problems x seeds, from a file
"""


def _table(rows: list[tuple], header: tuple) -> str:
    rows = [tuple(str(c) for c in r) for r in rows]
    widths = [max(len(str(h)), *(len(r[i]) for r in rows)) if rows else len(str(h)) for i, h in enumerate(header)]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    lines = [fmt.format(*header), fmt.format(*("-" * w for w in widths))]
    lines += [fmt.format(*r) for r in rows]
    return "\n".join(lines)


def cmd_plugins(args) -> int:
    """``pliant plugins [--kind KIND] [--options KIND NAME]``: the plugins with their status and the components they
    register (only those of ``--kind``), or one component's description and table of options."""
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
        from pliant.components import KINDS

        if args.kind not in KINDS:
            raise PliantError(f"unknown component kind (kinds: {', '.join(KINDS)})", field="--kind", value=args.kind)
    if args.check:
        return _check_components(reg, args.kind)
    plugins = reg.plugins()
    print(_table([(p.name, p.distribution, p.status, p.error) for p in plugins],
                 ("plugin", "distribution", "status", "error")))
    print()
    entries = [e for e in reg.entries() if args.kind is None or e.kind == args.kind]
    print(_table([(e.kind, e.name, e.plugin, e.description) for e in entries],
                 ("kind", "name", "plugin", "description")))
    return 0


def _check_components(reg, kind: str | None) -> int:
    """``pliant plugins --check``: the conformance kit (:func:`pliant.testing.check_component`) on every component
    of a checked kind (only ``kind``'s), one line each as it goes, then a table; 1 when any fails.  Running each
    component's example also compiles its numba kernels into numba's cache, so that the first run does not."""
    import time

    from pliant.testing import CHECKED_KINDS, check_component

    entries = [e for e in reg.entries() if e.kind in CHECKED_KINDS and kind in (None, e.kind)]
    rows, failed = [], 0
    for k, entry in enumerate(entries, 1):
        started = time.perf_counter()
        try:
            verdict, detail = "ok", ", ".join(check_component(entry.kind, entry.name, registry=reg))
        except Exception as exc:        # a component that crashes (a TypeError...) fails its check too
            failed += 1
            verdict, detail = "FAILED", f"{type(exc).__name__}: {exc}"
        seconds = time.perf_counter() - started
        print(f"[{k}/{len(entries)}] {entry.kind} '{entry.name}' ({entry.plugin}): {verdict} in {seconds:.1f} s",
              flush=True)
        rows.append((entry.kind, entry.name, entry.plugin, verdict, detail))
    print()
    print(_table(rows, ("kind", "name", "plugin", "verdict", "checks (or what failed)")))
    print(f"\n{len(entries) - failed} of {len(entries)} components conform")
    return 1 if failed else 0


def cmd_scenes(args) -> int:
    """``pliant scenes [NAME]``: the bundled scenes and pipelines, or one scene's details (checked as ``run`` checks
    it); exit status 2 when a bundled scene is invalid."""
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
    """``pliant run PIPELINE``: run a pipeline file or bundled pipeline (with the ``--set`` overrides, ``--output`` and
    ``--view``) and print its summary; returns the run's exit status (docs/outcomes.md)."""
    from pliant.pipeline import Pipeline, RunInterrupted

    overrides = list(args.set or [])
    if args.output is not None:
        overrides.append(f"output={json.dumps(args.output)}")     # a JSON string is a TOML basic string
    pipeline = Pipeline.from_file(args.pipeline, overrides=overrides)
    view = _live_view(pipeline, args) if args.view else None
    record = None
    try:
        try:
            record = pipeline.run(on_step=view.on_step if view is not None else None)
        except RunInterrupted as stopped:
            record = stopped.record
            print_run(record)
            return record.exit_status                     # 130, with what was planned so far on file
        print_run(record)
        return record.exit_status
    finally:
        if view is not None:
            view.finish(record)                           # the finished run in the page (held as --view-hold says)


def _live_view(pipeline, args):
    """``pliant run --view``: the live view a plugin offers through the ``pliant_run_view`` hook (the first that
    answers), or a :class:`PliantError` naming ``--view`` when none does.  A plugin's input error (a bad
    ``--view-port``) is the user's error line; any other failure is a :class:`PluginError` naming ``--view``."""
    from pliant.errors import PluginError
    from pliant.registry import default_registry

    registry = default_registry()
    registry.load()
    try:
        view = registry.manager.hook.pliant_run_view(pipeline=pipeline, args=args)
    except PliantError:
        raise
    except Exception as exc:  # a plugin's bug: one error line, not a traceback
        raise PluginError(f"the live view failed: {type(exc).__name__}: {exc}", field="--view", value=True) from exc
    if view is not None:
        return view
    raise PliantError("no plugin offers a live view (the viewer plugin, pliant_viewer, is not loaded: see pliant "
                      "plugins)", field="--view", value=True)


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


def cmd_robot_list(args) -> int:
    """``pliant robot list [NAME]``: the drivers, or one driver's joints and limits (without connecting)."""
    from pliant import registry
    from pliant.pipeline import parse_override

    reg = registry.default_registry()
    if not getattr(args, "name", None):
        print(_table([(e.name, e.plugin, e.description) for e in reg.entries() if e.kind == "driver"],
                     ("driver", "plugin", "description")))
        return 0
    options = dict(parse_override(text, "--set") for text in (args.set or []))
    driver = reg.create("driver", args.name, source="--set", **options)
    print(f"driver '{args.name}': joints {', '.join(driver.joint_names())}; limits {driver.limits.source}")
    print(f"pliant robot check {args.name} connects and inspects the robot")
    return 0


def cmd_robot_check(args) -> int:
    """``pliant robot check NAME``: connect, read the robot's state and status, print them; no command is sent."""
    from pliant import registry
    from pliant.errors import DriverError, RobotDisabled
    from pliant.pipeline import parse_override

    options = dict(parse_override(text, "--set") for text in (args.set or []))
    driver = registry.default_registry().create("driver", args.name, source="--set", **options)
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
    """``pliant bench [NAME] [-- ARGS]``: list the benchmark scripts, or run ``benchmarks/bench_NAME.py`` as its own
    program; ``pliant bench FILE.toml ...``: run a benchmark file.  Returns the exit status."""
    if args.name and args.name.endswith(".toml"):     # a benchmark file: planners x problems x seeds x budgets
        from pliant.experiments.benchfile import main as bench_file

        return bench_file([args.name, *args.args])
    directory = _benchmarks_dir()
    scripts = sorted(p.stem.removeprefix("bench_") for p in directory.glob("bench_*.py"))
    if not args.name:
        print("benchmarks: " + (", ".join(scripts) or "none"))
        return 0
    if args.name not in scripts:
        raise PliantError(f"unknown benchmark (available: {', '.join(scripts)})", field="NAME", value=args.name)
    # the script runs as its own program (its own argv, sys.path and exit status), as `python benchmarks/bench_X.py`
    import subprocess

    return subprocess.run([sys.executable, str(directory / f"bench_{args.name}.py"), *args.args],
                          check=False).returncode


#: the core's old spellings (the plugins declare theirs); ``driver`` is rewritten by :func:`_driver_alias`
CORE_ALIASES = (Alias("reproduce", "experiment"),)


def _declarations() -> tuple[list[Command], list[Alias]]:
    """The plugins' commands and aliases (``pliant_commands``; a plugin whose hook raises is reported by
    ``pliant plugins`` and skipped)."""
    from pliant.registry import default_registry

    commands: list[Command] = []
    aliases: list[Alias] = list(CORE_ALIASES)
    for group in default_registry().call_isolated("pliant_commands"):
        for item in group or ():
            if isinstance(item, Command):
                commands.append(item)
            elif isinstance(item, Alias):
                words = item.old.split()
                if not words or (len(words) == 1 and words[0] in GROUPS):      # never hide `pliant run` & co.
                    log.warning("the alias %r would hide a command (skipped)", item.old)
                else:
                    aliases.append(item)
            else:
                log.warning("pliant_commands returned %r: neither a Command nor an Alias (skipped)", item)
    return commands, aliases


def _add(sub, command: Command, taken: set[str]) -> None:
    """Add one plugin command to a group's sub-parsers (a name taken, an unknown group or arguments that raise:
    logged and skipped, the other commands stay)."""
    if command.name in taken:
        log.warning("pliant %s %s is already taken (skipped the plugin's command)", command.group, command.name)
        return
    parser = sub.add_parser(command.name, help=command.help, description=command.description or command.help)
    try:
        if command.arguments is not None:
            load(command.arguments, "arguments")(parser)
    except Exception as exc:  # isolate: one plugin's broken parser must not break the command line
        log.warning("the arguments of pliant %s %s raised %s: %s (skipped)", command.group, command.name,
                    type(exc).__name__, exc)
        sub._name_parser_map.pop(command.name, None)
        sub._choices_actions[:] = [a for a in sub._choices_actions if a.dest != command.name]
        return
    taken.add(command.name)
    parser.set_defaults(handler=_runner(command))


def _runner(command: Command):
    def handler(args) -> int:
        return load(command.run)(args)

    return handler


def _add_run(sub) -> None:
    p = sub.add_parser("run", help=GROUPS["run"][0],
                       description="Run a pipeline file (or a bundled pipeline by name) and write its report.")
    p.add_argument("pipeline", help="pipeline TOML file or bundled pipeline name")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override one value, e.g. planning.max_iterations=500, simulator=pybullet, scene.variant=soft")
    p.add_argument("--output", help="report directory (default out/<pipeline name>)")
    live = p.add_argument_group("live 3-D view (a plugin's: pliant_viewer)")
    live.add_argument("--view", action="store_true",
                      help="stream the execution into a 3-D page as it happens (prints its address)")
    add_page_arguments(live, "view-", what="the live page")
    p.set_defaults(handler=cmd_run)


def _add_experiments(sub, commands: list[Command]) -> None:
    from pliant.experiments.reproduce import CATALOGUE, command, list_command, reproductions

    group = sub.add_parser("experiment", help=GROUPS["experiment"][0],
                           description="Every thesis table and figure (a reproduction: our numbers beside the "
                                       "thesis's, headline numbers checked, exit status 3 if one is out of range; "
                                       "reports in out/reproduce/NAME/MODE/) and the plugins' other experiments.  "
                                       "Without NAME: list them.")
    names = group.add_subparsers(dest="experiment", metavar="NAME")
    others = {c.name: c.help for c in commands}
    group.set_defaults(handler=list_command, experiments=others)
    names.add_parser("list", help="what exists and what waits").set_defaults(handler=list_command,
                                                                           experiments=others)
    available = reproductions()
    taken = {"list"}
    for name in dict.fromkeys([*CATALOGUE, *available]):
        reproduction = available.get(name)
        title = reproduction.title if reproduction else CATALOGUE[name][0] + " (waiting)"
        p = names.add_parser(name, help=title, description=title)
        try:
            _reproduction_arguments(p, reproduction)
        except Exception as exc:  # isolate: a plugin's broken options leave the reproduction without them
            log.warning("the options of experiment %s raised %s: %s", name, type(exc).__name__, exc)
        p.set_defaults(handler=command, name=name)
        taken.add(name)
    for c in commands:
        _add(names, c, taken)


def _reproduction_arguments(parser, reproduction) -> None:
    """The options of ``pliant experiment NAME``: the mode (``--quick`` / ``--ci``), ``--output``, ``--fresh``, the
    executor, and the reproduction's own options (their destinations kept in ``reproduction_options``)."""
    from pliant.cli.commands import add_common_arguments

    modes = reproduction.modes if reproduction is not None else {}
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="CI-sized: " + modes.get("quick", "minutes"))
    size.add_argument("--ci", action="store_true",
                      help="smaller still: " + modes.get("ci", "for reproductions whose --quick is long"))
    add_common_arguments(parser, output="out/reproduce", fresh="the records", executor=True)
    parser.set_defaults(reproduction_options=())
    if reproduction is not None and reproduction.arguments:
        before = {a.dest for a in parser._actions}
        group = parser.add_argument_group(f"options of {reproduction.name} (default: the mode's setting)")
        load(reproduction.arguments, "arguments")(group)
        parser.set_defaults(reproduction_options=tuple(a.dest for a in parser._actions if a.dest not in before))


def _add_robot(sub, commands: list[Command]) -> None:
    group = sub.add_parser("robot", help=GROUPS["robot"][0],
                           description="Robot drivers: list them, inspect a robot without moving it, and the "
                                       "plugins' emulated robots (peers) for demos and tests.")
    names = group.add_subparsers(dest="robot", metavar="COMMAND")
    group.set_defaults(handler=cmd_robot_list)
    p = names.add_parser("list", help="the robot drivers, or one driver's joints and limits (no connection)")
    p.add_argument("name", nargs="?", help="a driver name")
    p.add_argument("--set", action="append", metavar="OPTION=VALUE", help="a driver option, e.g. side=left")
    p.set_defaults(handler=cmd_robot_list)
    p = names.add_parser("check", help="connect to a robot and inspect it (state, limits, rates; no command sent)",
                         description="Inspect a robot through its driver without moving it: connect, read its joint "
                                     "states and status, print state, limits and rates; any problem is one line and "
                                     "exit status 2.")
    p.add_argument("name", help="driver name (pliant robot list names them)")
    p.add_argument("--enable", action="store_true", help="enable a disabled robot (its motors hold)")
    p.add_argument("--set", action="append", metavar="OPTION=VALUE",
                   help="a driver option, e.g. side=left or master_uri=http://127.0.0.1:11311")
    p.set_defaults(handler=cmd_robot_check)
    taken = {"list", "check"}
    for c in commands:
        _add(names, c, taken)


def _add_group(sub, name: str, commands: list[Command]) -> None:
    """A group whose sub-commands all come from plugins (``learn``)."""
    group = sub.add_parser(name, help=GROUPS[name][0], description=GROUPS[name][0])
    names = group.add_subparsers(dest=name, metavar="COMMAND")
    group.set_defaults(handler=lambda args: _no_subcommand(group, name, commands))
    taken: set[str] = set()
    for c in commands:
        _add(names, c, taken)


def _no_subcommand(parser, name: str, commands: list[Command]) -> int:
    parser.print_help()
    if not commands:
        print(f"\nno installed plugin adds a command to pliant {name} (see pliant plugins)")
    return 0


def _add_view(sub, commands: list[Command]) -> None:
    """``pliant view``: the one command of that name a plugin provides, or a stand-in saying none does."""
    for c in commands:
        _add(sub, c, set())
        if "view" in sub.choices:
            return
    p = sub.add_parser("view", help=GROUPS["view"][0] + " (needs the pliant_viewer plugin)")
    p.add_argument("args", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    p.set_defaults(handler=_no_view)


def _no_view(args) -> int:
    raise PliantError("no plugin provides it (the viewer plugin, pliant_viewer, is not loaded: see pliant plugins)",
                      field="pliant view", value=" ".join(args.args) or None)


def build_parser(declarations: tuple[list[Command], list[Alias]] | None = None) -> argparse.ArgumentParser:
    """The ``pliant`` parser: the core's commands and groups, and the plugins' commands in them (``declarations``:
    what :func:`_declarations` returned, asked again if None)."""
    parser = argparse.ArgumentParser(
        prog="pliant", description="Plan and execute robot motion where contact, deformation and uncertainty matter.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"pliant {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv for debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    commands, _ = declarations if declarations is not None else _declarations()
    by_group: dict[str, list[Command]] = {g: [] for g in PLUGIN_GROUPS}
    for c in commands:
        if c.group not in by_group or (c.group == "view") != (c.name == "view"):
            log.warning("pliant %s %s: a plugin adds commands to %s only (skipped)", c.group, c.name,
                        ", ".join(PLUGIN_GROUPS))
            continue
        by_group[c.group].append(c)

    _add_run(sub)

    p = sub.add_parser("scenes", help=GROUPS["scenes"][0])
    p.add_argument("name", nargs="?", help="a scene name or TOML file to describe")
    p.set_defaults(handler=cmd_scenes)

    p = sub.add_parser("plugins", help=GROUPS["plugins"][0])
    p.add_argument("--kind", help="only components of this kind")
    p.add_argument("--options", nargs=2, metavar=("KIND", "NAME"), help="show one component's options")
    p.add_argument("--check", action="store_true",
                   help="run the conformance kit on every component (of --kind); exit 1 if one fails. Also compiles "
                        "and caches their numba kernels (make does this once)")
    p.set_defaults(handler=cmd_plugins)

    _add_view(sub, by_group["view"])
    _add_experiments(sub, by_group["experiment"])
    _add_group(sub, "learn", by_group["learn"])
    _add_robot(sub, by_group["robot"])

    p = sub.add_parser("bench", help=GROUPS["bench"][0])
    p.add_argument("name", nargs="?", help="benchmark name (omit to list them), or a benchmark file FILE.toml "
                   "(docs/benchmarking.md; pliant bench FILE.toml --help)")
    p.add_argument("args", nargs=argparse.REMAINDER, help="arguments passed to the benchmark")
    p.set_defaults(handler=cmd_bench)
    return parser


def _driver_alias(words: list[str]) -> list[str]:
    """``driver [NAME] [--check] ...`` (before 0.x): ``robot check NAME ...`` with --check, else ``robot list``."""
    rest = words[1:]
    if "--check" in rest:
        rest.remove("--check")
        return ["robot", "check", *rest]
    return ["robot", "list", *[w for w in rest if w != "--enable"]]


def rewrite(argv: list[str], aliases: list[Alias]) -> tuple[list[str], str | None]:
    """``argv`` with an old spelling replaced by the new one, and the deprecation line to print (None: not old).
    Leading options (``-v``) stay in front; the longest matching alias wins."""
    lead = 0
    while lead < len(argv) and argv[lead].startswith("-") and argv[lead] not in ("--", "-"):
        lead += 1
    head, words = argv[:lead], argv[lead:]
    if not words:
        return argv, None
    if words[0] == "driver":
        new = _driver_alias(words)
        old_words, new_words = words[:1], new[:2]
        rest = new[2:]
    else:
        best = None
        for alias in aliases:
            old = alias.old.split()
            if words[:len(old)] == old and (best is None or len(old) > len(best.old.split())):
                best = alias
        if best is None:
            if words[0] == "experiment" and len(words) > 1 and words[1] == "LIST":
                return [*head, "experiment", "list", *words[2:]], None
            return argv, None
        old_words, new_words = best.old.split(), best.new.split()
        rest = words[len(old_words):]
        if new_words == ["experiment"] and rest[:1] == ["LIST"]:
            rest = ["list", *rest[1:]]
    note = f"pliant {' '.join(old_words)} is deprecated: use pliant {' '.join(new_words)}"
    return [*head, *new_words, *rest], note


def main(argv: list[str] | None = None) -> int:
    """The ``pliant`` command: run ``argv`` (default ``sys.argv[1:]``; an old spelling is rewritten, with a deprecation
    line on stderr) and return its exit status (an input error: one line on stderr, status 2 unless the error gives
    another; Ctrl-C or SIGTERM: 130)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    declarations = _declarations()
    argv, note = rewrite(argv, declarations[1])
    if note:
        print(note, file=sys.stderr)
    parser = build_parser(declarations)
    args = parser.parse_args(argv)
    logging.basicConfig(level=[logging.WARNING, logging.INFO, logging.DEBUG][min(args.verbose, 2)],
                        format="%(levelname)s %(name)s: %(message)s")
    if not getattr(args, "handler", None):
        parser.print_help()
        return 0
    from pliant.termination import interrupted_by, sigterm_as_interrupt

    try:
        from pliant.experiments.executor import from_args, pin_threads, using
        from pliant.files import check_path_name

        pin_threads(1)          # BLAS on one thread unless the user sized it (OPENBLAS_NUM_THREADS, ...)

        if isinstance(getattr(args, "output", None), str):      # any command's --output: "" is not "here"
            check_path_name(args.output, "--output")
        # a command given add_executor_arguments: its tasks run with the executor asked for (--executor ray);
        # SIGTERM stops any command as Ctrl-C does (a background job ignores SIGINT)
        executor = from_args(args) if hasattr(args, "executor") else None
        with sigterm_as_interrupt(), using(executor):
            return int(args.handler(args) or 0)
    except PliantError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return int(getattr(exc, "exit_status", 2))      # 2: bad input; an experiment's failed tasks: 3 (failed)
    except KeyboardInterrupt:
        print("interrupted (SIGTERM)" if interrupted_by() == "SIGTERM" else "interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:       # `pliant plugins | head`: the reader left; say nothing more
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
