"""Entry point of the ROS 1 plugin: the ``pr2-ros``, ``baxter-ros`` and ``iiwa-ros`` drivers and the
``pliant robot ros-peer`` and ``pliant robot ros-demo`` commands.  Light: rospy and the drivers are imported only when
a component is created."""

from __future__ import annotations

from pliant.api import Alias, Command, hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the three ROS 1 drivers."""
    registrar.add("driver", "pr2-ros", "pliant_ros1.pr2:Pr2Driver",
                  description="a PR2 arm over ROS 1: JointTrajectory to /<r|l>_arm_controller/command, /joint_states")
    registrar.add("driver", "baxter-ros", "pliant_ros1.baxter:BaxterDriver",
                  description="a Baxter arm over ROS 1: JointCommand (position mode) to "
                              "/robot/limb/<side>/joint_command, /robot/joint_states, /robot/state, enabling")
    registrar.add("driver", "iiwa-ros", "pliant_ros1.iiwa:IiwaDriver",
                  description="a KUKA LBR iiwa 7 over ROS 1 (iiwa_stack): iiwa_msgs/JointPosition command and state")


@hookimpl
def pliant_commands():
    """``pliant robot ros-peer``: a ROS node that behaves as a robot's controller (docs/plugins/ros1.md)."""
    return [Command("robot", "ros-peer",
                    "emulate a ROS 1 robot's controller (Baxter, PR2, iiwa) moving a simulated arm",
                    run="pliant_ros1.testing.command:run_from_args",
                    arguments="pliant_ros1.testing.command:add_arguments",
                    description="Run a ROS node that speaks a robot's own topics, types and rates (joint states, "
                                "commands, Baxter's enabling and /robot/state), moving the arm in a pliant "
                                "simulator, until Ctrl-C.  Fault switches arrive as std_msgs/String on "
                                "/pliant_peer/fault (stale, names-wrong, names-shuffle, names-duplicate, "
                                "stamps-backwards, stamps-repeat, flood, disable, estop, die, clear).  Start a master "
                                "first, e.g. `rosmaster --core` or pliant_ros1.master.RosMaster."),
            Command("robot", "ros-demo",
                    "plan a bundled robot pipeline and execute it on an emulated robot (a ROS 1 peer on loopback)",
                    run=_demo_command, arguments=_demo_arguments,
                    description="Start a ROS master on a free loopback port, plan the pipeline, then start a peer "
                                "that behaves as the robot's controller and execute on it through the robot's ROS 1 "
                                "driver; every command the peer received is checked against the robot's limits "
                                "(docs/plugins/ros1.md; make robot-demo runs iiwa-policy)."),
            Alias("ros-peer", "robot ros-peer")]


def _demo_arguments(parser) -> None:
    from pliant.api import add_common_arguments

    from pliant_ros1.demo import PIPELINES

    parser.add_argument("pipeline", choices=sorted(PIPELINES), help="a bundled robot pipeline")
    add_common_arguments(parser, seed=0, overrides="a pipeline override, e.g. planning.max_iterations=40")


def _demo_command(args) -> int:
    from pliant_ros1.demo import run

    return run(args.pipeline, args.seed, args.set)
