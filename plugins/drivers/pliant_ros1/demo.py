"""Run a bundled pipeline on a robot peer through its ROS 1 driver: the one-setting swap, end to end on one machine.

::

    python -m pliant_ros1.demo iiwa-policy            (make robot-demo)
    python -m pliant_ros1.demo baxter-policy --set planner.max_time=180
    python -m pliant_ros1.demo pr2-policy --seed 1

A ROS master starts on a free loopback port; the robot's peer (:mod:`pliant_ros1.peer`) starts on it with its arm
in the same simulator, with the same options, as the pipeline's own execution world (pybullet for the bundled
policies); the pipeline then runs with ``execution.world`` set to the robot's driver.  Planning is unchanged; the
policy executes closed-loop on the peer's measured joint states through the driver, the core's command stream and
safety layer.  The report is written to ``out/<pipeline>-on-<driver>/``; every command the peer received is in
``commands.jsonl`` there, checked against the limits file at the end.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: the driver and peer of each bundled robot pipeline
PIPELINES = {"baxter-policy": ("baxter-ros", "baxter", "right"), "pr2-policy": ("pr2-ros", "pr2", "right"),
             "iiwa-policy": ("iiwa-ros", "iiwa", "right")}


def _toml(value) -> str:
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def run(pipeline_name: str, seed: int = 0, overrides: list[str] | None = None) -> int:
    """Run ``pipeline_name`` on its robot's peer; returns the exit status of ``pliant run`` (docs/outcomes.md): 0 the
    execution reached the goal and every command the peer received was within the limits, 1 not planned, 3 the
    execution failed (the report says what: a watchdog, a fault), got stuck, or sent a command outside the limits,
    130 interrupted.  The pipeline writes its plan, the execution so far and the report in every case."""
    import pliant
    from pliant.pipeline import RunInterrupted

    from pliant_ros1.master import RosMaster
    from pliant_ros1.peer import PeerProcess, command_violations, read_record

    if pipeline_name not in PIPELINES:
        print(f"error: pipeline: no robot demo for {pipeline_name!r} (demos: {', '.join(PIPELINES)})",
              file=sys.stderr)
        return 2
    driver, robot, side = PIPELINES[pipeline_name]
    base = pliant.Pipeline.from_file(pipeline_name, overrides=[f"seed={seed}", *(overrides or [])])
    world = base.world_spec()
    output = Path("out") / f"{pipeline_name}-on-{driver}"
    output.mkdir(parents=True, exist_ok=True)
    record = output / "commands.jsonl"
    record.unlink(missing_ok=True)
    extra = ["--simulator", world.name, "--seed", str(seed), "--speed-ratio", "1.0"]
    if world.name == "pybullet":
        extra += ["--physics-rate", "240"]
    for key, value in world.options.items():
        if key != "frequency":
            extra += ["--sim-option", f"{key}={_toml(value)}"]
    with RosMaster() as master, PeerProcess(robot, master.uri, side=side, record=record, extra=extra):
        print(f"ROS master {master.uri}; {robot} peer ({world.name}) up; running {pipeline_name} on {driver}",
              flush=True)
        arm = [] if driver == "iiwa-ros" else [f'execution.world.side="{side}"']
        pipeline = pliant.Pipeline.from_file(pipeline_name, overrides=[
            f"seed={seed}", *(overrides or []), f"execution.world={driver}", *arm,
            f'execution.world.master_uri="{master.uri}"', f'output="{output}"'])
        try:
            run_record = pipeline.run()
        except RunInterrupted as stopped:
            run_record = stopped.record
        limits = None if run_record.context is None else pipeline.execution_world(run_record.context).limits
    for key, value in run_record.summary_rows():
        print(f"{key:<22}  {value}")
    bad = [] if limits is None else command_violations(read_record(record), limits)
    commands = sum(1 for r in read_record(record) if r.get("kind") == "command")
    print(f"\ncommands received by the peer: {commands}; outside the limits: {len(bad)}")
    print(f"report: {output / 'report.md'}")
    if not run_record.outcome.success:
        print(f"{run_record.outcome.value}: {run_record.error}", file=sys.stderr)
    if bad and run_record.exit_status in (0, 3):
        return 3                                # planned, but the execution broke the limits
    return run_record.exit_status


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pliant_ros1.demo", description=__doc__.split("\n\n")[0])
    parser.add_argument("pipeline", choices=sorted(PIPELINES), help="a bundled robot pipeline")
    parser.add_argument("--seed", type=int, default=0, help="the pipeline's seed")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a pipeline override")
    args = parser.parse_args(argv)
    from pliant.errors import PliantError

    try:
        return run(args.pipeline, args.seed, args.set)
    except PliantError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
