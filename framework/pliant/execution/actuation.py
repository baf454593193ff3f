"""The actuator model shared by every simulator: which tangent directions rotate, and velocity limits.

Thesis ch. 5 limits rigid bodies by the norm of their translation (m/s) and of their rotation
(rad/s) separately; articulated robots are limited per joint.  Scaling keeps the command's direction.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pliant.errors import DimensionError
from pliant.execution.noise import ActuationNoise
from pliant.spaces import Space


def angular_mask(space: Space) -> np.ndarray:
    """Bool ``(t,)``: which tangent directions of ``space`` are rotations (SE(2)'s theta, SE(3)'s w)."""
    kinds = {"se2": [False, False, True], "se3": [False] * 3 + [True] * 3}
    if space.kind in kinds:
        return np.array(kinds[space.kind])
    if space.kind == "compound":
        return np.concatenate([angular_mask(c) for c in space.components])
    return np.zeros(space.tangent_dim, dtype=bool)


def limit_velocity(velocity: np.ndarray, angular: np.ndarray, linear_limit: float, angular_limit: float,
                   per_actuator: np.ndarray | None = None) -> np.ndarray:
    """Velocities ``(n, t)`` scaled into the limits, keeping their direction.

    With ``per_actuator`` limits ``(t,)`` every component is capped by one common factor; otherwise
    the norms of the translational and of the rotational parts are capped separately.
    """
    v = np.array(velocity, dtype=np.float64)
    if per_actuator is not None:
        ratio = np.max(np.abs(v) / per_actuator, axis=1, keepdims=True)
        return v / np.maximum(ratio, 1.0)
    for mask, lim in ((~angular, linear_limit), (angular, angular_limit)):
        if mask.any():
            norm = np.linalg.norm(v[:, mask], axis=1, keepdims=True)
            v[:, mask] /= np.maximum(norm / lim, 1.0)
    return v


def actuator_limits(space: Space, velocity_limit: float, angular_velocity_limit: float,
                    joint_velocity_limits=()) -> np.ndarray:
    """Speed limit ``(t,)`` of every actuator: ``joint_velocity_limits`` when given (one per tangent
    coordinate), else ``angular_velocity_limit`` (rad/s) for rotations and ``velocity_limit`` (m/s or rad/s)
    for the rest.  Raises :class:`DimensionError` naming ``simulator.joint_velocity_limits``."""
    t = space.tangent_dim
    if joint_velocity_limits:
        if len(joint_velocity_limits) != t:
            raise DimensionError(f"needs one limit per actuator ({t})", field="simulator.joint_velocity_limits",
                                 value=list(joint_velocity_limits))
        return np.asarray(joint_velocity_limits, dtype=np.float64)
    return np.where(angular_mask(space), angular_velocity_limit, velocity_limit)


@dataclass(frozen=True)
class ControlLaw:
    """The control law a simulator applies each control step, for components that must predict it.

    Thesis eq. 8.1-8.2 (app. B) and eq. 6.5-6.6: each step of ``dt`` seconds commands the tangent displacement
    ``kp * e`` (``e = space.difference(target, q)``), capped by :func:`limit_velocity` (keeping its direction),
    and the actuators add noise drawn from ``noise`` (:mod:`pliant.execution.noise`).  The path metric of thesis ch. 6
    propagates reachable volumes with it.  ``kd`` (on the change of the error) is recorded, but
    :meth:`velocity` is the proportional part only: a reachable volume has no previous error.

    space: the configuration space.
    kp: fraction of the error commanded per step (dimensionless).
    kd: derivative gain per step.
    dt: control period (s).
    angular: bool ``(t,)`` rotation directions (:func:`angular_mask`).
    linear_limit / angular_limit: speed limits (m/s, rad/s) of the translational and rotational parts.
    per_actuator: ``(t,)`` per-actuator limits instead, or ``None``.
    noise: the actuation noise model.
    noise_draws: ``(q (n, d), velocity (n, t)) -> int``, how many independent noise draws the simulator averages
        over one step (a simulator that draws noise per microstep, as the kinematic one does), or ``None`` for one
        draw per step.  The spread of a step's noise shrinks with the square root of the draws.
    """

    space: Space
    kp: float
    kd: float
    dt: float
    angular: np.ndarray
    linear_limit: float
    angular_limit: float
    per_actuator: np.ndarray | None
    noise: ActuationNoise
    noise_draws: Callable[[np.ndarray, np.ndarray], int] | None = None

    def velocity(self, q: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Commanded tangent velocities ``(n, t)`` (m/s, rad/s) at configurations ``(n, d)`` toward ``target``."""
        error = self.space.difference(np.broadcast_to(target, np.shape(q)), q)
        return limit_velocity(self.kp * np.atleast_2d(error) / self.dt, self.angular, self.linear_limit,
                              self.angular_limit, self.per_actuator)

    def step(self, q: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Noise-free configurations ``(n, d)`` one control step after ``q`` ``(n, d)``, with no obstacles."""
        return self.space.retract(q, self.velocity(q, target) * self.dt)

    def step_noise(self, rng: np.random.Generator, q: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        """The tangent displacement ``(n, t)`` the actuation error adds over one free step from ``q`` at
        ``velocity``: ``dt`` times the mean of the simulator's draws (:attr:`noise_draws`)."""
        draws = 1 if self.noise_draws is None else max(1, int(self.noise_draws(q, velocity)))
        total = np.zeros(np.shape(velocity))
        for _ in range(draws):
            total += self.noise.sample(rng, velocity)
        return total / draws * self.dt

    def noise_bounds(self, velocity: np.ndarray) -> np.ndarray:
        """Largest tangent displacement ``(n, t)`` the actuation error can add in one step at ``velocity``."""
        return self.noise.limits(velocity) * self.dt
