"""The PR2 arm driver (``pr2-ros``): a ``JointTrajectoryActionController`` over ROS 1.

* **commands**: ``trajectory_msgs/JointTrajectory`` on ``/r_arm_controller/command`` (``/l_arm_controller/command``
  with ``side = "left"``), one message per command period holding one point: the seven arm joints' positions
  (rad) and velocities (rad/s), ``time_from_start`` one command period, ``header.stamp`` zero ("start now", so
  the robot's clock need not agree with ours).  The controller splines from where it is to that point and then
  holds it: a PR2 arm whose commands stop stays where the last one ends (it has no command timeout).
* **states**: ``sensor_msgs/JointState`` on ``/joint_states``, every joint of the robot (torso, head, both arms,
  grippers...); the core picks the arm's joints by name.
* **limits**: the URDF's safety-controller soft limits (inside the hard limits), ``pliant_ros1/limits/
  pr2_<side>_arm.toml``.  The PR2's run-stop state is not read (pr2_msgs is not packaged): the robot is
  reported ready.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.options import option

from pliant_ros1.driver import RosDriver, RosDriverOptions


@dataclass(frozen=True)
class Pr2Options(RosDriverOptions):
    """Options of :class:`Pr2Driver`."""

    side: str = option("right", "which arm: right (r_ joints, /r_arm_controller) or left (l_, /l_arm_controller)",
                       choices=("right", "left"))


class Pr2Driver(RosDriver):
    """One PR2 arm through its ``<r|l>_arm_controller`` (see the module docstring)."""

    Options = Pr2Options
    robot = "pr2"

    def _command_publisher(self):
        from trajectory_msgs.msg import JointTrajectory

        return self._advertise(self.spec.command_topic, JointTrajectory)

    def _command(self, positions: np.ndarray, velocities: np.ndarray):
        import rospy
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

        msg = JointTrajectory()
        msg.joint_names = list(self.spec.joints)
        msg.points = [JointTrajectoryPoint(positions=positions.tolist(), velocities=velocities.tolist(),
                                           time_from_start=rospy.Duration.from_sec(self.limits.period))]
        return msg
