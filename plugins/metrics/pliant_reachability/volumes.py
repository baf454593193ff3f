"""Approximate reachable volumes of one waypoint-to-waypoint motion (thesis 6.4.1, eq. 6.1-6.8).

Coordinates.  A motion from waypoint ``a`` to waypoint ``b`` is described in the tangent coordinates of the
target, ``x = space.difference(q, b)`` (metres and radians; ``q = space.retract(b, x)``), so the target is
``x = 0``.  Distances and measures use the *weighted* coordinates ``w * x``, with the translation weight on
translations and the rotation weight on rotations (thesis 6.5: translation weighted by 10, so 0.25 is 2.5 cm
or 0.25 rad).

Volumes.  ``RV_0`` is the ``epsilon_reached`` ball around ``a`` (where the robot may be when ``b`` becomes its
target), bounded by the box of half-widths ``epsilon / w_d``.  Each further volume is the box bounding one
control step of every configuration of the previous one (eq. 6.1-6.2): the controller's noise-free step
(:class:`pliant.execution.actuation.ControlLaw`, which caps the command's norm like the simulator does) evaluated at the
box's corners, the centres of its faces, its centre and its point nearest the target (which, within one step
of the target, lands on it), widened per dimension by the largest displacement
the actuation error can add in one step (eq. 6.7-6.8 with ``F`` of eq. 6.14).  For a per-dimension
proportional controller these points give eq. 6.3-6.8's bounds exactly; with the norm cap they are a close
approximation.  The sequence ends with the first volume whose every evaluated point lies within
``epsilon_reached`` of ``b`` (the robot has then switched to the next target), or after ``max_volumes``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from pliant.api import ConfigError, ControlLaw


def tangent_weights(law: ControlLaw, translation_weight: float, rotation_weight: float) -> np.ndarray:
    """``(t,)`` weights of the tangent coordinates: rotations by ``rotation_weight``, the rest by
    ``translation_weight`` (joint-space robots: every joint by ``translation_weight``)."""
    return np.where(law.angular, rotation_weight, translation_weight).astype(np.float64)


def _box_points(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The corners, face centres and centre of a box and its point nearest the target (the origin),
    ``(2^t + 2t + 2, t)``."""
    t = len(lower)
    centre = 0.5 * (lower + upper)
    corners = np.array(list(itertools.product((0, 1), repeat=t)), dtype=np.float64)
    points = [lower + corners * (upper - lower)]
    faces = np.repeat(centre[None], 2 * t, axis=0)
    for d in range(t):
        faces[2 * d, d] = lower[d]
        faces[2 * d + 1, d] = upper[d]
    points += [faces, centre[None], np.clip(np.zeros(t), lower, upper)[None]]
    return np.concatenate(points)


@dataclass(frozen=True)
class ReachableVolumes:
    """The volumes ``RV_0..RV_n`` of the motion ``a -> b`` (thesis 6.4.1).

    start / target: waypoints ``a`` and ``b`` ``(d,)``.
    lower / upper: ``(n + 1, t)`` per-volume bounds in target-tangent coordinates (m, rad).
    weights: ``(t,)`` weights of the coordinates.
    epsilon: ``epsilon_reached`` (weighted units).
    law: the controller predicted.
    converged: whether the last volume lies within ``epsilon`` of ``b`` (else ``max_volumes`` stopped it).
    """

    start: np.ndarray
    target: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    weights: np.ndarray
    epsilon: float
    law: ControlLaw
    converged: bool

    def __len__(self) -> int:
        return len(self.lower)

    def measures(self) -> np.ndarray:
        """Weighted measure (volume) of each box, ``(n + 1,)`` (weighted units to the power ``t``)."""
        return np.prod((self.upper - self.lower) * self.weights, axis=1)

    def coordinates(self, q: np.ndarray) -> np.ndarray:
        """Target-tangent coordinates ``(n, t)`` of configurations ``(n, d)``."""
        return self.law.space.difference(np.atleast_2d(q), self.target)

    def configurations(self, x: np.ndarray) -> np.ndarray:
        """Configurations ``(n, d)`` of target-tangent coordinates ``(n, t)``."""
        return self.law.space.retract(np.broadcast_to(self.target, (len(x), len(self.target))), x)

    def distance_to_target(self, x: np.ndarray) -> np.ndarray:
        """Weighted distance ``(n,)`` of coordinates ``(n, t)`` to the target."""
        return np.linalg.norm(np.atleast_2d(x) * self.weights, axis=1)

    def contains(self, index: int, x: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: which coordinates lie in volume ``index``'s box (to within 1e-9, rounding)."""
        return np.all((x >= self.lower[index] - 1e-9) & (x <= self.upper[index] + 1e-9), axis=1)

    def sample_start_ball(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` configurations uniform in the ``epsilon`` ball around ``a`` (weighted tangent of ``a``)."""
        t = len(self.weights)
        direction = rng.standard_normal((n, t))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        radius = self.epsilon * rng.random(n) ** (1.0 / t)
        u = direction * radius[:, None] / self.weights
        return self.law.space.retract(np.broadcast_to(self.start, (n, len(self.start))), u)

    def sample(self, index: int, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` coordinates ``(n, t)``: uniform in the start ball for ``index`` 0, else in the volume's box."""
        if index == 0:
            return self.coordinates(self.sample_start_ball(rng, n))
        return self.lower[index] + rng.random((n, len(self.weights))) * (self.upper[index] - self.lower[index])


def reachable_volumes(law: ControlLaw, start: np.ndarray, target: np.ndarray, epsilon: float,
                      weights: np.ndarray, max_volumes: int = 200) -> ReachableVolumes:
    """Compute the approximate reachable volumes of the motion ``start -> target`` (eq. 6.1-6.8).

    ``epsilon`` is ``epsilon_reached`` in weighted units; ``weights`` ``(t,)`` from :func:`tangent_weights`.
    """
    if not (np.isfinite(epsilon) and epsilon > 0):
        raise ConfigError("must be a positive distance", field="epsilon_reached", value=epsilon)
    start = np.asarray(start, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    space = law.space
    centre = space.difference(start[None], target)[0]
    half = epsilon / weights
    lower, upper = [centre - half], [centre + half]
    converged = False
    for _ in range(max_volumes):
        x = _box_points(lower[-1], upper[-1])
        q = space.retract(np.broadcast_to(target, (len(x), len(target))), x)
        if np.all(np.linalg.norm(x * weights, axis=1) <= epsilon):
            converged = True
            break
        velocity = law.velocity(q, target)
        nxt = space.difference(space.retract(q, velocity * law.dt), target)
        noise = np.max(law.noise_bounds(velocity), axis=0)
        lower.append(np.min(nxt, axis=0) - noise)
        upper.append(np.max(nxt, axis=0) + noise)
    return ReachableVolumes(start, target, np.array(lower), np.array(upper), weights, float(epsilon), law, converged)
