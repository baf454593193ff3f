"""The near-neighbour radius of RRT* (Karaman & Frazzoli 2011, Theorem 38; as OMPL's RRTstar computes it).

``r(n) = min(gamma * (log n / n) ** (1 / d), max_step)`` with ``d`` the dimension of the space's
tangent (R^n: n; SE(2): 3; SE(3): 6) and

``gamma = rewire_factor * (2 (1 + 1/d)) ** (1/d) * (mu(X) / zeta_d) ** (1/d)``

where ``mu(X)`` is the volume of the space measured in its own weighted metric (an upper bound of
the free space's volume, as in OMPL) and ``zeta_d`` the volume of the unit ball of R^d.  Karaman and
Frazzoli require ``gamma > gamma*`` (``rewire_factor > 1``) for asymptotic optimality.
"""

from __future__ import annotations

import math

import numpy as np
from pliant.api import CompoundSpace, ConfigError, RealVectorSpace, SE2Space, SE3Space, Space

__all__ = ["unit_ball_volume", "space_measure", "rrt_star_gamma", "near_radius"]


def unit_ball_volume(d: int) -> float:
    """Volume of the unit ball of R^d: ``pi^(d/2) / Gamma(d/2 + 1)``."""
    return math.pi ** (d / 2) / math.gamma(d / 2 + 1)


def space_measure(space: Space) -> float:
    """Volume of ``space`` in its own metric (units: metric units to the power ``space.tangent_dim``).

    R^n: ``prod(w_i (upper_i - lower_i))``.  SE(2): ``wt^2 * area * wr * 2 pi``.  SE(3):
    ``wt^3 * volume * wr^3 * 8 pi^2`` — SO(3) with the rotation angle as distance is the real
    projective 3-space of radius 2 (OMPL's ``acos |<q1, q2>|`` is half that angle: ``pi^2``).
    Compound spaces multiply their components' measures, each scaled by ``w^t`` of its weight.
    Other spaces raise :class:`~pliant.errors.ConfigError` (give ``gamma`` explicitly).
    """
    if isinstance(space, RealVectorSpace):
        return float(np.prod(space.weights * (space.upper - space.lower)))
    if isinstance(space, SE2Space):
        area = float(np.prod(space.upper - space.lower))
        return space.translation_weight ** 2 * area * space.rotation_weight * 2.0 * math.pi
    if isinstance(space, SE3Space):
        volume = float(np.prod(space.upper - space.lower))
        return space.translation_weight ** 3 * volume * space.rotation_weight ** 3 * 8.0 * math.pi ** 2
    if isinstance(space, CompoundSpace):
        return float(np.prod([w ** c.tangent_dim * space_measure(c) for w, c in zip(space.weights, space.components)]))
    raise ConfigError(f"no volume known for a {type(space).__name__}; set gamma", field="gamma", value=None)


def rrt_star_gamma(space: Space, rewire_factor: float = 1.1) -> float:
    """``gamma`` of the RRT* radius (metric units) for ``space``, ``rewire_factor`` times Karaman & Frazzoli's bound."""
    d = space.tangent_dim
    return rewire_factor * (2.0 * (1.0 + 1.0 / d) * space_measure(space) / unit_ball_volume(d)) ** (1.0 / d)


def near_radius(n: int, d: int, gamma: float, max_step: float) -> float:
    """RRT*'s ball radius for a tree of ``n`` nodes in dimension ``d``: ``min(gamma (log n / n)^(1/d), max_step)``."""
    if n < 2:
        return max_step
    return min(gamma * (math.log(n) / n) ** (1.0 / d), max_step)
