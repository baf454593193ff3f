"""Entry point of the ROS 2 plugin: the ``ros2-control`` and ``iiwa-ros2`` drivers and the ``pliant robot ros2-peer``
and ``pliant robot ros2-graph`` commands.  Light: nothing of ROS 2 is imported (its node runs in a child process)."""

from __future__ import annotations

from pliant.api import Command, hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the two ROS 2 drivers."""
    registrar.add("driver", "ros2-control", "pliant_ros2.driver:Ros2ControlDriver",
                  description="an arm under ros2_control (ROS 2): Float64MultiArray to a forward position controller "
                              "or JointTrajectory to a joint_trajectory_controller, JointState from the broadcaster")
    registrar.add("driver", "iiwa-ros2", "pliant_ros2.driver:IiwaRos2Driver",
                  description="a KUKA LBR iiwa 7 R800 under the lbr_fri_ros2_stack (ROS 2): /lbr, lbr_A1..lbr_A7, "
                              "forward_position_controller, joint_trajectory_controller")


@hookimpl
def pliant_commands():
    """``pliant robot ros2-peer`` (an emulated ros2_control arm) and ``pliant robot ros2-graph`` (what a ROS 2
    driver finds on the graph)."""
    return [Command("robot", "ros2-peer", "emulate an arm under ros2_control (ROS 2) moving a simulated arm",
                    run="pliant_ros2.testing.command:run_from_args",
                    arguments="pliant_ros2.testing.command:add_arguments",
                    description="Run a ROS 2 node that behaves as ros2_control with a forward position controller, a "
                                "joint trajectory controller and a joint state broadcaster, moving a simulated arm, "
                                "until Ctrl-C (docs/plugins/ros2.md).  Needs the ROS 2 wheels (make install)."),
            Command("robot", "ros2-graph", "what a ROS 2 driver finds on the graph: controllers' topics, types, "
                    "publishers and subscribers, joint names, state rate",
                    run=_graph_command, arguments=_graph_arguments,
                    description="Start the driver's ROS 2 node (no command is sent), look at the graph for a second "
                                "and print the controllers' topics, the joint names the states carry and their rate.  "
                                "pliant robot check NAME (pliant driver NAME --check) then checks the states against "
                                "the limits.")]


def _graph_arguments(parser) -> None:
    parser.add_argument("name", nargs="?", default="ros2-control", help="the driver (ros2-control, iiwa-ros2)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a driver option, e.g. namespace=/lbr or domain_id=7")
    parser.add_argument("--duration", type=float, default=1.0, help="seconds to listen to the states")


def _graph_command(args) -> int:
    from pliant_ros2.check import run

    return run(args.name, args.set, args.duration)
