"""The planning request: space, start, goal, validity, cost and collision checker (:class:`PlanningProblem`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from pliant.components.context import Context
from pliant.components.controller import Controller
from pliant.components.cost import CostModel
from pliant.components.robot import RobotModel
from pliant.components.simulator import Simulator
from pliant.components.validity import ValidityChecker, Verdict
from pliant.results import Status
from pliant.spaces import Space
from pliant.termination import Budget


@dataclass
class PlanningProblem:
    """A query: the space, start, goal and what to consult (cost, simulator, robot, scene).

    goal_tolerance: distance (in the space's metric) within which the goal counts as reached.
    validity: optional extra check ``(n, d) -> bool (n,)``; the cost's NaN also marks infeasible states.
    goal_region: optional ``(n, d) -> bool (n,)`` replacing the goal configuration (task-space goals).
    checker: the scene's and robot's collision checker (:class:`pliant.planning.validity.ValidityChecker`);
    :meth:`from_context` sets it whenever the context has a scene and a robot, so :meth:`is_valid`,
    :meth:`motions_valid` and :meth:`path_verdict` check collisions with or without a cost model.  The core
    re-checks every successful result's path with it (:func:`pliant.contracts.checked_plan`).
    budget: the request's budget (:class:`pliant.termination.Budget`: ``max_iterations`` in the planner's work unit,
    ``max_time`` a wall-clock cap, ``stop_on_first``), for the whole ``plan`` call; a pipeline sets it from its
    ``[planning]`` table.  ``None``: the planner's defaults (docs/determinism.md).
    goal_states: optional ``(k, d)`` alternative goal configurations (``goal`` among them), e.g. the inverse-kinematics
    solutions of a task-space goal: reaching any of them within ``goal_tolerance`` reaches the goal (:meth:`in_goal`).
    """

    space: Space
    start: np.ndarray
    goal: np.ndarray
    goal_tolerance: float = 0.0
    cost: CostModel | None = None
    robot: RobotModel | None = None
    simulator: Simulator | None = None
    controller: Controller | None = None
    scene: Any = None
    validity: Callable[[np.ndarray], np.ndarray] | None = None
    goal_region: Callable[[np.ndarray], np.ndarray] | None = None
    checker: Any = None
    budget: Budget | None = None
    goal_states: np.ndarray | None = None

    @classmethod
    def from_context(cls, context: Context, start=None, goal=None, budget: Budget | dict | None = None
                     ) -> PlanningProblem:
        """The scene's task (or the given start/goal) with the context's components and the scene's and robot's
        collision checker; ``budget``: the request's budget (a :class:`~pliant.termination.Budget` or a
        ``[planning]`` table)."""

        scene = context.scene
        space = context.space
        start = scene.start if start is None else start
        goal = scene.goal if goal is None else goal
        return cls(space=space, start=np.asarray(start, dtype=np.float64), goal=np.asarray(goal, dtype=np.float64),
                   goal_tolerance=scene.goal_tolerance if scene is not None else 0.0, cost=context.cost,
                   robot=context.robot, simulator=context.simulator, controller=context.controller, scene=scene,
                   checker=ValidityChecker.from_context(context),
                   budget=None if budget is None else Budget.from_table(budget))

    def is_valid(self, q: np.ndarray, collisions: bool = True) -> np.ndarray:
        """Bool ``(n,)``: in the space's bounds, collision-free (:attr:`checker`), feasible for the cost, and
        passing ``validity``.  ``collisions=False`` leaves the collision check out, for states of a motion that
        :meth:`motions_valid` checks anyway."""
        q = np.atleast_2d(q)
        ok = np.asarray(self.space.is_valid(q), dtype=bool)
        if collisions and self.checker is not None and ok.any():
            ok &= self.checker.states_valid(q)
        if self.cost is not None and ok.any():
            ok &= self.cost.is_valid(q)
        if self.validity is not None and ok.any():
            ok &= np.asarray(self.validity(q), dtype=bool)
        return ok

    def motions_valid(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Bool ``(m,)``: both ends of each motion ``a[i] -> b[i]`` (``(m, d)`` or ``(d,)``, broadcast) are in the
        space's bounds and every instant of the motion (the space's interpolation) is collision-free, at the
        resolution of the scene's voxels (conservative advancement, :mod:`pliant.planning.validity`); only the
        bounds without a :attr:`checker`.  The states' cost feasibility and ``validity`` are :meth:`is_valid`'s
        (a planner checks them on the states it discretises anyway)."""
        a, b = np.broadcast_arrays(np.atleast_2d(np.asarray(a, dtype=np.float64)),
                                   np.atleast_2d(np.asarray(b, dtype=np.float64)))
        ok = np.asarray(self.space.is_valid(a), dtype=bool) & np.asarray(self.space.is_valid(b), dtype=bool)
        if self.checker is not None and ok.any():
            idx = np.nonzero(ok)[0]
            ok[idx] = self.checker.motions_valid(a[idx], b[idx])
        return ok

    def motion_is_valid(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Whether the single motion ``a -> b`` (``(d,)`` each) is valid (:meth:`motions_valid`)."""
        return bool(self.motions_valid(a, b)[0])

    def path_verdict(self, configurations: np.ndarray):
        """The :class:`pliant.planning.validity.Verdict` of a path ``(k, d)``: every state (bounds, collisions,
        cost feasibility, ``validity``) and every motion between consecutive states (collisions at voxel
        resolution)."""

        path = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
        if path.ndim != 2 or path.shape[1] != self.space.dim or not np.all(np.isfinite(path)):
            return Verdict(False, 0, "state", f"the path is not a sequence of finite {self.space.dim}-coordinate "
                                              "configurations")
        states = self.is_valid(path)
        if not states.all():
            i = int(np.argmin(states))
            why = self.checker.explain(path[i]) if self.checker is not None else None
            if why is None:
                why = ("outside the space's bounds" if not self.space.is_valid(path[i])
                       else "infeasible for the cost model or the problem's validity check")
            return Verdict(False, i, "state", f"state {i} {np.round(path[i], 6).tolist()} is not valid: {why}",
                           len(path))
        if self.checker is None:
            return Verdict(True, checked_states=len(path))
        return self.checker.path_verdict(path)

    def path_is_valid(self, configurations: np.ndarray) -> bool:
        """Whether every state and every motion of the path ``(k, d)`` is valid (:meth:`path_verdict`)."""
        return self.path_verdict(configurations).valid

    def checked_endpoints(self) -> tuple[np.ndarray, np.ndarray, Status | None]:
        """Start and goal as ``(d,)`` arrays, and ``invalid start`` / ``invalid goal`` if one is infeasible.

        Malformed endpoints (wrong length, NaN) raise :class:`~pliant.errors.DimensionError`.
        """
        start = self.space.check(self.start, field="start")
        goal = self.space.check(self.goal, field="goal")
        if not self.is_valid(start)[0]:
            return start, goal, Status.INVALID_START
        if self.goal_region is None and not self.is_valid(goal)[0]:
            return start, goal, Status.INVALID_GOAL
        return start, goal, None

    def densify(self, configurations: np.ndarray, step: float) -> np.ndarray:
        """The path ``(k, d)`` with states inserted so that consecutive ones are at most ``step`` apart."""
        configurations = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
        if len(configurations) < 2:
            return configurations.copy()
        return np.vstack([configurations[:1]] + [self.space.discretize(a, b, step)[1:]
                                                  for a, b in itertools.pairwise(configurations)])

    def path_cost(self, configurations: np.ndarray, step: float) -> float:
        """The discrete integral of the state cost along a path ``(k, d)``: ``sum_j c(q_j) |q_j - q_{j-1}|``.

        Each segment is discretised at ``step`` (space metric units) first, so the value does not depend
        on how many waypoints a planner kept (thesis Table 3.1: "the integral of costs incurred at each
        state in a trajectory"); 0 without a cost model.  NaN when a state is infeasible.
        """
        dense = self.densify(configurations, step)
        if self.cost is None or len(dense) < 2:
            return 0.0
        steps = np.asarray(self.space.distance(dense[:-1], dense[1:]), dtype=np.float64)
        return float(np.sum(self.cost.cost(dense[1:]) * steps))

    def in_goal(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: within ``goal_tolerance`` of the goal, or inside ``goal_region``."""
        q = np.atleast_2d(q)
        if self.goal_region is not None:
            return np.asarray(self.goal_region(q), dtype=bool)
        reached = self.space.distance(q, self.goal) <= self.goal_tolerance + 1e-12
        for goal in np.atleast_2d(self.goal_states) if self.goal_states is not None else ():
            reached |= self.space.distance(q, goal) <= self.goal_tolerance + 1e-12
        return reached
