"""What a driver plugin reports about its robot: joint states and the robot's status."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class JointState:
    """One joint-state message as the robot sent it.

    names: the joints in the message's order (a robot whose messages carry no names, such as the iiwa, reports
    the driver's own joint order).  positions / velocities: ``(k,)`` rad (or m for prismatic joints) and rad/s;
    velocities may be ``None`` when the robot does not report them.  stamp: the robot's time stamp (s).
    received: :func:`time.monotonic` when the message arrived (s).  sequence: how many state messages the
    driver has received so far (the flood check counts with it).
    """

    names: tuple[str, ...]
    positions: np.ndarray
    velocities: np.ndarray | None
    stamp: float
    received: float
    sequence: int = 0


@dataclass(frozen=True)
class RobotStatus:
    """The robot's readiness: ``enabled`` (motors on), ``estop`` (emergency stop engaged), ``fault`` (a drive or
    controller fault, in words; empty when none), ``lost`` (the link to the robot or part of it is gone: a ROS master
    or node that died, a CAN drive's heartbeat that stopped, frames that cannot be decoded; in words, empty when
    fine) and a free-text ``detail`` for ``pliant robot check``."""

    enabled: bool = True
    estop: bool = False
    fault: str = ""
    lost: str = ""
    detail: str = ""

    @property
    def ready(self) -> bool:
        return self.enabled and not self.estop and not self.fault and not self.lost
