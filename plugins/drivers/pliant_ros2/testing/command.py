"""``pliant robot ros2-peer`` / ``python -m pliant_ros2.testing``: an emulated ros2_control arm until Ctrl-C.

``pliant robot ros2-peer`` (pliant's process) re-runs itself as ``python -m pliant_ros2.testing`` in the ROS 2
environment (:func:`pliant_ros2.environment.ros2_environment`); the child is the node.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

PRESETS = {"iiwa": {"namespace": "/lbr", "joints": [f"lbr_A{i}" for i in range(1, 8)],
                    "start": [0.0, 0.3, 0.0, -1.2, 0.0, 0.6, 0.0]}}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``pliant robot ros2-peer`` and ``python -m pliant_ros2.testing``: the preset arm, its namespace,
    joints and start, the controllers, the update rate, the servo time constant, the ROS domain and the record."""
    parser.add_argument("preset", nargs="?", default="iiwa", choices=sorted(PRESETS),
                        help="the arm (iiwa: the lbr_fri_ros2_stack's /lbr, lbr_A1..lbr_A7)")
    parser.add_argument("--namespace", help="the robot's namespace (default the preset's)")
    parser.add_argument("--joints", help="comma-separated joint names (default the preset's)")
    parser.add_argument("--start", help="comma-separated start positions, rad (default the preset's)")
    parser.add_argument("--forward", default="forward_position_controller", help="the forward controller's name")
    parser.add_argument("--trajectory", default="joint_trajectory_controller", help="the trajectory controller's name")
    parser.add_argument("--rate", type=float, default=100.0, help="controller manager update rate, Hz")
    parser.add_argument("--tau", type=float, default=0.02, help="the joints' servo time constant, s")
    parser.add_argument("--domain-id", type=int, default=None, help="ROS domain id (default $ROS_DOMAIN_ID, else 0)")
    parser.add_argument("--localhost", action="store_true", help="discovery limited to this machine")
    parser.add_argument("--record", help="JSON-lines record of commands, states and faults")
    parser.add_argument("--exit-with-parent", type=int, default=None, help=argparse.SUPPRESS)


def _peer_arguments(args) -> list[str]:
    out = [args.preset, "--forward", args.forward, "--trajectory", args.trajectory, "--rate", str(args.rate),
           "--tau", str(args.tau)]
    for flag, value in (("--namespace", args.namespace), ("--joints", args.joints), ("--start", args.start),
                        ("--record", args.record), ("--exit-with-parent", args.exit_with_parent)):
        if value is not None:
            out += [flag, str(value)]
    return out


def run_from_args(args) -> int:
    """Run the peer in a child process of the ROS 2 environment (from pliant's command line)."""
    from pliant_ros2.environment import check_domain_id, python, ros2_environment

    domain = check_domain_id(args.domain_id if args.domain_id is not None else int(os.environ.get("ROS_DOMAIN_ID")
                                                                                     or 0), "--domain-id")
    env = ros2_environment(domain, localhost=args.localhost)
    try:
        if args.exit_with_parent is None:
            args.exit_with_parent = os.getpid()          # the node goes when this command goes (SIGTERM, SIGKILL)
        return subprocess.call([python(), "-m", "pliant_ros2.testing", *_peer_arguments(args)], env=env)
    except KeyboardInterrupt:
        return 130


def main(argv: list[str] | None = None) -> int:
    """``python -m pliant_ros2.testing`` (in the ROS 2 environment)."""
    from pliant_ros2.testing.peer import ControlPeer, serve

    parser = argparse.ArgumentParser(prog="python -m pliant_ros2.testing", description=__doc__)
    add_arguments(parser)
    args = parser.parse_args(argv)
    preset = PRESETS[args.preset]
    joints = args.joints.split(",") if args.joints else preset["joints"]
    start = [float(x) for x in args.start.split(",")] if args.start else preset["start"]
    if len(start) != len(joints):
        start = [0.0] * len(joints)
    peer = ControlPeer(joints, start, namespace=args.namespace if args.namespace is not None else preset["namespace"],
                       forward=args.forward, trajectory=args.trajectory, rate=args.rate, tau=args.tau,
                       record=args.record)
    try:
        serve(peer, exit_with_parent=args.exit_with_parent)
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
