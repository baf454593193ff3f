"""The KUKA LBR iiwa driver (``iiwa-ros``), iiwa_stack conventions (IFL-CAMP/iiwa_stack).

* **commands**: ``iiwa_msgs/JointPosition`` (``header``, ``position``: a ``JointQuantity`` of float32 ``a1`` ...
  ``a7``, rad) on ``<namespace>/command/JointPosition``, one per command period, stamped with the send time.  The
  robot (SmartServo on the Sunrise controller) moves to the newest destination and keeps going to the last one
  received: it has no command timeout.
* **states**: ``iiwa_msgs/JointPosition`` on ``<namespace>/state/JointPosition``.  The message names no joints and
  carries no velocities: the state reports the driver's own joint order (``lbr_iiwa_joint_1`` ... ``_7``, axes A1
  ... A7) and the core estimates velocities from successive states.
* **limits**: the LBR iiwa 7 R800 data sheet, ``pliant_ros1/limits/iiwa7_r800.toml``.  The message types are
  generated from the shipped ``.msg`` files (:mod:`pliant_ros1.messages`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import option

from pliant_ros1.driver import RosDriver, RosDriverOptions
from pliant_ros1.messages import message_class

AXES = ("a1", "a2", "a3", "a4", "a5", "a6", "a7")


@dataclass(frozen=True)
class IiwaOptions(RosDriverOptions):
    """Options of :class:`IiwaDriver`."""

    namespace: str = option("/iiwa", "the robot's ROS namespace (iiwa_stack's robot_name); topics are "
                            "<namespace>/command/JointPosition and <namespace>/state/JointPosition")


class IiwaDriver(RosDriver):
    """A KUKA LBR iiwa 7 R800 through iiwa_stack's joint position topics (see the module docstring)."""

    Options = IiwaOptions
    robot = "iiwa"

    def _topic(self, kind: str) -> str:
        return f"/{self.options.namespace.strip('/')}/{kind}/JointPosition"

    def _connect(self) -> None:
        self._subscribe(self._topic("state"), message_class("iiwa_msgs/JointPosition"), self._on_position)

    def _command_publisher(self):
        return self._advertise(self._topic("command"), message_class("iiwa_msgs/JointPosition"))

    def _on_position(self, msg) -> None:
        p = msg.position
        self._received(self.spec.joints, [getattr(p, a) for a in AXES], None, msg.header.stamp.to_sec())

    def _command(self, positions: np.ndarray, velocities: np.ndarray):
        import rospy

        msg = message_class("iiwa_msgs/JointPosition")()
        msg.header.stamp = rospy.Time.now()
        for axis, value in zip(AXES, positions.tolist()):
            setattr(msg.position, axis, value)
        return msg
