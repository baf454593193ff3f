"""Task-space goals: "the probe tip touches this point" (thesis 4.3.4).

A :class:`TaskSpaceGoal` is a robot point — a point in a rigid robot's body frame, or one of any
robot's body points by index — and a world target with a tolerance.  It is a goal region
(:meth:`TaskSpaceGoal.contains`) and a sampler of goal configurations (:meth:`TaskSpaceGoal.sample`):
a uniformly sampled configuration (random orientation for a rigid body) is moved until the tip is on
the target by damped least squares on the tip's Jacobian, taken by finite differences along the
space's tangent (``space.retract``), so it works for any robot and any space.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pliant.api import ConfigError, RobotModel, Space

__all__ = ["TaskSpaceGoal"]


class TaskSpaceGoal:
    """The tip of the robot within ``tolerance`` metres of ``target`` ``(3,)`` (world frame, metres).

    ``tip``: a point ``(3,)`` in the body frame of a rigid robot (:meth:`RobotModel.rigid_placement`);
    or ``tip_index``: the index of one of the robot's body points (any robot).
    ``valid``: the problem's validity test ``(n, d) -> bool (n,)`` for sampled goal configurations.
    """

    def __init__(self, robot: RobotModel, space: Space, target, tolerance: float, *, tip=None,
                 tip_index: int | None = None, valid: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        if robot is None:
            raise ConfigError("a task-space target needs a robot", field="planner.target", value=target)
        self.robot, self.space = robot, space
        self.target = np.asarray(target, dtype=np.float64)
        self.tolerance = float(tolerance)
        self.valid = valid
        if tip is not None:
            # a geometric probe (is the robot rigid?): any configuration answers it, and it influences no result
            if robot.rigid_placement(space.sample(np.random.default_rng(0), 1)) is None:
                raise ConfigError("a body-frame tip needs a rigid robot (use tip_index for others)",
                                  field="planner.tip", value=list(tip))
            self._local = np.asarray(tip, dtype=np.float64)
            self._index = None
        else:
            if tip_index is None or not 0 <= tip_index < robot.point_count():
                raise ConfigError(f"must be a body point index below {robot.point_count()}",
                                  field="planner.tip_index", value=tip_index)
            self._local, self._index = None, np.array([tip_index])

    def tip(self, q: np.ndarray) -> np.ndarray:
        """World position ``(n, 3)`` of the tip at configurations ``(n, d)`` (metres)."""
        q = np.atleast_2d(q)
        if self._index is not None:
            return self.robot.body_points(q, self._index)[:, 0]
        rot, pos, _ = self.robot.rigid_placement(q)
        return np.einsum("nij,j->ni", rot, self._local) + pos

    def contains(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: the tip within the tolerance of the target (a goal region for the planner)."""
        return np.linalg.norm(self.tip(q) - self.target, axis=-1) <= self.tolerance + 1e-12

    def jacobian(self, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
        """``(3, t)``: d(tip)/d(tangent motion) at one configuration ``(d,)``, by forward differences."""
        t = self.space.tangent_dim
        moved = self.space.retract(np.repeat(q[None], t, axis=0), h * np.eye(t))
        return (self.tip(moved) - self.tip(q[None])).T / h

    def project(self, q: np.ndarray, iterations: int = 30, damping: float = 1e-3) -> np.ndarray | None:
        """``q`` moved until the tip is on the target (damped least squares), or ``None`` if it did not converge."""
        for _ in range(iterations):
            error = self.target - self.tip(q[None])[0]
            if np.linalg.norm(error) <= 0.5 * self.tolerance:
                return q
            jac = self.jacobian(q)
            step = jac.T @ np.linalg.solve(jac @ jac.T + damping ** 2 * np.eye(3), error)
            q = self.space.enforce_bounds(self.space.retract(q, step))
        return q if self.contains(q[None])[0] else None

    def sample(self, rng: np.random.Generator, attempts: int = 20) -> np.ndarray | None:
        """A valid goal configuration ``(d,)`` (tip on the target), or ``None`` after ``attempts`` tries."""
        for _ in range(attempts):
            q = self.project(self.space.sample(rng, 1)[0])
            if q is not None and (self.valid is None or bool(self.valid(q[None])[0])):
                return q
        return None
