"""Run a bundled pipeline on a robot peer through its ROS 1 driver: the one-setting swap, end to end on one machine.

::

    python -m pliant_ros1.demo iiwa-policy            (make robot-demo)
    python -m pliant_ros1.demo baxter-policy --set planning.max_iterations=40
    python -m pliant_ros1.demo pr2-policy --seed 1

A ROS master starts on a free loopback port; the pipeline runs with ``execution.world`` set to the robot's driver,
and when that driver connects (after planning) the robot's peer (:mod:`pliant_ros1.testing.peer`) starts on the master
with its arm in the same simulator, with the same options, as the pipeline's own execution world (pybullet for the
bundled policies).  Started before planning, the peer (physics at 240 Hz, joint states at 100-250 Hz) took as much
CPU as the planner on a loaded machine (56 s against 51 s over the first 14.5 minutes of one run).  Planning is
unchanged; the policy executes closed-loop on the peer's measured joint states through the driver, the core's
command stream and safety layer.  The report is written to ``out/<pipeline>-on-<driver>/``; every command the
peer received is in ``commands.jsonl`` there, checked against the limits file at the end.

The iiwa and PR2 demos plan to a budget of work, not of wall time (:data:`BUDGETS`: belief-planner iterations, with
``max_time`` only a safety cap), so that whether they plan, and what, is the same on a quiet and on a loaded
machine (docs/plugins/ros1.md has the measurements); ``--set planning.max_iterations=N`` / ``planning.max_time=S``
change it.
"""

from __future__ import annotations

import sys
from pathlib import Path

#: the driver and peer of each bundled robot pipeline
PIPELINES = {"baxter-policy": ("baxter-ros", "baxter", "right"), "pr2-policy": ("pr2-ros", "pr2", "right"),
             "iiwa-policy": ("iiwa-ros", "iiwa", "right")}
#: the planning budget of a demo: (belief-planner iterations, max_time in s as a safety cap only).  With seed 0 both
#: find their first solution in the first iteration (its RRT-Connect), which took 29 s (iiwa) and 194 s (PR2) of
#: wall time at load 8-12 on two cores, against the pipelines' own 30 s and 45 s budgets; the iterations after it
#: add alternative routes to the policy.  baxter-policy keeps its pipeline's time budget (not measured here).
BUDGETS = {"iiwa-policy": (20, 1200.0), "pr2-policy": (10, 1800.0)}
#: the driver's stale-state watchdog in a demo (s; the limits files' 0.1 s is for the robots, whose controllers
#: publish from their own hardware).  A peer is a simulator sharing the CPU with the planner and everything else:
#: at load 12-13 on two cores, the peer's 50 Hz state records showed gaps up to 88 ms and the driver's 100 Hz
#: commands gaps up to 86 ms at the peer, and one iiwa run failed on "the newest joint state is 0.121 s old".
DEMO_STATE_TIMEOUT = 0.5


def budget_overrides(pipeline_name: str, overrides: list[str] | None = None) -> list[str]:
    """The demo's planning budget (:data:`BUDGETS`) as pipeline overrides, followed by ``overrides`` (the user's
    ``--set``, which win)."""
    budget = []
    if pipeline_name in BUDGETS:
        iterations, cap = BUDGETS[pipeline_name]
        budget = [f"planning.max_iterations={iterations}", f"planning.max_time={cap}"]
    return [*budget, *(overrides or [])]


def robot_overrides(pipeline_name: str, seed: int, user: list[str], master_uri: str, output: Path) -> list[str]:
    """The overrides of the run on the robot's peer: the budget, the robot's driver as the execution world (with
    :data:`DEMO_STATE_TIMEOUT`), then the user's ``--set`` (after the world's name, which starts its table afresh,
    so that theirs win), the master and the output folder."""
    driver, _, side = PIPELINES[pipeline_name]
    arm = [] if driver == "iiwa-ros" else [f'execution.world.side="{side}"']
    return [f"seed={seed}", *budget_overrides(pipeline_name), f"execution.world={driver}", *arm,
            f"execution.world.state_timeout={DEMO_STATE_TIMEOUT}", *user,
            f'execution.world.master_uri="{master_uri}"', f'output="{output}"']


def start_peer_on_connect(pipeline, peer) -> None:
    """Make ``pipeline``'s robot driver start ``peer`` (a :class:`~pliant_ros1.testing.process.PeerProcess`) when it
    connects, i.e. after planning, and not before."""
    from pliant.api import Driver

    make_world = pipeline.execution_world

    def execution_world(context):
        world = make_world(context)
        if isinstance(world, Driver):
            open_driver = world.open

            def open_with_peer() -> None:
                if not peer.alive():
                    print(f"starting the {peer.robot} peer", flush=True)
                    peer.start()
                open_driver()

            world.open = open_with_peer
        return world

    pipeline.execution_world = execution_world


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
    from pliant import api
    from pliant.api import RunInterrupted

    from pliant_ros1.master import RosMaster
    from pliant_ros1.testing.process import PeerProcess
    from pliant_ros1.testing.record import command_violations, read_record

    if pipeline_name not in PIPELINES:
        print(f"error: pipeline: no robot demo for {pipeline_name!r} (demos: {', '.join(PIPELINES)})",
              file=sys.stderr)
        return 2
    driver, robot, side = PIPELINES[pipeline_name]
    user = list(overrides or [])
    overrides = budget_overrides(pipeline_name, user)
    base = api.Pipeline.from_file(pipeline_name, overrides=[f"seed={seed}", *overrides])
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
    with RosMaster() as master:
        peer = PeerProcess(robot, master.uri, side=side, record=record, extra=extra)   # started by the driver
        print(f"ROS master {master.uri}; running {pipeline_name} on {driver} (the {robot} peer, {world.name}, "
              "starts when the driver connects)", flush=True)
        pipeline = api.Pipeline.from_file(pipeline_name, overrides=robot_overrides(
            pipeline_name, seed, user, master.uri, output))
        start_peer_on_connect(pipeline, peer)
        try:
            try:
                run_record = pipeline.run()
            except RunInterrupted as stopped:
                run_record = stopped.record
            limits = None if run_record.context is None else pipeline.execution_world(run_record.context).limits
        finally:
            peer.stop()
    for key, value in run_record.summary_rows():
        print(f"{key:<22}  {value}")
    received = read_record(record) if record.exists() else []      # no peer when nothing was planned
    bad = [] if limits is None else command_violations(received, limits)
    commands = sum(1 for r in received if r.get("kind") == "command")
    print(f"\ncommands received by the peer: {commands}; outside the limits: {len(bad)}")
    print(f"report: {output / 'report.md'}")
    if not run_record.outcome.success:
        print(f"{run_record.outcome.value}: {run_record.error}", file=sys.stderr)
    if bad and run_record.exit_status in (0, 3):
        return 3                                # planned, but the execution broke the limits
    return run_record.exit_status


def main(argv: list[str] | None = None) -> int:
    """``python -m pliant_ros1.demo PIPELINE [--seed N] [--set KEY=VALUE]``: ``pliant robot ros-demo``."""
    from pliant.api import cli_main

    return cli_main(["robot", "ros-demo", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
