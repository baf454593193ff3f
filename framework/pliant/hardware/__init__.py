"""Executing on robots: joint limits, the safety layer, ruckig smoothing and the command stream.

Every command a :class:`~pliant.interfaces.Driver` puts on the wire is produced here, in the core, so that no
driver plugin can skip a check (DESIGN rule 9).  The layers, from the caller to the wire:

1. :class:`~pliant.hardware.stream.CommandStream` runs at the robot's command rate in its own thread.  Callers
   (``move_to``, ``follow``, ``stream``, ``stop``, the execution loop) only set its *target*.
2. :class:`~pliant.hardware.smoothing.OnlineSmoother` (ruckig, online) turns the target into a jerk-limited
   reference one cycle ahead, and plans a stop before any position limit.
3. :class:`~pliant.hardware.safety.SafetyLayer` checks every reference before it is written (finite, position
   limits with a margin, velocity, acceleration, largest step per cycle) and every state the robot reports
   (joint names and order, freshness, time stamps, flood, robot status).  A refusal raises a
   :class:`~pliant.errors.DriverError` subclass; the stream then brakes within the limits.
4. The driver plugin's ``write`` serialises the checked command for its robot.

The limits of each robot come from a limits file (:mod:`pliant.hardware.limits`) with its data-sheet sources.
"""

from pliant.hardware.limits import JointLimits, load_limits
from pliant.hardware.state import JointState, RobotStatus

__all__ = ["JointLimits", "JointState", "RobotStatus", "load_limits"]
