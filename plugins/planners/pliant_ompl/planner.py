"""Any OMPL geometric planner as a pliant planner (``planner.name = "ompl"``, ``planner.algorithm = "BITstar"``).

The problem goes to OMPL as it is in pliant:

* the space (:mod:`pliant_ompl.spaces`): R^n (points, joints), SE(2), SE(3);
* validity: a state is valid when :meth:`PlanningProblem.is_valid` says so (bounds, the scene's and robot's
  collision checker, the cost model's feasibility, the problem's extra check); a motion is valid when every state
  along it at ``check_step`` is, and the motion itself is collision-free at voxel resolution
  (:meth:`PlanningProblem.motions_valid`) -- OMPL's motion validator is replaced by pliant's, so a path OMPL
  accepts is one the core's final check accepts;
* the objective of optimising planners (RRT*, InformedRRTstar, BITstar, ...): pliant's path cost, the integral of
  the state cost along the path discretised at ``check_step`` (:meth:`PlanningProblem.path_cost`) plus
  ``length_weight`` per unit of length, as pliant's RRT* minimises; without a cost model, the length;
* the seed: OMPL's global generator is seeded (``ompl.util.RNG.setSeed``) from the planner's ``numpy`` generator
  before the OMPL planner is made, so a seed gives the same path (OMPL's planners are single-threaded here; PRM and
  PRM* run a solution thread and timed phases, and are refused unless ``allow_nondeterministic``);
* the budget: the request's ``max_iterations`` counts OMPL's termination-condition checks (a custom
  ``PlannerTerminationCondition``; about one per planner iteration), ``max_time`` is a wall-clock cap, Ctrl-C
  stops the planner with its best path so far.

The result is an ordinary :class:`PlanResult` whose cost is recomputed by pliant on the returned path.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np
from pliant.api import (
    ConfigError,
    Path,
    Planner,
    PlannerSpecs,
    PlanningProblem,
    PlanResult,
    Status,
    Termination,
    option,
)

from pliant_ompl import parameters as declared_parameters
from pliant_ompl.spaces import KINDS, OMPLSpace


@dataclass(frozen=True)
class OMPLOptions:
    """Options of :class:`OMPLPlanner` (distances in the space's metric)."""

    algorithm: str = option("RRTConnect", "the OMPL geometric planner by its class name in ompl.geometric "
                            "(RRTConnect, RRTstar, BITstar, KPIECE1, ...: those the installed wheel binds; "
                            "docs/plugins/ompl.md)")
    parameters: dict | None = option(None, "the planner's own parameters by the names OMPL declares for it "  # noqa: RUF009
                                     "(e.g. {range = 0.05, goal_bias = 0.1}); checked against the declared ones")
    check_step: float | None = option(None, "motions are checked and their cost integrated every this distance "
                                      "(default: the scene resolution, else 1/100 of the space's extent)",
                                      minimum=1e-9)
    length_weight: float = option(0.0, "optimising planners: path cost = integral of the state cost + this x "
                                  "path length (without a cost model the cost is the length)", minimum=0.0)
    goal_tolerance: float | None = option(None, "distance to the goal that counts as reached (default: the "
                                          "scene's; 0: the goal state itself)", minimum=0.0)
    stop_on_first: bool = option(False, "optimising planners: return the first solution instead of improving it "
                                 "to the budget")
    allow_nondeterministic: bool = option(False, "run planners OMPL declares multithreaded (PRM, PRM*): their "
                                          "results depend on timing, not only on the seed")


@cache
def planner_properties(algorithm: str) -> dict:
    """What OMPL declares about ``algorithm``: ``optimizing``, ``multithreaded``, ``approximate`` (bools) and the
    declared ``parameters`` with their defaults; raises :class:`ConfigError` for a name the bindings do not have."""
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    available = ompl_algorithms()
    if algorithm not in available:
        raise ConfigError(f"not an OMPL geometric planner of the installed ompl wheel (available: "
                          f"{', '.join(available)})", field="planner.algorithm", value=algorithm)
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    try:
        space = ob.RealVectorStateSpace(1)
        bounds = ob.RealVectorBounds(1)
        bounds.setLow(0.0)
        bounds.setHigh(1.0)
        space.setBounds(bounds)
        si = ob.SpaceInformation(space)
        si.setStateValidityChecker(lambda s: True)
        si.setup()
        planner = getattr(og, algorithm)(si)
        text = planner.printProperties()
        params = declared_parameters.declared(planner)
    finally:
        ou.setLogLevel(level)

    def flag(label: str) -> bool:
        return any(line.startswith(label) and line.rstrip().endswith("Yes") for line in text.splitlines())

    return {"optimizing": flag("Can optimize solutions"), "multithreaded": flag("Multithreaded"),
            "approximate": flag("Reports approximate solutions"), "parameters": params}


def ompl_algorithms() -> list[str]:
    """The geometric planners the installed ``ompl`` wheel binds (class names of ``ompl.geometric``)."""
    from ompl import base as ob
    from ompl import geometric as og

    return sorted(n for n in dir(og) if isinstance(getattr(og, n), type) and issubclass(getattr(og, n), ob.Planner))


class OMPLPlanner(Planner):
    """An OMPL geometric planner on a pliant problem (module docstring).

    Statistics: ``algorithm``, ``iterations`` (termination-condition checks), ``validity_checks`` (states),
    ``motion_checks``, ``ompl_status`` (OMPL's own), ``ompl_cost`` (the objective as OMPL summed it), ``seed`` (given to
    OMPL), ``parameters`` (every declared parameter as set), ``optimizing``, ``deterministic``, ``time``,
    ``interrupted``.
    """

    Options = OMPLOptions
    name = "ompl"
    example_scene = "triple-wall"
    example_components = {"cost": "voxel"}
    example_budget = {"max_iterations": 2000}       # conformance: quick and deterministic

    def __init__(self, options=None, **kwargs) -> None:
        # ``--set planner.parameters.range=0.05``: dotted keys into the parameters table
        super().__init__(_fold_parameters(options) if isinstance(options, dict) else options,
                         **_fold_parameters(kwargs))
        o = self.options
        self.properties = planner_properties(o.algorithm)
        if self.properties["multithreaded"] and not o.allow_nondeterministic:
            raise ConfigError(f"OMPL declares {o.algorithm} multithreaded: its result depends on timing, not only "
                              "on the seed; set allow_nondeterministic = true to run it anyway",
                              field="planner.algorithm", value=o.algorithm)
        for name, value in (o.parameters or {}).items():
            if name not in self.properties["parameters"]:
                names = ", ".join(sorted(self.properties["parameters"])) or "none"
                raise ConfigError(f"OMPL's {o.algorithm} declares no such parameter (it declares: {names})",
                                  field=f"planner.parameters.{name}", value=value)

    @property
    def specs(self) -> PlannerSpecs:
        return PlannerSpecs(anytime=self.properties["optimizing"], spaces=KINDS,
                            work_unit="OMPL termination-condition checks (about one per planner iteration)")

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou

        o = self.options
        t0 = time.perf_counter()
        options = dataclasses.asdict(o)
        start, goal, invalid = problem.checked_endpoints()
        if invalid is not None:
            return PlanResult.invalid_endpoint(invalid, self.name, options)
        if problem.goal_region is not None:
            raise ConfigError("the ompl planner plans to a goal configuration; this problem has a goal region",
                              field="planner", value=o.algorithm)
        mapped = OMPLSpace(problem.space)
        step = o.check_step or (float(problem.scene.resolution) if problem.scene is not None
                                else float(mapped.ompl.getMaximumExtent()) / 100.0)
        tolerance = problem.goal_tolerance if o.goal_tolerance is None else o.goal_tolerance
        length_weight = o.length_weight if problem.cost is not None else (o.length_weight or 1.0)
        seed = int(rng.integers(1, 2**31 - 1))
        counts = {"iterations": 0, "validity_checks": 0, "motion_checks": 0}
        errors: list[BaseException] = []
        level = ou.getLogLevel()
        ou.setLogLevel(ou.LOG_NONE)       # OMPL logs an error when the seed is set a second time in a process
        ou.RNG.setSeed(seed)
        ou.setLogLevel(ou.LOG_ERROR)
        try:
            si = ob.SpaceInformation(mapped.ompl)
            configuration = mapped.configuration

            def state_valid(s) -> bool:
                counts["validity_checks"] += 1
                try:
                    return bool(problem.is_valid(configuration(s)[None])[0])
                except BaseException as exc:       # an error inside a C++ callback: stop and raise it after solve
                    errors.append(exc)
                    return False

            si.setStateValidityChecker(state_valid)
            validator = _MotionValidator(si, problem, configuration, step, counts, errors)
            si.setMotionValidator(validator)
            si.setup()
            pdef = ob.ProblemDefinition(si)
            pdef.setStartAndGoalStates(mapped.state(start), mapped.state(goal), max(float(tolerance), 1e-9))
            if problem.goal_states is not None:            # several goal states (e.g. inverse kinematics'): any
                goals = ob.GoalStates(si)
                for q in np.atleast_2d(problem.goal_states):
                    goals.addState(mapped.state(q))
                goals.setThreshold(max(float(tolerance), 1e-9))
                pdef.setGoal(goals)
            objective = None
            stop = self.stop_condition(problem, termination, t0, stop_on_first=o.stop_on_first)
            first = bool(getattr(stop, "stop_on_first", False))
            if self.properties["optimizing"]:
                objective = _Objective(si, problem, configuration, step, length_weight)
                # OMPL's optimising planners stop by themselves once a solution satisfies the threshold (most add
                # their solution to the problem only when they return): any solution when stopping on the first,
                # else none -- the budget stops them
                objective.setCostThreshold(ob.Cost(math.inf if first else -math.inf))
                pdef.setOptimizationObjective(objective)
            planner = getattr(og, o.algorithm)(si)
            planner.setProblemDefinition(pdef)
            planner.setup()
            settings = declared_parameters.apply(planner, dict(o.parameters or {}), o.algorithm)

            def should_stop() -> bool:
                if errors:
                    return True
                calls = counts["iterations"]
                counts["iterations"] += 1
                try:
                    return stop.should_stop(calls, solved=pdef.hasExactSolution())
                except BaseException as exc:
                    errors.append(exc)
                    return True

            with stop.watch():
                status = planner.solve(ob.PlannerTerminationCondition(should_stop))
            if errors:
                raise errors[0]
            ompl_status = str(status)
            exact = bool(pdef.hasExactSolution())
            if exact and first:
                stop.note_stop("solution")
            path = None
            ompl_cost = math.nan
            if pdef.hasSolution():
                solution = pdef.getSolutionPath()
                path = np.array([configuration(solution.getState(i)) for i in range(solution.getStateCount())])
                if objective is not None:
                    ompl_cost = float(solution.cost(objective).value())
        finally:
            ou.setLogLevel(level)
        stats = dict(counts, algorithm=o.algorithm, ompl_status=ompl_status, ompl_cost=ompl_cost, seed=seed,
                     parameters=settings, optimizing=self.properties["optimizing"],
                     deterministic=not self.properties["multithreaded"], time=time.perf_counter() - t0,
                     interrupted=stop.interrupted, check_step=step)
        if path is None or len(path) == 0:
            return PlanResult(Status.TIMEOUT, planner=self.name, statistics=stats, options=options,
                              message=f"OMPL's {o.algorithm} found no solution within the budget ({ompl_status})")
        path[0] = start                                   # exact endpoints (R^n is planned in weighted coordinates)
        for target in np.atleast_2d(problem.goal_states) if problem.goal_states is not None else [goal]:
            if exact and np.allclose(path[-1], target, rtol=0.0, atol=1e-9):
                path[-1] = target
        cost = problem.path_cost(path, step) + length_weight * float(problem.space.path_length(path))
        return PlanResult(Status.SOLVED if exact else Status.APPROXIMATE,
                          path=Path(path, space_kind=problem.space.kind), cost=cost, planner=self.name,
                          statistics=stats, options=options,
                          message="" if exact else f"OMPL's {o.algorithm} returned an approximate solution")


def _fold_parameters(values: dict) -> dict:
    """``values`` with keys ``parameters.<name>`` moved into the ``parameters`` table."""
    out = {k: v for k, v in values.items() if not str(k).startswith("parameters.")}
    dotted = {str(k)[len("parameters."):]: v for k, v in values.items() if str(k).startswith("parameters.")}
    if dotted:
        table = out.get("parameters")
        if table is not None and not isinstance(table, dict):
            raise ConfigError("must be a table of OMPL parameters", field="planner.parameters", value=table)
        out["parameters"] = {**(table or {}), **dotted}
    return out


def _make_motion_validator():
    from ompl import base as ob

    class MotionValidator(ob.MotionValidator):
        """pliant's motion validity: every state at ``step`` valid, and the motion collision-free at voxel
        resolution."""

        def __init__(self, si, problem, configuration, step, counts, errors) -> None:
            super().__init__(si)
            self.problem, self.configuration, self.step = problem, configuration, step
            self.counts, self.errors = counts, errors

        def checkMotion(self, s1, s2, *rest) -> bool:
            self.counts["motion_checks"] += 1
            try:
                a, b = self.configuration(s1), self.configuration(s2)
                states = self.problem.space.discretize(a, b, self.step)[1:]
                if not self.problem.is_valid(states, collisions=False).all():
                    return False
                return self.problem.motion_is_valid(a, b)
            except BaseException as exc:
                self.errors.append(exc)
                return False

    return MotionValidator


def _make_objective():
    from ompl import base as ob

    class Objective(ob.OptimizationObjective):
        """pliant's path cost: ``sum_j c(q_j) d(q_{j-1}, q_j)`` at ``step`` plus ``length_weight`` x length."""

        def __init__(self, si, problem, configuration, step, length_weight) -> None:
            super().__init__(si)
            self.problem, self.configuration, self.step = problem, configuration, step
            self.length_weight = length_weight

        def stateCost(self, s):
            if self.problem.cost is None:
                return ob.Cost(0.0)
            c = float(self.problem.cost.cost(self.configuration(s)[None])[0])
            return ob.Cost(c if math.isfinite(c) else math.inf)

        def motionCost(self, s1, s2):
            # PlanningProblem.path_cost of the motion (to rounding), in one interpolation and one cost call: the
            # motion split into ceil(d / step) equal parts, each state after the start weighted by the part's length
            # (every built-in space interpolates at constant speed along its geodesic)
            a, b = self.configuration(s1), self.configuration(s2)
            space = self.problem.space
            d = float(space.distance(a, b))
            c = self.length_weight * d
            if self.problem.cost is not None and d > 0.0:
                parts = max(1, math.ceil(d / self.step - 1e-9))
                t = np.arange(1, parts + 1, dtype=np.float64) / parts
                states = space.interpolate(a[None], b[None], t[:, None])
                c += float(np.sum(self.problem.cost.cost(states))) * (d / parts)
            return ob.Cost(c if math.isfinite(c) else math.inf)

        def motionCostHeuristic(self, s1, s2):
            # admissible: the state cost is >= 0, so the length term alone is a lower bound
            a, b = self.configuration(s1), self.configuration(s2)
            return ob.Cost(self.length_weight * float(self.problem.space.distance(a, b)))

    return Objective


def _MotionValidator(*args):
    return _classes()[0](*args)


def _Objective(*args):
    return _classes()[1](*args)


@lru_cache(maxsize=1)
def _classes():
    return _make_motion_validator(), _make_objective()
