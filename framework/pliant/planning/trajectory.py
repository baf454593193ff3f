"""Time-parameterised trajectories of planned paths: positions, velocities and accelerations over time within
velocity, acceleration (and, where given, jerk) limits.

A planner's path is piecewise linear in configuration space, and the planner checked exactly those straight motions.
:func:`time_parameterize` keeps that geometry: the trajectory moves along each segment and nowhere else.  With bounded
acceleration a corner of a piecewise-linear path can only be passed at rest, so the trajectory stops at every corner
(consecutive collinear segments are merged first, so a densified straight motion does not stop) and each segment is a
rest-to-rest move of the path parameter ``s`` from 0 to 1, ``q(s) = a + s (b - a)``, under the tightest of the joint
limits mapped onto ``s``::

    s_dot <= min_i v_i / |b_i - a_i|,   s_ddot <= min_i a_i / |b_i - a_i|,   s_dddot <= min_i j_i / |b_i - a_i|

The move is time-optimal for those limits: a trapezoidal speed profile (a triangle when the segment is too short to
reach the speed limit) without a jerk limit; with one, ruckig's time-optimal jerk-limited profile of the one degree of
freedom ``s`` (ruckig's offline interface; its waypoint interface needs a cloud service and is never used).  So every
joint stays within its limits at every instant, up to rounding, and the trajectory is the time-optimal one of the
geometric path among those that follow it exactly.  Space conventions: R^n coordinates (joints); other spaces'
configurations are interpolated linearly too, which is their geodesic only for R^n.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from pliant.errors import ConfigError, DimensionError

#: segments whose directions differ by less than this (radians) are merged
COLLINEAR = 1e-6


@dataclass
class Trajectory:
    """A trajectory through ``k`` knots and the segment profiles between them.

    knots: ``(k, d)`` the path's corners (rest points); knot_times: ``(k,)`` when it is at each (s, from 0).
    velocity / acceleration / jerk: the ``(d,)`` limits it was made for (``jerk`` ``None``: not limited).
    """

    knots: np.ndarray
    knot_times: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray | None = None
    _profiles: list = field(default_factory=list, repr=False)

    @property
    def duration(self) -> float:
        """Seconds from the first knot to the last."""
        return float(self.knot_times[-1])

    @property
    def dim(self) -> int:
        return int(self.knots.shape[1])

    def state(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations at the times ``t`` (``(n,)``; clipped to ``[0, duration]``): three
        ``(n, d)`` arrays."""
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=np.float64)), 0.0, self.duration)
        n, d = len(t), self.dim
        q, v, a = np.empty((n, d)), np.zeros((n, d)), np.zeros((n, d))
        if len(self._profiles) == 0:
            q[:] = self.knots[0]
            return q, v, a
        seg = np.clip(np.searchsorted(self.knot_times, t, side="right") - 1, 0, len(self._profiles) - 1)
        for k in np.unique(seg):
            idx = np.flatnonzero(seg == k)
            s, sd, sdd = self._profiles[k](t[idx] - self.knot_times[k])
            delta = self.knots[k + 1] - self.knots[k]
            q[idx] = self.knots[k] + s[:, None] * delta
            v[idx] = sd[:, None] * delta
            a[idx] = sdd[:, None] * delta
        return q, v, a

    def sample(self, rate: float = 1000.0) -> dict[str, np.ndarray]:
        """The trajectory at ``rate`` Hz (and its last instant): ``times (n,)``, ``positions``, ``velocities``,
        ``accelerations`` ``(n, d)``."""
        if not rate > 0:
            raise ConfigError("must be positive", field="rate", value=rate)
        times = np.arange(0.0, self.duration, 1.0 / rate)
        times = np.append(times, self.duration)
        q, v, a = self.state(times)
        return {"times": times, "positions": q, "velocities": v, "accelerations": a}

    def limit_ratio(self, rate: float = 1000.0) -> dict[str, float]:
        """The largest ``|velocity| / limit`` and ``|acceleration| / limit`` over the samples at ``rate`` Hz (<= 1
        within the limits, up to rounding)."""
        s = self.sample(rate)
        return {"velocity": float(np.max(np.abs(s["velocities"]) / self.velocity)),
                "acceleration": float(np.max(np.abs(s["accelerations"]) / self.acceleration))}

    def to_dict(self, rate: float = 100.0) -> dict:
        """A JSON-ready record: the knots, their times, the limits and the samples at ``rate`` Hz."""
        s = self.sample(rate)
        return {"duration": self.duration, "knots": self.knots.tolist(), "knot_times": self.knot_times.tolist(),
                "limits": {"velocity": self.velocity.tolist(), "acceleration": self.acceleration.tolist(),
                           "jerk": None if self.jerk is None else self.jerk.tolist()},
                "rate": rate, **{k: v.tolist() for k, v in s.items()}}


def rest_to_rest(distance: float, velocity: float, acceleration: float):
    """The time-optimal rest-to-rest move of one coordinate over ``distance`` (>= 0) under the speed and acceleration
    limits (a trapezoid, or a triangle when the speed limit is not reached): ``(duration, profile)`` where
    ``profile(t) -> (position, velocity, acceleration)`` for times ``t`` (``(n,)``) from its start."""
    if distance <= 0.0:
        return 0.0, lambda t: (np.zeros(len(t)), np.zeros(len(t)), np.zeros(len(t)))
    ramp = velocity / acceleration                            # time to reach the speed limit
    if distance >= velocity * ramp:                           # trapezoid: accelerate, cruise, brake
        peak, cruise = velocity, distance / velocity - ramp
    else:                                                      # triangle: accelerate half way, brake
        ramp = math.sqrt(distance / acceleration)
        peak, cruise = acceleration * ramp, 0.0
    duration = 2.0 * ramp + cruise

    def profile(t):
        t = np.clip(np.asarray(t, dtype=np.float64), 0.0, duration)
        s, v, a = np.empty_like(t), np.empty_like(t), np.empty_like(t)
        up = t < ramp
        flat = (~up) & (t < ramp + cruise)
        down = ~(up | flat)
        s[up], v[up], a[up] = 0.5 * acceleration * t[up] ** 2, acceleration * t[up], acceleration
        tf = t[flat] - ramp
        s[flat], v[flat], a[flat] = 0.5 * peak * ramp + peak * tf, peak, 0.0
        left = duration - t[down]
        s[down], v[down], a[down] = distance - 0.5 * acceleration * left ** 2, acceleration * left, -acceleration
        return s, v, a

    return duration, profile


def _jerk_limited(distance: float, velocity: float, acceleration: float, jerk: float):
    """:func:`rest_to_rest` with a jerk limit, by ruckig's time-optimal offline profile of one degree of freedom."""
    import ruckig

    otg = ruckig.Ruckig(1)
    inp = ruckig.InputParameter(1)
    inp.current_position, inp.target_position = [0.0], [float(distance)]
    inp.current_velocity = inp.current_acceleration = inp.target_velocity = inp.target_acceleration = [0.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [velocity], [acceleration], [jerk]
    trajectory = ruckig.Trajectory(1)
    result = otg.calculate(inp, trajectory)
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise ConfigError(f"ruckig found no jerk-limited profile ({result})", field="jerk", value=jerk)
    duration = float(trajectory.duration)

    def profile(t):
        t = np.clip(np.asarray(t, dtype=np.float64), 0.0, duration)
        out = np.array([[x[0] for x in trajectory.at_time(float(ti))[:3]] for ti in t]).reshape(len(t), 3)
        return out[:, 0], out[:, 1], out[:, 2]

    return duration, profile


def _limits(value, d: int, name: str) -> np.ndarray:
    out = np.broadcast_to(np.asarray(value, dtype=np.float64), (d,)).copy()
    if not np.all(np.isfinite(out)) or np.any(out <= 0):
        raise ConfigError(f"must be positive and finite, one per coordinate ({d})", field=name, value=out.tolist())
    return out


def corners(configurations: np.ndarray) -> np.ndarray:
    """The path without repeated states and without the states inside straight runs (where it does not turn)."""
    q = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
    keep = [q[0]]
    for x in q[1:]:
        if np.linalg.norm(x - keep[-1]) > 0.0:
            keep.append(x)
    out = [keep[0]]
    for i in range(1, len(keep) - 1):
        u, w = keep[i] - out[-1], keep[i + 1] - keep[i]
        cos = float(u @ w) / (np.linalg.norm(u) * np.linalg.norm(w))
        if math.acos(min(1.0, max(-1.0, cos))) > COLLINEAR:
            out.append(keep[i])
    if len(keep) > 1:
        out.append(keep[-1])
    return np.array(out)


def time_parameterize(configurations, velocity, acceleration, jerk=None) -> Trajectory:
    """The time-optimal trajectory along the piecewise-linear path ``configurations`` (``(k, d)``) that stops at its
    corners, within the ``(d,)`` (or scalar) velocity, acceleration and optional jerk limits (module docstring)."""
    q = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
    if q.ndim != 2 or len(q) == 0 or not np.all(np.isfinite(q)):
        raise DimensionError("must be a non-empty (k, d) array of finite configurations", field="path",
                             value=list(np.shape(configurations)))
    d = q.shape[1]
    v, a = _limits(velocity, d, "velocity"), _limits(acceleration, d, "acceleration")
    j = None if jerk is None else _limits(jerk, d, "jerk")
    knots = corners(q)
    times, profiles = [0.0], []
    for start, end in itertools.pairwise(knots):
        delta = np.abs(end - start)
        moving = delta > 0
        sv = float(np.min(v[moving] / delta[moving]))
        sa = float(np.min(a[moving] / delta[moving]))
        if j is None:
            duration, profile = rest_to_rest(1.0, sv, sa)
        else:
            duration, profile = _jerk_limited(1.0, sv, sa, float(np.min(j[moving] / delta[moving])))
        times.append(times[-1] + duration)
        profiles.append(profile)
    return Trajectory(knots=knots, knot_times=np.array(times), velocity=v, acceleration=a, jerk=j,
                      _profiles=profiles)
