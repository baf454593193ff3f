"""The safety layer: every command checked before the wire, every robot state checked before it is used.

:class:`SafetyLayer` is core code that the command stream (:mod:`pliant.hardware.stream`) runs for every driver;
a driver plugin never sees an unchecked command.  It refuses, with a :class:`~pliant.errors.DriverError` subclass
naming the joint, the value and the limit:

* commands (after ruckig): non-finite values; positions outside ``[lower + margin, upper - margin]``; velocities
  or accelerations beyond their limits; a change larger than the largest step per cycle;
* targets (before ruckig): non-finite values, positions outside the commanded range, velocities beyond limits;
* robot states: joints missing, repeated or unnamed where names are expected (names and order are mapped by
  name, so a robot reporting both arms and a head is fine); non-finite values; time stamps that go backwards, or
  repeat with different values; positions that jump further between two stamps than the velocity limits allow
  (:func:`state_jump`: a broken encoder, a restarted controller, a remapped joint); no fresh state within
  ``state_timeout`` (the watchdog); more state messages per second than ``max_state_rate`` (a flood);
* robot status: lost (a link or a part of it gone), disabled, e-stopped, faulted.

The checks allow a relative tolerance of 1e-6 (and 1e-9 absolute) for floating-point rounding in ruckig's output.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from pliant.errors import (
    ConnectionLost,
    DriveFault,
    EmergencyStop,
    JointMismatch,
    LimitViolation,
    NonFiniteCommand,
    RobotDisabled,
    StaleState,
    StateError,
    StepTooLarge,
)
from pliant.hardware.limits import JointLimits
from pliant.hardware.state import JointState, RobotStatus

RELATIVE_TOLERANCE = 1e-6
ABSOLUTE_TOLERANCE = 1e-9
#: seconds of state messages the flood check counts over
FLOOD_WINDOW = 0.5
#: two joint states jump when a joint moved more than JUMP_FACTOR x its velocity limit x the time between their stamps
#: (at least JUMP_MIN_INTERVAL s: stamps jitter, and a drive may step a late cycle's worth at once) + JUMP_SLACK rad
#: (encoder noise)
JUMP_FACTOR = 2.0
JUMP_MIN_INTERVAL = 0.05
JUMP_SLACK = 0.02


def state_jump(previous: np.ndarray, positions: np.ndarray, interval: float,
               velocity: np.ndarray) -> tuple[int, float] | None:
    """``(joint index, allowed move in rad)`` of the first joint whose move from ``previous`` to ``positions``
    (``(d,)`` rad, ``interval`` s apart by their stamps) an arm within ``velocity`` ``(d,)`` rad/s cannot make, or
    None.  Allowed: ``JUMP_FACTOR * velocity * max(interval, JUMP_MIN_INTERVAL) + JUMP_SLACK``."""
    allowed = JUMP_FACTOR * np.asarray(velocity, dtype=np.float64) * max(interval, JUMP_MIN_INTERVAL) + JUMP_SLACK
    bad = np.flatnonzero(~(np.abs(np.asarray(positions) - np.asarray(previous)) <= allowed))
    return (int(bad[0]), float(allowed[bad[0]])) if bad.size else None


class SafetyLayer:
    """Checks commands against ``limits`` and robot states against the driver's joints (see the module doc)."""

    def __init__(self, limits: JointLimits) -> None:
        self.limits = limits
        self.last_positions: np.ndarray | None = None
        self.last_velocities: np.ndarray | None = None
        self._last_stamp: float | None = None
        self._last_state_positions: np.ndarray | None = None
        self._last_fresh: float | None = None
        self._started: float | None = None
        self._fresh_positions: np.ndarray | None = None
        self._fresh_velocities: np.ndarray | None = None
        self._arrivals: deque[tuple[float, int]] = deque()
        self._index: tuple[tuple[str, ...], np.ndarray] | None = None

    # --- commands --------------------------------------------------------------------------------------------

    def _finite(self, values: np.ndarray, what: str) -> None:
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise NonFiniteCommand(f"{what} is not finite", joint=self.limits.names[bad[0]],
                                   value=float(values[bad[0]]))

    def _shape(self, values, what: str) -> np.ndarray:
        values = np.asarray(values, dtype=np.float64)
        if values.shape != (self.limits.dof,):
            raise JointMismatch(f"{what} must have one value per joint ({self.limits.dof}: "
                                f"{', '.join(self.limits.names)})", value=values.shape)
        return values

    def _within(self, values: np.ndarray, lower: np.ndarray, upper: np.ndarray, what: str, unit: str,
                error: type = LimitViolation) -> None:
        slack = RELATIVE_TOLERANCE * np.maximum(np.abs(lower), np.abs(upper)) + ABSOLUTE_TOLERANCE
        bad = np.flatnonzero((values < lower - slack) | (values > upper + slack))
        if bad.size:
            i = bad[0]
            raise error(f"{what} {values[i]:.6g} {unit} outside [{lower[i]:.6g}, {upper[i]:.6g}]",
                        joint=self.limits.names[i], value=float(values[i]),
                        limit=[float(lower[i]), float(upper[i])])

    def check_target(self, position, velocity=None) -> tuple[np.ndarray, np.ndarray]:
        """A target ``(d,)`` (and velocity ``(d,)``, default zero) as arrays, or the refusal."""
        position = self._shape(position, "target")
        self._finite(position, "target position")
        lim = self.limits
        self._within(position, lim.command_lower, lim.command_upper, "target position", "rad")
        velocity = np.zeros(lim.dof) if velocity is None else self._shape(velocity, "target velocity")
        self._finite(velocity, "target velocity")
        self._within(velocity, -lim.velocity, lim.velocity, "target velocity", "rad/s")
        return position, velocity

    @property
    def fresh_at(self) -> float | None:
        """:func:`time.monotonic` when the newest fresh joint state arrived (None before the first)."""
        return self._last_fresh

    def begin(self, positions: np.ndarray) -> None:
        """Start checking steps from the measured ``positions`` (the robot at rest)."""
        self.last_positions = np.array(positions, dtype=np.float64)
        self.last_velocities = np.zeros(self.limits.dof)

    def check_command(self, positions, velocities, accelerations=None) -> None:
        """Refuse a command that breaks a limit; remember it as the last one sent when it passes."""
        lim = self.limits
        positions = self._shape(positions, "command")
        velocities = self._shape(velocities, "command velocity")
        self._finite(positions, "command position")
        self._finite(velocities, "command velocity")
        self._within(positions, lim.command_lower, lim.command_upper, "command position", "rad")
        self._within(velocities, -lim.velocity, lim.velocity, "command velocity", "rad/s")
        if accelerations is not None:
            accelerations = self._shape(accelerations, "command acceleration")
            self._finite(accelerations, "command acceleration")
            self._within(accelerations, -lim.acceleration, lim.acceleration, "command acceleration", "rad/s^2")
        if self.last_positions is not None:
            step = positions - self.last_positions
            self._within(step, -lim.max_step, lim.max_step, "step per cycle", "rad", StepTooLarge)
        self.last_positions = positions.copy()
        self.last_velocities = velocities.copy()

    # --- robot states ----------------------------------------------------------------------------------------

    def _order(self, names: tuple[str, ...]) -> np.ndarray:
        if self._index is not None and self._index[0] == names:
            return self._index[1]
        positions: dict[str, int] = {}
        for i, name in enumerate(names):
            if name in positions:
                raise JointMismatch("the robot reports this joint twice", joint=name, value=list(names))
            positions[name] = i
        missing = [n for n in self.limits.names if n not in positions]
        if missing:
            raise JointMismatch(f"the robot's joint states lack it (they name {', '.join(names) or 'no joints'})",
                                joint=missing[0])
        order = np.array([positions[n] for n in self.limits.names])
        self._index = (names, order)
        return order

    def read_state(self, state: JointState | None, now: float) -> tuple[np.ndarray, np.ndarray]:
        """The measured positions and velocities ``(d,)`` in command order, or the refusal.

        ``now`` is :func:`time.monotonic`.  Without any state yet, only the watchdog applies (from the first call).
        Velocities the robot does not report are estimated from the last two fresh states.
        """
        lim = self.limits
        if self._started is None:
            self._started = now
        if state is None:
            if now - self._started > lim.state_timeout:
                raise StaleState(f"no joint state received within {lim.state_timeout:g} s", value=None)
            raise StaleState("no joint state received yet", value=None)
        order = self._order(tuple(state.names))
        raw = np.asarray(state.positions, dtype=np.float64)
        if raw.shape != (len(state.names),):
            raise JointMismatch("the joint state has a different number of positions than names",
                                value=[len(state.names), raw.shape])
        positions = raw[order]
        bad = np.flatnonzero(~np.isfinite(positions))
        if bad.size:
            raise StateError("the robot reports a non-finite position", joint=lim.names[bad[0]],
                             value=float(positions[bad[0]]))
        velocities = None
        if state.velocities is not None and len(state.velocities):
            raw_v = np.asarray(state.velocities, dtype=np.float64)
            if raw_v.shape == raw.shape:
                velocities = raw_v[order]
                if not np.all(np.isfinite(velocities)):
                    raise StateError("the robot reports a non-finite velocity", value=velocities.tolist())
        fresh = self._last_stamp is None or state.stamp > self._last_stamp
        if self._last_stamp is not None and state.stamp < self._last_stamp:
            raise StateError(f"time stamps go backwards: {state.stamp:.6f} s after {self._last_stamp:.6f} s",
                             value=state.stamp)
        if (self._last_stamp is not None and state.stamp == self._last_stamp
                and not np.array_equal(positions, self._last_state_positions)):
            raise StateError(f"two joint states carry the same time stamp {state.stamp:.6f} s with different "
                             "positions", value=state.stamp)
        self._count(state.sequence, now)
        if fresh:
            if self._fresh_positions is not None and self._last_stamp is not None:
                interval = state.stamp - self._last_stamp
                jump = state_jump(self._fresh_positions, positions, interval, lim.velocity)
                if jump is not None:
                    i, allowed = jump
                    raise StateError(f"the joint states jump: moved {positions[i] - self._fresh_positions[i]:+.4g} "
                                     f"rad in {interval:.4g} s between two stamps (an arm within "
                                     f"{lim.velocity[i]:.4g} rad/s moves at most {allowed:.4g} rad)",
                                     joint=lim.names[i], value=float(positions[i]))
            if velocities is None:
                if self._fresh_positions is not None and self._last_stamp is not None:
                    velocities = (positions - self._fresh_positions) / (state.stamp - self._last_stamp)
                else:
                    velocities = np.zeros(lim.dof)
            self._last_stamp = state.stamp
            self._last_state_positions = positions
            self._last_fresh = state.received
            self._fresh_positions, self._fresh_velocities = positions, velocities
        age = now - (self._last_fresh if self._last_fresh is not None else self._started)
        if age > lim.state_timeout:
            raise StaleState(f"the newest joint state is {age:.3f} s old (watchdog {lim.state_timeout:g} s)",
                             value=round(age, 6))
        return self._fresh_positions, self._fresh_velocities

    def _count(self, sequence: int, now: float) -> None:
        arrivals = self._arrivals
        arrivals.append((now, sequence))
        while len(arrivals) > 2 and now - arrivals[0][0] > FLOOD_WINDOW:
            arrivals.popleft()
        span = now - arrivals[0][0]
        if span >= FLOOD_WINDOW / 2:
            rate = (sequence - arrivals[0][1]) / span
            if rate > self.limits.max_state_rate:
                raise StateError(f"joint states arrive at {rate:.0f} messages/s, more than the robot's "
                                 f"{self.limits.max_state_rate:g}/s (a flood)", value=round(rate))

    @staticmethod
    def check_status(status: RobotStatus) -> None:
        """Refuse to move a robot that is lost, e-stopped, faulted or disabled."""
        if status.lost:
            raise ConnectionLost(f"the link to the robot is lost: {status.lost}")
        if status.estop:
            raise EmergencyStop("the robot's emergency stop is engaged" + (f": {status.detail}" if status.detail
                                                                           else ""))
        if status.fault:
            raise DriveFault(f"the robot reports a fault: {status.fault}")
        if not status.enabled:
            raise RobotDisabled("the robot is disabled" + (f": {status.detail}" if status.detail else ""))
