"""Entry point of the CANopen plugin: the ``canopen`` driver and the ``pliant robot canopen-peer`` command (light
imports)."""

from __future__ import annotations

from pliant.api import Alias, Command, hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``canopen`` driver (CiA 402 joint drives over python-can)."""
    registrar.add("driver", "canopen", "pliant_canopen.driver:CanopenDriver",
                  description="CiA 402 joint drives over CANopen (python-can): SYNC, PDOs, heartbeat, EMCY")


@hookimpl
def pliant_commands():
    """``pliant robot canopen-peer``: emulated CiA 402 drives for a joint map on a CAN bus, until Ctrl-C."""
    return [Command("robot", "canopen-peer",
                    "emulate the CiA 402 joint drives of a joint map on a CAN bus (until Ctrl-C)",
                    run=_peer_command, arguments=_peer_arguments,
                    description="Start one emulated CiA 402 servo drive per joint of a joint map (default: the "
                                "bundled 7-joint KUKA iiwa example) on a python-can bus, e.g. socketcan vcan0 or "
                                "udp_multicast, so that the canopen driver of another process can connect to it.  "
                                "The virtual interface only reaches buses in the same process."),
            Alias("canopen-peer", "robot canopen-peer")]


def _peer_arguments(parser) -> None:
    parser.add_argument("--joint-map", help="joint-map TOML file (default: the bundled iiwa example)")
    parser.add_argument("--interface", default="socketcan", help="python-can interface (default socketcan)")
    parser.add_argument("--channel", default="vcan0", help="python-can channel (default vcan0)")
    parser.add_argument("--bitrate", type=int, default=1_000_000, help="bit/s (default 1000000)")
    parser.add_argument("--duration", type=float, default=None, help="seconds to run (default: until Ctrl-C)")


def _peer_command(args) -> int:
    from pliant_canopen.testing.peer import run_peer

    return run_peer(joint_map=args.joint_map, interface=args.interface, channel=args.channel,
                    bitrate=args.bitrate, duration=args.duration)
