"""Entry point of the ROS 1 plugin: the ``pr2-ros``, ``baxter-ros`` and ``iiwa-ros`` drivers and the
``pliant robot ros-peer`` command.  Light: rospy and the drivers are imported only when a component is created."""

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
            Alias("ros-peer", "robot ros-peer")]
