"""The planners ``astar`` (one p) and ``astar-pareto`` (a sweep over p), thesis 3.2.3 and 3.3.1."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
from pliant.api import (
    Budget,
    BudgetExpired,
    ConfigError,
    Path,
    Planner,
    PlannerSpecs,
    PlanningError,
    PlanningProblem,
    PlanResult,
    Status,
    Termination,
    option,
    warm_up,
)

from pliant_astar.pareto import ParetoPoint, pareto_front, sweep
from pliant_astar.search import path_deformation, path_length, search

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class AStarOptions:
    """Options of :class:`AStarPlanner`."""

    p: float = option(0.5, "weight of deformation against path length in f = (1-p)(g+h) + p*DEFORM",
                      minimum=0.0, maximum=1.0)
    max_time: float | None = option(None, "deprecated: the request's wall-clock cap, planning.max_time ([planning] "
                                    "table)", minimum=0.0)


@dataclass(frozen=True)
class ParetoOptions:
    """Options of :class:`ParetoPlanner`."""

    values: int = option(101, "number of p values swept evenly over [0, 1]", minimum=2)
    select: str = option("knee", "which Pareto path the result carries: knee (closest to the utopia point "
                         "after normalisation), shortest or least-deformation",
                         choices=("knee", "shortest", "least-deformation"))
    max_time: float | None = option(None, "deprecated: the request's wall-clock cap, planning.max_time ([planning] "
                                    "table)", minimum=0.0)


class LatticeProblem:
    """A translation problem mapped onto the scene's voxel lattice: the cost field and the endpoints."""

    def __init__(self, problem: PlanningProblem) -> None:
        space = problem.space
        scene = problem.scene
        if space.kind != "rn" or space.dim != 3:
            raise PlanningError("A* plans 3-D translations: the robot's space must be r3", field="robot.space",
                                value=f"{space.kind} of dimension {space.dim}")
        if scene is None:
            raise PlanningError("A* needs the scene (its voxel lattice) in the problem", field="scene")
        self.scene = scene
        self.resolution = scene.resolution
        self.origin = scene.lower + 0.5 * scene.resolution
        self.shape = scene.shape
        self.start = self.cell(space.check(problem.start, field="start"), "start")
        self.goal = self.cell(space.check(problem.goal, field="goal"), "goal")
        if problem.cost is not None:
            self.costs = np.asarray(problem.cost.translation_costs(self.origin, self.resolution, self.shape),
                                    dtype=np.float64)
        else:
            self.costs = np.zeros(self.shape)
        if np.all(np.isnan(self.costs)):
            raise PlanningError("the robot does not fit anywhere in the grid (every translation is infeasible)",
                                field="robot.parts", value=list(self.shape))
        if self.costs.shape != tuple(self.shape):
            raise PlanningError("the cost model returned a field of the wrong shape", field="cost",
                                value=list(self.costs.shape))

    def cell(self, q: np.ndarray, name: str) -> tuple[int, int, int]:
        idx = np.round((q - self.origin) / self.resolution).astype(int)
        if np.any(idx < 0) or np.any(idx >= np.array(self.shape)):
            raise PlanningError("lies outside the voxel lattice", field=name, value=q.tolist())
        return tuple(int(i) for i in idx)

    def valid(self, cell: tuple[int, int, int]) -> bool:
        return bool(np.isfinite(self.costs[cell]))

    def to_path(self, cells: np.ndarray) -> Path:
        return Path(self.origin + cells * self.resolution, space_kind="rn")


def _check_endpoints(lattice: LatticeProblem, t0: float, name: str) -> PlanResult | None:
    if not lattice.valid(lattice.start):
        return PlanResult(Status.INVALID_START, planner=name, message="the start is infeasible (NaN state cost)",
                          statistics={"time": time.perf_counter() - t0})
    if not lattice.valid(lattice.goal):
        return PlanResult(Status.INVALID_GOAL, planner=name, message="the goal is infeasible (NaN state cost)",
                          statistics={"time": time.perf_counter() - t0})
    return None


class AStarPlanner(Planner):
    """Exact A* over 26-connected 3-D translations with ``f = (1-p)(g+h) + p*DEFORM`` (thesis Algorithm 1).

    The state cost of every lattice cell is computed first, through the cost model's
    ``translation_costs`` (the voxel model correlates the robot with the environment), then a numba
    A* searches it.  ``cost`` in the result is the objective ``(1-p) * length + p * deformation``
    (length in voxels); ``statistics`` carries ``length_voxels``, ``deformation``, ``expanded``,
    ``field_time`` and ``search_time`` (s).
    """

    SPECS = PlannerSpecs(needs_cost=True, needs_scene=True, spaces=("r3",),
                         work_unit="searches (one complete A* search: deterministic, no work budget needed)")
    DEFAULT_BUDGET = Budget()               # an exact search: it ends on its own; planning.max_time caps it

    Options = AStarOptions
    example_components = {"cost": "voxel"}

    def bind(self, context) -> None:
        """Attach to the pipeline and warm up (:func:`pliant.planning.warmup.warm_up`: one-off loading when the
        pipeline is built, not inside ``max_time``)."""
        super().bind(context)
        warm_up(context)

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        t0 = time.perf_counter()
        lattice = LatticeProblem(problem)
        t_field = time.perf_counter() - t0
        bad = _check_endpoints(lattice, t0, "astar")
        if bad is not None:
            return bad
        p = self.options.p
        t1 = time.perf_counter()
        termination = self.stop_condition(problem, termination, t0)
        with termination.watch():
            try:
                with termination.interruptible():       # the search checks the budget every CHUNK expansions
                    cells, expanded, objective = search(lattice.costs, lattice.start, lattice.goal, p)
            except BudgetExpired:
                stats = {"p": p, "field_time": t_field, "search_time": time.perf_counter() - t1,
                         "time": time.perf_counter() - t0, "interrupted": termination.interrupted}
                return PlanResult(Status.TIMEOUT, planner="astar", statistics=stats, options=self._option_dict(),
                                  message="the search did not reach the goal within the budget")
        stats = {"p": p, "expanded": expanded, "field_time": t_field, "search_time": time.perf_counter() - t1}
        if cells is None:
            stats["time"] = time.perf_counter() - t0
            return PlanResult(Status.INFEASIBLE, planner="astar", statistics=stats, options=self._option_dict(),
                              message="the search exhausted the lattice without reaching the goal")
        stats.update(length_voxels=path_length(cells), deformation=path_deformation(lattice.costs, cells),
                     time=time.perf_counter() - t0)
        return PlanResult(Status.SOLVED, path=lattice.to_path(cells), cost=objective, planner="astar",
                          statistics=stats, options=self._option_dict())

    def _option_dict(self) -> dict:
        return {"p": self.options.p, "max_time": self.options.max_time}


class ParetoPlanner(Planner):
    """Sweep p over [0, 1] with exact A* and keep the distinct Pareto-optimal paths (thesis 3.3.1).

    The result's path is one Pareto path chosen by ``select``; ``statistics["pareto"]`` lists every
    Pareto path as ``{p_values, length_voxels, deformation}`` and ``statistics["sweep"]`` every
    ``(p, length, deformation)`` of the sweep.  Ctrl-C stops the sweep with the front found so far.
    """

    SPECS = PlannerSpecs(needs_cost=True, needs_scene=True, spaces=("r3",), work_unit="p values searched")
    DEFAULT_BUDGET = Budget()               # the whole sweep; planning.max_iterations stops after that many p values

    Options = ParetoOptions
    example_components = {"cost": "voxel"}

    def bind(self, context) -> None:
        """Attach to the pipeline and warm up (:func:`pliant.planning.warmup.warm_up`: one-off loading when the
        pipeline is built, not inside ``max_time``)."""
        super().bind(context)
        warm_up(context)

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        t0 = time.perf_counter()
        lattice = LatticeProblem(problem)
        bad = _check_endpoints(lattice, t0, "astar-pareto")
        if bad is not None:
            return bad
        termination = self.stop_condition(problem, termination, t0)
        with termination.watch():
            runs = sweep(lattice.costs, lattice.start, lattice.goal, np.linspace(0.0, 1.0, self.options.values),
                         termination)
        front = pareto_front(runs)
        stats = {"sweep": [[r.p, r.length, r.deformation] for r in runs], "values_done": len(runs),
                 "pareto": [{"p_values": pt.p_values, "length_voxels": pt.length, "deformation": pt.deformation}
                            for pt in front], "pareto_paths": [pt.cells.tolist() for pt in front],
                 "time": time.perf_counter() - t0}
        if not front:
            return PlanResult(Status.INFEASIBLE if len(runs) == self.options.values else Status.TIMEOUT,
                              planner="astar-pareto", statistics=stats, message="no path for any p")
        chosen = select_point(front, self.options.select)
        stats.update(length_voxels=chosen.length, deformation=chosen.deformation, p=chosen.p_values[0],
                     pareto_size=len(front))
        status = Status.SOLVED if len(runs) == self.options.values else Status.APPROXIMATE
        return PlanResult(status, path=lattice.to_path(chosen.cells), cost=chosen.deformation,
                          planner="astar-pareto", statistics=stats, options={"values": self.options.values},
                          message="" if status is Status.SOLVED else "the sweep was interrupted")


def select_point(front: list[ParetoPoint], how: str) -> ParetoPoint:
    """Pick one point of a Pareto front: ``knee``, ``shortest`` or ``least-deformation``."""
    if how == "shortest":
        return min(front, key=lambda pt: (pt.length, pt.deformation))
    if how == "least-deformation":
        return min(front, key=lambda pt: (pt.deformation, pt.length))
    if how != "knee":
        raise ConfigError("unknown selection", field="planner.select", value=how)
    lengths = np.array([pt.length for pt in front])
    deform = np.array([pt.deformation for pt in front])
    span_l = max(lengths.max() - lengths.min(), 1e-12)
    span_d = max(deform.max() - deform.min(), 1e-12)
    dist = np.hypot((lengths - lengths.min()) / span_l, (deform - deform.min()) / span_d)
    return front[int(np.argmin(dist))]
