"""The PR2 arm driver (``pr2-ros``): a ``JointTrajectoryActionController`` over ROS 1.

* **commands**: ``trajectory_msgs/JointTrajectory`` on ``/r_arm_controller/command`` (``/l_arm_controller/command``
  with ``side = "left"``), one message per command period holding one point: the seven arm joints' positions
  (rad) and velocities (rad/s), ``time_from_start`` one command period, ``header.stamp`` zero ("start now", so
  the robot's clock need not agree with ours).  The controller splines from where it is to that point and then
  holds it: a PR2 arm whose commands stop stays where the last one ends (it has no command timeout).
* **states**: ``sensor_msgs/JointState`` on ``/joint_states``, every joint of the robot (torso, head, both arms,
  grippers...); the core picks the arm's joints by name.
* **limits**: the URDF's safety-controller soft limits (inside the hard limits), ``pliant_ros1/limits/
  pr2_<side>_arm.toml``.
* **status and enabling** (``robot_state = true``, the default): the run-stops from ``/power_board/state``
  (``pr2_msgs/PowerBoardState``: ``run_stop`` / ``wireless_stop`` false while pressed: an e-stop) and whether the
  motors are halted from ``<ethercat_namespace>/motors_halted`` (``std_msgs/Bool``, latched; true after a run-stop or
  a ``halt_motors`` call: the robot is disabled).  :meth:`Pr2Driver.enable` calls ``<ethercat_namespace>/
  reset_motors`` (``std_srvs/Empty``), refused while a run-stop is pressed.  A simulated PR2 without a power board
  runs with ``robot_state = false``: the status is not read and the robot counts as ready.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import RobotStatus, option

from pliant_ros1.driver import RosDriver, RosDriverOptions


@dataclass(frozen=True)
class Pr2Options(RosDriverOptions):
    """Options of :class:`Pr2Driver`."""

    side: str = option("right", "which arm: right (r_ joints, /r_arm_controller) or left (l_, /l_arm_controller)",
                       choices=("right", "left"))
    robot_state: bool = option(True, "read the run-stops (/power_board/state) and the motors' halt state; false "
                               "for a simulated PR2 without a power board (the robot then counts as ready)")
    ethercat_namespace: str = option("/pr2_ethercat", "namespace of motors_halted and reset_motors (older setups: "
                                     "/pr2_etherCAT)")


class Pr2Driver(RosDriver):
    """One PR2 arm through its ``<r|l>_arm_controller`` (see the module docstring)."""

    Options = Pr2Options
    robot = "pr2"

    def __init__(self, options=None, **kwargs) -> None:
        super().__init__(options, **kwargs)
        self._power = None
        self._halted: bool | None = None

    def _connect(self) -> None:
        from std_msgs.msg import Bool

        from pliant_ros1.messages import message_class

        self._power, self._halted = None, None
        super()._connect()
        if self.options.robot_state:
            from pliant.api import RobotNotReady

            from pliant_ros1.node import wait_for

            self._subscribe("/power_board/state", message_class("pr2_msgs/PowerBoardState"), self._on_power)
            self._subscribe(f"{self.options.ethercat_namespace}/motors_halted", Bool, self._on_halted)
            # the power board publishes about once a second: wait for it, so the status is known when connected
            timeout = self.options.connect_timeout
            if not wait_for(lambda: self._power is not None and self._halted is not None, timeout):
                missing = "/power_board/state" if self._power is None else \
                    f"{self.options.ethercat_namespace}/motors_halted"
                raise RobotNotReady(f"no {missing} within {timeout:g} s (a simulated PR2 without a power board? set "
                                    "robot_state = false)")

    def _on_power(self, msg) -> None:
        self._power = msg

    def _on_halted(self, msg) -> None:
        self._halted = bool(msg.data)

    def _status(self) -> RobotStatus:
        if not self.options.robot_state:
            return RobotStatus(detail="robot_state = false: run-stops and motors not read")
        power, halted = self._power, self._halted
        if power is None or halted is None:
            missing = "/power_board/state" if power is None else f"{self.options.ethercat_namespace}/motors_halted"
            return RobotStatus(enabled=False, detail=f"no {missing} received yet")
        stops = [name for name, ok in (("the run-stop", power.run_stop), ("the wireless run-stop",
                                                                          power.wireless_stop)) if not ok]
        if stops:
            return RobotStatus(enabled=False, estop=True, detail=f"{' and '.join(stops)} pressed; motors halted")
        if halted:
            return RobotStatus(enabled=False, detail="motors halted (after a run-stop or halt_motors); --enable "
                                                     "resets them")
        return RobotStatus(detail="ready")

    def enable(self) -> None:
        """Reset the halted motors: ``<ethercat_namespace>/reset_motors`` (``std_srvs/Empty``); refused while a
        run-stop is pressed (the robot would halt again)."""
        import rospy
        from pliant.api import EmergencyStop, RobotNotReady
        from std_srvs.srv import Empty

        if not self.options.robot_state:
            return
        status = self._status()
        if status.estop:
            raise EmergencyStop(f"cannot reset the motors: {status.detail}")
        name = f"{self.options.ethercat_namespace}/reset_motors"
        try:
            rospy.wait_for_service(name, timeout=self.options.connect_timeout)
            rospy.ServiceProxy(name, Empty)()
        except (rospy.ROSException, rospy.ServiceException) as exc:
            raise RobotNotReady(f"cannot reset the motors through {name}: {exc}") from None

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
