"""Jerk-limited smoothing of streamed targets with ruckig (online trajectory generation), one cycle at a time.

:class:`OnlineSmoother` holds the commanded reference (position, velocity, acceleration per joint).  Each
:meth:`~OnlineSmoother.update` advances it by one command period toward the current target under the velocity,
acceleration and jerk limits; a new target mid-motion starts from the current reference (it blends, it does not
stop).  The traps of ruckig this module handles:

* **Position limits are ignored by ruckig.**  A time-optimal trajectory may overshoot an in-range target when
  it starts fast, and a target with a velocity continues past its position.  Each new trajectory's position
  extrema are checked (and, for a target with a velocity, the stop from the next reference); when either would
  leave ``[lower + margin, upper - margin]`` the smoother brakes instead — it plans the stop, it never clamps a
  position (which would be a jump).
* ``Result.Working`` means "in progress" and ``Result.Finished`` "at the target"; negative results and
  ``RuckigError`` (raised on invalid input) become :class:`~pliant.errors.SmoothingError`.
* ``InputParameter.intermediate_positions`` makes ruckig send the waypoints to a cloud service: never set here.
* A finished trajectory with a non-zero target velocity is not a resting state: the stream expires such
  targets and brakes (see :mod:`pliant.hardware.stream`).
"""

from __future__ import annotations

import numpy as np

from pliant.errors import SmoothingError
from pliant.hardware.limits import JointLimits

#: below these (rad/s, rad/s^2) the reference counts as at rest
REST_VELOCITY = 1e-9
REST_ACCELERATION = 1e-9
#: how far (rad) a target is moved when ruckig fails on it once (see ``update``)
NUDGE = 1e-9


class OnlineSmoother:
    """Online ruckig over ``limits`` at ``limits.period``; see the module docstring."""

    def __init__(self, limits: JointLimits) -> None:
        import ruckig

        self._ruckig = ruckig
        self.limits = limits
        d = limits.dof
        self._otg = ruckig.Ruckig(d, limits.period)
        self._input = ruckig.InputParameter(d)
        self._output = ruckig.OutputParameter(d)
        self._planner = ruckig.Ruckig(d)
        self._check_input = ruckig.InputParameter(d)
        self._trajectory = ruckig.Trajectory(d)
        self._brake_input = ruckig.InputParameter(d)
        for parameters in (self._input, self._check_input, self._brake_input):
            parameters.max_velocity = limits.velocity.tolist()
            parameters.max_acceleration = limits.acceleration.tolist()
            parameters.max_jerk = limits.jerk.tolist()
        self._brake_input.control_interface = ruckig.ControlInterface.Velocity
        self._brake_input.target_velocity = [0.0] * d
        self._brake_input.target_acceleration = [0.0] * d
        self._brake_otg = ruckig.Ruckig(d, limits.period)
        self._brake_output = ruckig.OutputParameter(d)
        self.position = np.zeros(d)
        self.velocity = np.zeros(d)
        self.acceleration = np.zeros(d)
        self.target_position = np.zeros(d)
        self.target_velocity = np.zeros(d)
        #: "position" (aim at a position) or "velocity" (reach and hold a velocity: the execution protocol)
        self.mode = "position"
        self.braking = False
        #: why the last brake began ("" when not braking): "stop", "position limit", ...
        self.brake_reason = ""
        self.finished = True

    # --- state -----------------------------------------------------------------------------------------------

    def reset(self, position: np.ndarray) -> None:
        """Start at rest at ``position`` (the measured one), holding it."""
        self.position = np.array(position, dtype=np.float64)
        self.velocity = np.zeros_like(self.position)
        self.acceleration = np.zeros_like(self.position)
        self.target_position = self.position.copy()
        self.target_velocity = np.zeros_like(self.position)
        self.mode = "position"
        self.braking = False
        self.brake_reason = ""
        self.finished = True

    def set_velocity(self, velocity: np.ndarray) -> None:
        """Reach ``velocity`` ``(d,)`` (rad/s) and hold it; the stream expires it, and a stop is planned before
        any position limit (checked by the caller against the velocity limits)."""
        self.target_velocity = np.array(velocity, dtype=np.float64)
        self.mode = "velocity"
        self.braking = False
        self.brake_reason = ""
        self.finished = False

    def set_target(self, position: np.ndarray, velocity: np.ndarray | None = None) -> None:
        """Aim at ``position`` ``(d,)`` arriving with ``velocity`` (default zero); checked by the caller."""
        self.target_position = np.array(position, dtype=np.float64)
        self.target_velocity = np.zeros_like(self.target_position) if velocity is None else \
            np.array(velocity, dtype=np.float64)
        self.mode = "position"
        self.braking = False
        self.brake_reason = ""
        self.finished = False

    def brake(self, reason: str = "stop") -> None:
        """Decelerate to rest within the limits from the current reference (then hold there)."""
        if not self.braking:
            self.braking = True
            self.brake_reason = reason

    @property
    def at_rest(self) -> bool:
        return bool(np.all(np.abs(self.velocity) <= REST_VELOCITY) and
                    np.all(np.abs(self.acceleration) <= REST_ACCELERATION))

    # --- one cycle -------------------------------------------------------------------------------------------

    def update(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance one period; the new reference ``(position, velocity, acceleration)``."""
        if self.braking:
            return self._brake_step()
        if self.finished and not np.any(self.target_velocity):
            self.velocity[:] = 0.0
            self.acceleration[:] = 0.0
            return self.position.copy(), self.velocity.copy(), self.acceleration.copy()
        inp = self._input
        inp.control_interface = self._ruckig.ControlInterface.Velocity if self.mode == "velocity" else \
            self._ruckig.ControlInterface.Position
        inp.current_position = self.position.tolist()
        inp.current_velocity = self.velocity.tolist()
        inp.current_acceleration = self.acceleration.tolist()
        inp.target_position = self.target_position.tolist()
        inp.target_velocity = self.target_velocity.tolist()
        inp.target_acceleration = [0.0] * self.limits.dof
        try:
            result = self._call(self._otg.update, inp, self._output)
        except SmoothingError:
            # ruckig (0.19) fails on some valid inputs: a move from rest of exactly 2 a^3 / j^2 ("error in step 1",
            # pantor/ruckig #90, #160) -- a distance the stream's own brake can leave.  A target 1e-9 rad away is
            # the same motion and plans; a second failure is real.
            if not (np.all(np.isfinite(self.target_position)) and np.all(np.isfinite(self.target_velocity))):
                raise
            inp.target_position = (self.target_position + NUDGE).tolist()
            result = self._call(self._otg.update, inp, self._output)
        out = self._output
        if self.mode == "position" and out.new_calculation and not self._inside(out.trajectory.position_extrema):
            self.brake("position limit")
            return self._brake_step()
        position = np.array(out.new_position)
        velocity = np.array(out.new_velocity)
        acceleration = np.array(out.new_acceleration)
        if np.any(self.target_velocity) and not self._stops_inside(position, velocity, acceleration):
            self.brake("position limit")
            return self._brake_step()
        self.position, self.velocity, self.acceleration = position, velocity, acceleration
        self.finished = result == self._ruckig.Result.Finished and self.mode == "position"
        if self.finished and not np.any(self.target_velocity):
            self.position = self.target_position.copy()
            self.velocity[:] = 0.0
            self.acceleration[:] = 0.0
        return self.position.copy(), self.velocity.copy(), self.acceleration.copy()

    def duration(self) -> float:
        """Seconds ruckig needs from the current reference to the target (0 when there)."""
        inp = self._check_input
        inp.current_position = self.position.tolist()
        inp.current_velocity = self.velocity.tolist()
        inp.current_acceleration = self.acceleration.tolist()
        inp.target_position = self.target_position.tolist()
        inp.target_velocity = self.target_velocity.tolist()
        inp.target_acceleration = [0.0] * self.limits.dof
        self._call(self._planner.calculate, inp, self._trajectory)
        return float(self._trajectory.duration)

    def _brake_step(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.at_rest:
            self.velocity[:] = 0.0
            self.acceleration[:] = 0.0
            self.finished = True
            return self.position.copy(), self.velocity.copy(), self.acceleration.copy()
        inp = self._brake_input
        inp.current_position = self.position.tolist()
        inp.current_velocity = self.velocity.tolist()
        inp.current_acceleration = self.acceleration.tolist()
        result = self._call(self._brake_otg.update, inp, self._brake_output)
        out = self._brake_output
        self.position = np.array(out.new_position)
        self.velocity = np.array(out.new_velocity)
        self.acceleration = np.array(out.new_acceleration)
        if result == self._ruckig.Result.Finished:
            self.velocity[:] = 0.0
            self.acceleration[:] = 0.0
        self.target_position = self.position.copy()
        self.target_velocity = np.zeros_like(self.position)
        return self.position.copy(), self.velocity.copy(), self.acceleration.copy()

    def _stops_inside(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> bool:
        """Whether braking from this reference keeps every joint inside the commanded range."""
        inp = self._check_input
        inp.control_interface = self._ruckig.ControlInterface.Velocity
        inp.current_position = position.tolist()
        inp.current_velocity = velocity.tolist()
        inp.current_acceleration = acceleration.tolist()
        inp.target_velocity = [0.0] * self.limits.dof
        inp.target_acceleration = [0.0] * self.limits.dof
        try:
            self._call(self._planner.calculate, inp, self._trajectory)
        finally:
            inp.control_interface = self._ruckig.ControlInterface.Position
        return self._inside(self._trajectory.position_extrema)

    def _inside(self, extrema) -> bool:
        lower, upper = self.limits.command_lower, self.limits.command_upper
        return all(b.min >= lo - 1e-9 and b.max <= hi + 1e-9 for b, lo, hi in zip(extrema, lower, upper))

    def _call(self, method, *args):
        ruckig = self._ruckig
        try:
            result = method(*args)
        except ruckig.RuckigError as exc:
            raise SmoothingError(f"ruckig rejected its input: {exc}") from None
        if result not in (ruckig.Result.Working, ruckig.Result.Finished):
            raise SmoothingError(f"ruckig failed to plan: {result.name}", value=[self.position.tolist(),
                                                                                 self.target_position.tolist()])
        return result
