"""The peer's command line: ``python -m pliant_ros1.testing ROBOT ...`` and ``pliant ros-peer ROBOT ...``."""

from __future__ import annotations

import argparse
import gc
import os
import sys
from typing import Any

from pliant_ros1.robots import ROBOTS, SIDES
from pliant_ros1.testing import peer
from pliant_ros1.testing.emulator import SIMULATORS
from pliant_ros1.testing.peer import DEFAULT_FAULT_TOPIC, READY, RobotPeer


def _option_value(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` with VALUE read as a TOML value when it is one (``[0.5, 1.0]``, ``"proportional"``, ``true``,
    ``2.5``), else as the text itself (``proportional``)."""
    import tomllib

    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    key, value = (part.strip() for part in text.split("=", 1))
    try:
        return key, tomllib.loads(f"value = {value}")["value"]
    except tomllib.TOMLDecodeError:
        return key, value


def add_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The peer's command-line arguments (``python -m pliant_ros1.testing`` and ``pliant ros-peer``)."""
    parser.add_argument("robot", choices=ROBOTS, help="which robot's controller to emulate")
    parser.add_argument("--side", choices=SIDES, default="right", help="the arm (PR2, Baxter; default right)")
    parser.add_argument("--master", default=None,
                        help="ROS master URI (default $ROS_MASTER_URI, else http://127.0.0.1:11311)")
    parser.add_argument("--scene", default=None, help="scene name or file (default: the robot's: baxter-reach, "
                        "iiwa-shelf, the plugin's pr2-arm)")
    parser.add_argument("--simulator", choices=SIMULATORS, default="kinematic",
                        help="what moves the arm (default kinematic; none: an ideal servo, no contact)")
    parser.add_argument("--sim-option", action="append", type=_option_value, default=[], metavar="KEY=VALUE",
                        help="a simulator option (repeatable), e.g. self_collision=true")
    parser.add_argument("--physics-rate", type=float, default=500.0, help="physics ticks per second (default 500)")
    parser.add_argument("--state-rate", type=float, default=None, help="joint states per second (default: the "
                        "robot's: Baxter and PR2 100, iiwa 250)")
    parser.add_argument("--flood-rate", type=float, default=10000.0,
                        help="joint states per second during the flood fault (default 10000)")
    parser.add_argument("--record", default=None, help="append every command received (JSON lines) to this file")
    parser.add_argument("--start", default=None, help="initial joint positions, comma-separated (rad)")
    parser.add_argument("--limits", default=None, help="limits file (default the plugin's for the robot)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the simulator's noise and the shuffles")
    parser.add_argument("--enabled", action="store_true", help="Baxter: start enabled (the real robot starts "
                        "disabled)")
    parser.add_argument("--speed-ratio", type=float, default=0.3, help="Baxter: initial position-mode speed "
                        "ratio (default 0.3, as the real robot)")
    parser.add_argument("--fault-topic", default=DEFAULT_FAULT_TOPIC, help="where fault switches arrive "
                        f"(std_msgs/String; default {DEFAULT_FAULT_TOPIC})")
    parser.add_argument("--duration", type=float, default=None, help="seconds to run (default: until Ctrl-C)")
    parser.add_argument("--exit-with-parent", type=int, default=None, metavar="PID",
                        help="stop when the process PID is no longer this one's parent (PeerProcess passes its own)")
    return parser


def run_from_args(args: argparse.Namespace) -> int:
    """Start a peer from parsed arguments, print the ready line, run until told to stop."""
    start = None if args.start is None else [float(x) for x in args.start.split(",") if x.strip()]
    peer = RobotPeer(args.robot, args.side, master_uri=args.master, scene=args.scene, simulator=args.simulator,
                     simulator_options=dict(args.sim_option), physics_rate=args.physics_rate,
                     state_rate=args.state_rate, record=args.record, start=start, limits=args.limits,
                     seed=args.seed, enabled=args.enabled, speed_ratio=args.speed_ratio,
                     fault_topic=args.fault_topic, flood_rate=args.flood_rate)
    peer.start()
    # this process is the robot's controller and nothing else: its threads (physics, joint states at 100-250 Hz)
    # keep their timing better with the heap of the simulator's setup frozen (later collections walk only what
    # running allocates) and a 1 ms thread switch interval, as the drivers' command stream does (pliant.hardware)
    gc.freeze()
    sys.setswitchinterval(0.001)
    print(f"{READY} {args.robot} {peer.side if args.robot != 'iiwa' else ''} on {peer.master_uri}: state "
          f"{peer.spec.state_topic}, commands {peer.spec.command_topic}, faults {peer.fault_topic}", flush=True)
    peer.run(args.duration, parent=args.exit_with_parent)
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m pliant_ros1.testing``."""
    from pliant.api import PliantError

    parser = add_arguments(argparse.ArgumentParser(prog="python -m pliant_ros1.testing",
                                                   description=peer.__doc__.split("\n\n")[0],
                                                   formatter_class=argparse.RawDescriptionHelpFormatter))
    args = parser.parse_args(argv)
    try:
        code = run_from_args(args)
    except PliantError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    # the peer's topics are unregistered already; rospy's own shutdown would take another 0.6 s
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)

