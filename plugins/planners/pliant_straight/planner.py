"""The straight-line planner: the simplest complete baseline of every pipeline.

It discretises the straight motion from start to goal in the space's metric and checks each
configuration with the problem's validity (bounds, collisions, the cost model's feasibility, extra checks)
and each motion between them with the core's collision checker at the resolution of the scene's voxels
(:meth:`PlanningProblem.motions_valid`), so a straight line through a wall is ``infeasible``, never solved.
The path cost is the discrete integral of the state cost along the motion (thesis Table 3.1's
"integral of costs incurred at each state"): ``sum_k c(q_k) * |q_k - q_{k-1}|``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from pliant.api import Path, Planner, PlannerSpecs, PlanningProblem, PlanResult, Status, Termination, option


@dataclass(frozen=True)
class StraightLineOptions:
    """Options of :class:`StraightLinePlanner`."""

    step: float = option(0.01, "largest distance between checked configurations (space metric units)",
                         minimum=1e-9)


class StraightLinePlanner(Planner):
    """Plan the straight motion start -> goal if every step along it is valid.

    Statuses: ``invalid start`` / ``invalid goal`` when an endpoint fails validity, ``infeasible``
    when an intermediate configuration or the motion between two does (the message gives the fraction
    travelled), else ``solved``.
    """

    SPECS = PlannerSpecs()

    Options = StraightLineOptions

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        t0 = time.perf_counter()
        space = problem.space
        start, goal, invalid = problem.checked_endpoints()

        def result(status, path=None, cost=float("nan"), message="", checked=0):
            return PlanResult(status, path=path, cost=cost, planner="straight", message=message,
                              options={"step": self.options.step},
                              statistics={"checked": checked, "time": time.perf_counter() - t0})

        if invalid is not None:
            return PlanResult.invalid_endpoint(invalid, "straight", {"step": self.options.step},
                                               {"checked": 0, "time": time.perf_counter() - t0})
        configs = space.discretize(start, goal, self.options.step)
        valid = problem.is_valid(configs)
        if valid.all():     # the motions between the checked states, at voxel resolution (index i: the motion's end)
            valid = np.concatenate([[True], problem.motions_valid(configs[:-1], configs[1:])])
        if not valid.all():
            first = int(np.argmin(valid))
            return result(Status.INFEASIBLE, checked=len(configs),
                          message=f"the straight motion is blocked {first / (len(configs) - 1):.0%} of the way")
        steps = space.distance(configs[:-1], configs[1:])
        cost = 0.0
        if problem.cost is not None:
            cost = float(np.sum(problem.cost.cost(configs[1:]) * steps))
        return result(Status.SOLVED, Path(configs, space_kind=space.kind), cost, checked=len(configs))


@dataclass(frozen=True)
class WaypointOptions:
    """Options of :class:`WaypointPlanner`."""

    waypoints: tuple[tuple[float, ...], ...] = option((), "intermediate configurations between start and goal")


class WaypointPlanner(Planner):
    """A given motion: start, the ``waypoints`` option, goal — checked for validity, not searched.

    For scripted motions: executing a known path through a simulator, or replaying a demonstration.
    Statuses as :class:`StraightLinePlanner`, checking every waypoint and every straight motion between
    consecutive ones (:meth:`PlanningProblem.motions_valid`): a scripted motion may touch an obstacle and slide
    along it, not pass through it.
    """

    SPECS = PlannerSpecs()

    Options = WaypointOptions

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        t0 = time.perf_counter()
        space = problem.space
        start, goal, invalid = problem.checked_endpoints()
        middle = [space.check(w, field=f"planner.waypoints[{i}]") for i, w in enumerate(self.options.waypoints)]
        configs = np.vstack([start, *middle, goal]) if middle else np.vstack([start, goal])
        stats = {"waypoints": len(configs)}
        if invalid is not None:
            return PlanResult(invalid, planner="waypoints", statistics=stats)
        valid = problem.is_valid(configs)
        stats["time"] = time.perf_counter() - t0
        if not valid.all():
            return PlanResult(Status.INFEASIBLE, planner="waypoints", statistics=stats,
                              message=f"waypoint {int(np.argmin(valid))} is not valid")
        motions = problem.motions_valid(configs[:-1], configs[1:])
        if not motions.all():
            i = int(np.argmin(motions))
            return PlanResult(Status.INFEASIBLE, planner="waypoints", statistics=stats,
                              message=f"the motion from waypoint {i} to waypoint {i + 1} collides")
        cost = float(np.sum(problem.cost.cost(configs))) if problem.cost is not None else 0.0
        return PlanResult(Status.SOLVED, path=Path(configs, space_kind=space.kind), cost=cost, planner="waypoints",
                          statistics=stats)
