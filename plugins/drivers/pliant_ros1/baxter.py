"""The Baxter arm driver (``baxter-ros``), Rethink Robotics' RSDK ROS interface.

* **commands**: ``baxter_core_msgs/JointCommand`` (``mode`` = POSITION_MODE (1), ``command`` rad, ``names``) on
  ``/robot/limb/<side>/joint_command`` at the command rate (100 Hz; the RSDK's own publishers run at 100 Hz and up
  to 800 Hz).  The robot's motor controller holds its current position when no command arrives for 0.2 s (5 Hz):
  the limits file's ``command_timeout``.
* **speed ratio**: in position mode the robot moves toward each command at most at ``speed_ratio`` times its
  joint speed limits (``std_msgs/Float64`` on ``/robot/limb/<side>/set_speed_ratio``; 0.3 after power-up).  The
  commands the core sends are already within the limits, so the driver publishes ``speed_ratio`` (default 1.0)
  when it connects: a lower ratio makes the arm lag behind the reference.
* **states**: ``sensor_msgs/JointState`` on ``/robot/joint_states``: both arms, the head (``head_pan``,
  ``head_nod``) and ``torso_t0``; the core picks this arm's joints by name.
* **status and enabling**: ``baxter_core_msgs/AssemblyState`` on ``/robot/state`` (``enabled``, ``stopped`` = the
  e-stop is asserted, ``error``, the e-stop's button and source).  :meth:`BaxterDriver.enable` publishes
  ``std_msgs/Bool`` true on ``/robot/set_super_enable``.  The driver never disables the robot on leaving: a
  disabled Baxter's arms go limp.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import RobotStatus, option

from pliant_ros1.driver import RosDriver, RosDriverOptions
from pliant_ros1.messages import message_class

#: JointCommand.POSITION_MODE
POSITION_MODE = 1
ESTOP_BUTTON = {0: "unpressed", 1: "pressed", 2: "unknown", 3: "released"}
ESTOP_SOURCE = {0: "none", 1: "user (the red button)", 2: "unknown", 3: "a joint fault", 4: "brain heartbeat lapse"}


@dataclass(frozen=True)
class BaxterOptions(RosDriverOptions):
    """Options of :class:`BaxterDriver`."""

    side: str = option("right", "which arm: right or left (/robot/limb/<side>/...)", choices=("right", "left"))
    speed_ratio: float = option(1.0, "the robot's position-mode speed ratio, published when connecting: the "
                                "fraction of its joint speed limits it may use to follow each command (fraction)",
                                minimum=0.0,
                                maximum=1.0)


class BaxterDriver(RosDriver):
    """One Baxter arm in joint position mode (see the module docstring)."""

    Options = BaxterOptions
    robot = "baxter"

    def __init__(self, options=None, **kwargs) -> None:
        super().__init__(options, **kwargs)
        self._assembly = None
        self._enable_pub = None

    def _connect(self) -> None:
        from std_msgs.msg import Bool, Float64

        self._assembly = None
        super()._connect()
        self._subscribe("/robot/state", message_class("baxter_core_msgs/AssemblyState"), self._on_assembly)
        self._enable_pub = self._advertise("/robot/set_super_enable", Bool, latch=True)
        ratio = self._advertise(f"/robot/limb/{self.options.side}/set_speed_ratio", Float64, latch=True)
        ratio.publish(Float64(self.options.speed_ratio))

    def _command_publisher(self):
        return self._advertise(self.spec.command_topic, message_class("baxter_core_msgs/JointCommand"))

    def _command(self, positions: np.ndarray, velocities: np.ndarray):
        return message_class("baxter_core_msgs/JointCommand")(mode=POSITION_MODE, command=positions.tolist(),
                                                              names=list(self.spec.joints))

    def _on_assembly(self, msg) -> None:
        self._assembly = msg

    def _status(self) -> RobotStatus:
        s = self._assembly
        if s is None:
            return RobotStatus(enabled=False, detail="no /robot/state message received yet")
        estop = f"e-stop button {ESTOP_BUTTON.get(s.estop_button, s.estop_button)}, source " \
                f"{ESTOP_SOURCE.get(s.estop_source, s.estop_source)}"
        if s.stopped:
            return RobotStatus(enabled=bool(s.enabled), estop=True, detail=estop)
        fault = "the robot reports an error (/robot/state error: true) and is not enabled" \
            if s.error and not s.enabled else ""
        detail = "ready" if s.ready else ("enabled, not ready" if s.enabled else "/robot/state: enabled false")
        if s.error and s.enabled:
            detail += ", with a non-fatal error"
        return RobotStatus(enabled=bool(s.enabled), fault=fault, detail=detail)

    def enable(self) -> None:
        """Enable the motors: ``std_msgs/Bool`` true on ``/robot/set_super_enable`` (latched)."""
        from std_msgs.msg import Bool

        if self._enable_pub is not None:
            self._enable_pub.publish(Bool(True))
