"""The path-metric kind and the check of the paths it scores (every waypoint valid).
"""

from __future__ import annotations

import functools
from abc import abstractmethod
from typing import Any

import numpy as np

from pliant.components.base import Component
from pliant.components.checks import WRAPPED, check_rng
from pliant.components.problem import PlanningProblem
from pliant.errors import (
    DimensionError,
    PlanningError,
)
from pliant.results import Path


def checked_evaluate(method):
    """Wrap a metric's ``evaluate(path, problem, rng)``: ``problem`` must be a
    :class:`~pliant.interfaces.PlanningProblem` (the space, scene and robot the path is scored in), ``rng`` a
    Generator and ``path`` a :class:`~pliant.results.Path` of finite ``(k, d)`` configurations of the problem's space
    (``k >= 1``) whose every waypoint is valid in the problem as a planner's states must be
    (:meth:`PlanningProblem.is_valid <pliant.interfaces.PlanningProblem.is_valid>`: inside the space's bounds,
    collision-free for the scene and the robot, feasible for the cost model).  Otherwise a
    :class:`~pliant.errors.PliantError` names ``problem``, ``rng`` or ``path[i]`` (with the obstacle, where the
    problem's checker can say) before the metric's code runs: no metric scores waypoints out of the workspace or
    inside an obstacle.  The motions between waypoints are not refused: judging what executing them meets is what a
    metric of execution under contact is for (the straight motions of thesis ch. 6's peg tasks meet the block the
    hole is cut in)."""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def evaluate(self, path, problem, rng, *args, **kwargs):
        from pliant.results import Path

        if not isinstance(problem, PlanningProblem):
            raise PlanningError("a metric scores a path in the PlanningProblem it was planned for (its space, scene "
                                "and robot); pass that problem", field="problem",
                                value=None if problem is None else type(problem).__name__)
        check_rng(rng)
        if not isinstance(path, Path):
            raise DimensionError("must be a pliant.results.Path", field="path", value=type(path).__name__)
        q = np.asarray(path.configurations, dtype=np.float64)
        space = problem.space
        if q.ndim != 2 or q.shape[1] != space.dim or len(q) == 0:
            raise DimensionError(f"must hold (k, {space.dim}) configurations of the problem's {space.kind} space, "
                                 "k >= 1", field="path", value=list(q.shape))
        finite = np.all(np.isfinite(q), axis=1)
        if not finite.all():
            i = int(np.argmin(finite))
            raise DimensionError("must be finite", field=f"path[{i}]", value=q[i].tolist())
        valid = np.asarray(problem.is_valid(q), dtype=bool).reshape(-1)
        if not valid.all():
            i = int(np.argmin(valid))
            checker = problem.checker
            if not np.all(space.is_valid(q[i:i + 1])):
                why = space.explain_invalid(q[i:i + 1]) or "is outside the space's bounds"
                if "bounds" in why and hasattr(space, "lower"):
                    why += f" {np.round(space.lower, 6).tolist()} .. {np.round(space.upper, 6).tolist()}"
            else:
                why = (checker.explain(q[i]) if checker is not None else None) or \
                    "infeasible for the cost model or the problem's validity check"
            raise PlanningError(f"waypoint {i} is not valid in this problem, so the path cannot be scored: {why}",
                                field=f"path[{i}]", value=q[i].tolist())
        return method(self, path, problem, rng, *args, **kwargs)

    setattr(evaluate, WRAPPED, True)
    return evaluate


class PathMetric(Component):
    """Scores a path (e.g. the reachable-volume quality metric of thesis ch. 6).

    The core checks ``evaluate``'s arguments before the plugin's code runs (:func:`pliant.contracts.checked_evaluate`):
    the problem, the rng, and a path whose every waypoint is valid in the problem (:meth:`PlanningProblem.is_valid`:
    in the space's bounds, collision-free, feasible), so that no metric scores waypoints out of the workspace or
    inside an obstacle.
    """

    kind = "metric"

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # the core checks evaluate's problem, rng and path (its waypoints' validity) before the plugin's code runs
        super().__init_subclass__(**kwargs)
        if "evaluate" in cls.__dict__:
            cls.evaluate = checked_evaluate(cls.__dict__["evaluate"])

    @abstractmethod
    def evaluate(self, path: Path, problem: PlanningProblem, rng: np.random.Generator) -> dict[str, float]:
        """Named scores of ``path`` (units documented by the plugin)."""
