"""Argument checks the core puts in front of every component's entry points.

A plugin's :meth:`~pliant.interfaces.Planner.plan`, :meth:`~pliant.interfaces.Simulator.reset` /
:meth:`~pliant.interfaces.Simulator.step`, :meth:`~pliant.interfaces.Controller.command` and
:meth:`~pliant.interfaces.PathMetric.evaluate` receive arguments that
were checked here first, so that every plugin -- built-in or third-party -- answers bad input with one
:class:`~pliant.errors.PliantError` naming the argument and its value instead of a traceback deep inside, or worse,
a result computed from garbage (a NaN command, a step of negative time, a robot placed outside the workspace).

The kinds in :mod:`pliant.interfaces` wrap their subclasses' methods with these checks when the subclass is
defined (``__init_subclass__``); a plugin author writes the method as usual.  The checks are cheap (a few array
tests per call), so they stay on in hot loops.
"""

from __future__ import annotations

import functools
import math
import time
from typing import Any

import numpy as np

from pliant.errors import DimensionError, PlanningError, SimulationError

#: the attribute that marks a method as already wrapped (a subclass of a subclass is not wrapped twice)
WRAPPED = "__pliant_checked__"


def check_rng(rng: Any, *, field: str = "rng") -> np.random.Generator:
    """``rng`` if it is a :class:`numpy.random.Generator`, else :class:`~pliant.errors.PlanningError` (randomness is
    explicit: ``numpy.random.default_rng(seed)``, never a bare seed or the legacy global state)."""
    if not isinstance(rng, np.random.Generator):
        raise PlanningError("must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed))", field=field,
                            value=rng)
    return rng


def check_duration(dt: Any, *, field: str = "dt") -> float:
    """``dt`` (s) as a float if finite and positive, else :class:`~pliant.errors.SimulationError`."""
    try:
        value = float(dt)
    except (TypeError, ValueError):
        raise SimulationError("must be a number of seconds", field=field, value=dt) from None
    if not math.isfinite(value) or value <= 0.0:
        raise SimulationError("must be a finite positive number of seconds", field=field, value=dt)
    return value


def check_vector(values: Any, size: int, *, field: str) -> np.ndarray:
    """``values`` as a finite float64 ``(size,)`` array, else :class:`~pliant.errors.DimensionError`."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise DimensionError(f"must be {size} numbers", field=field, value=values) from None
    if arr.shape != (size,):
        raise DimensionError(f"must be {size} numbers (shape ({size},))", field=field, value=np.shape(values))
    if not np.all(np.isfinite(arr)):
        raise DimensionError("must be finite", field=field, value=arr.tolist())
    return arr


def _space_of(component) -> Any:
    context = getattr(component, "context", None)
    if context is None or getattr(context, "scene", None) is None:
        return None
    try:
        return context.space
    except Exception:  # a context without a robot yet: nothing to check against
        return None


def checked_plan(method):
    """Wrap a planner's ``plan(problem, rng, termination=None)``: the problem must be a
    :class:`~pliant.interfaces.PlanningProblem` and ``rng`` a Generator; a problem with a scene and a robot gets
    their collision checker (:class:`pliant.planning.validity.ValidityChecker`) when it has none, and a successful
    result's path is re-checked (:func:`validated_result`)."""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def plan(self, problem, rng, *args, **kwargs):
        import dataclasses

        from pliant.interfaces import PlanningProblem

        if not isinstance(problem, PlanningProblem):
            raise PlanningError("must be a pliant.interfaces.PlanningProblem (PlanningProblem.from_context(context))",
                                field="problem", value=type(problem).__name__)
        check_rng(rng)
        started = time.perf_counter()
        if problem.checker is None and problem.scene is not None and problem.robot is None and problem.scene.objects:
            raise PlanningError("the scene has obstacles, and without the robot no path can be checked against them "
                                "(PlanningProblem.from_context(context) sets both)", field="robot", value=None)
        if problem.checker is None and problem.scene is not None and problem.robot is not None:
            from pliant.planning.validity import ValidityChecker

            # the planner's pipeline keeps one checker of its scene and robot: a problem built by hand for them (as
            # the PIIRL verification plans one per task) reuses it instead of rebuilding the grid (0.45 s per plan)
            context = getattr(self, "context", None)
            shared = (context is not None and getattr(context, "scene", None) is problem.scene
                      and getattr(context, "robot", None) is problem.robot)
            checker = ValidityChecker.from_context(context) if shared else ValidityChecker(problem.scene, problem.robot)
            problem = dataclasses.replace(problem, checker=checker)
        result = method(self, problem, rng, *args, **kwargs)
        region = self.goal_region(problem) if hasattr(self, "goal_region") else None
        if region is not None:
            problem = dataclasses.replace(problem, goal_region=region)
        result = validated_result(problem, result)
        _record_budget(self, result, args[0] if args else kwargs.get("termination"), time.perf_counter() - started)
        return result

    setattr(plan, WRAPPED, True)
    return plan


def validated_result(problem, result):
    """``result`` unchanged unless it reports success (solved or approximate) with a path the problem's validity
    does not accept; then a copy with status ``invalid path``, no path and no policy, the reason in ``message``
    and ``statistics["validity"]`` (DESIGN rule 11: "solved" means valid).  Every state is checked, and every
    motion between consecutive states unless the result carries a policy (a policy's motions are its actions,
    executed -- and simulated while planning -- with contact; its path lists their outcomes, checked as states within
    the simulator's contact slop, ``Simulator.start_tolerance``).  Results without a path, or of a problem without a
    collision checker, pass unchanged."""
    import dataclasses

    from pliant.results import PlanResult, Status

    if not isinstance(result, PlanResult) or not result.status.success or result.path is None:
        return result
    if problem.checker is None:
        return result
    configurations = result.path.configurations
    if result.policy is not None:
        if configurations.ndim != 2 or configurations.shape[1] != problem.space.dim:
            return result               # a policy's path in another space (e.g. objects): the policy's own checks
        # simulated outcomes: collision-free up to the simulator's contact slop; the cost model is not asked (a
        # state in contact within the slop may be NaN for it)
        slop = float(getattr(problem.simulator, "start_tolerance", 0.0) or 0.0)
        ok = problem.checker.states_valid(configurations, tolerance=slop)
        if problem.validity is not None and ok.any():
            ok &= np.asarray(problem.validity(configurations), dtype=bool)
        if ok.all():
            result.statistics.setdefault("validity", {"valid": True, "checked_states": len(configurations)})
            return result
        i = int(np.argmin(ok))
        reason = (f"state {i} {np.round(configurations[i], 6).tolist()} is not valid: "
                  f"{problem.checker.explain(configurations[i]) or 'infeasible'}")
        verdict = {"valid": False, "index": i, "kind": "state", "reason": reason}
    else:
        found = problem.path_verdict(configurations)
        if found.valid:
            result.statistics.setdefault("validity", {"valid": True, "checked_states": found.checked_states})
            return _goal_checked(problem, result)
        reason = found.reason
        verdict = {"valid": False, "index": found.index, "kind": found.kind, "reason": reason,
                   "checked_states": found.checked_states}
    statistics = dict(result.statistics)
    statistics["validity"] = verdict
    statistics["reported_status"] = result.status.value
    return dataclasses.replace(result, status=Status.INVALID_PATH, path=None, policy=None, cost=math.nan,
                               statistics=statistics,
                               message=f"the planner reported {result.status.value}, but its path is not valid: "
                                       f"{reason}")


def _goal_checked(problem, result):
    """``result`` unchanged unless it reports ``solved`` with a path whose last state is not in the problem's goal
    (:meth:`PlanningProblem.in_goal`); then a copy with status ``approximate`` -- a valid path toward the goal, which
    is what it is -- and the distance left in ``message`` and ``statistics["goal"]``."""
    import dataclasses

    from pliant.results import Status

    if result.status is not Status.SOLVED or len(result.path.configurations) == 0:
        return result
    last = result.path.configurations[-1]
    if bool(problem.in_goal(last)[0]):
        return result
    left = float(np.asarray(problem.space.distance(last[None], problem.goal))[0]) if problem.goal_region is None \
        else math.nan
    statistics = dict(result.statistics)
    statistics["goal"] = {"reached": False, "distance": left, "tolerance": float(problem.goal_tolerance)}
    statistics["reported_status"] = result.status.value
    return dataclasses.replace(result, status=Status.APPROXIMATE, statistics=statistics,
                               message=f"the planner reported solved, but its path ends {left:.6g} from the goal "
                                       f"(tolerance {problem.goal_tolerance:.6g}): approximate")


def _record_budget(planner, result, termination, seconds: float) -> None:
    """Put the budget the plan ran under (``statistics["budget"]``: ``max_time`` s, ``max_iterations``; the
    termination's if one was passed, else the planner's options) and the wall time of the whole ``plan`` call
    (``statistics["planning_time"]``, s) on the result, for reports and budget benchmarks (docs/architecture.md)."""
    from pliant.results import PlanResult
    from pliant.termination import budget

    if not isinstance(result, PlanResult):
        return
    if termination is not None:
        limits = budget(termination)
    else:
        options = getattr(planner, "options", None)
        limits = {key: getattr(options, key, None) for key in ("max_time", "max_iterations")}
    result.statistics["budget"] = limits
    result.statistics["planning_time"] = seconds


#: set on a simulator once its stepping state is known to be a free start (a checked ``reset``, or a checked first
#: ``step`` from the state ``bind`` left)
START_CHECKED = "_pliant_start_checked"

#: at most this many offending indices are listed in the error of a batch
LISTED_STARTS = 8


def check_starts(simulator, starts: np.ndarray, *, field: str, single: bool = False) -> None:
    """Refuse configurations ``starts`` ``(n, d)`` that put the robot inside a rigid obstacle.

    The simulator measures (:meth:`~pliant.interfaces.Simulator.start_penetration`, m per configuration; ``None``:
    it cannot tell, nothing is refused) and tolerates :attr:`~pliant.interfaces.Simulator.start_tolerance` (m, the
    contact slop of its own states).  Deeper (or NaN) is a :class:`~pliant.errors.SimulationError` naming the field
    (``field`` for one configuration, ``field[k]`` for the first offending one of a batch, with the others' indices
    listed), the configuration and, where the simulator can say, the obstacle.  Nothing is simulated then.
    """
    if len(starts) == 0:
        return
    depth = simulator.start_penetration(starts)
    if depth is None:
        return
    depth = np.asarray(depth, dtype=np.float64).reshape(-1)
    tolerance = float(simulator.start_tolerance)
    bad = np.nonzero(~(depth <= tolerance))[0]
    if len(bad) == 0:
        return
    k = int(bad[0])
    name = field if single else f"{field}[{k}]"
    what = simulator.describe_obstacle(starts[k]) or "an obstacle"
    amount = "at an unknown depth" if not math.isfinite(depth[k]) else f"{depth[k]:.4g} m"
    message = (f"places the robot {amount} inside {what} (this simulator tolerates {tolerance:.4g} m of contact); "
               "start it in free space")
    if len(bad) > 1:
        listed = ", ".join(str(int(i)) for i in bad[:LISTED_STARTS]) + (", ..." if len(bad) > LISTED_STARTS else "")
        message += f"; {len(bad)} of the {len(starts)} {field} are inside: indices {listed}"
    raise SimulationError(message, field=name, value=np.asarray(starts[k]).tolist())


def checked_reset(method):
    """Wrap a simulator's ``reset(q)``: ``q`` must be a finite configuration inside the space's bounds (a robot placed
    outside the workspace would jump back in one step) that does not put the robot inside an obstacle
    (:func:`check_starts`).  A refused reset changes nothing."""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def reset(self, q, *args, **kwargs):
        space = _space_of(self)
        if space is not None:
            q = space.check(q, field="reset")
            if q.ndim != 1:
                raise DimensionError("must be one configuration", field="reset", value=list(q.shape))
            check_starts(self, q[None], field="reset", single=True)
        out = method(self, q, *args, **kwargs)
        if space is not None:
            self.__dict__[START_CHECKED] = True
        return out

    setattr(reset, WRAPPED, True)
    return reset


def checked_simulate(method):
    """Wrap a simulator's ``simulate(starts, targets, rng, duration, record=False)``: ``starts`` must be finite
    configurations of the space (``(n, d)`` or ``(d,)``), none of them inside an obstacle (:func:`check_starts`,
    naming ``starts[k]``); a refused batch simulates no particle."""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def simulate(self, starts, *args, **kwargs):
        space = _space_of(self)
        if space is not None:
            from pliant.interfaces import check_batch

            checked, single = check_batch(starts, space, "starts")
            check_starts(self, checked, field="starts", single=single)
        return method(self, starts, *args, **kwargs)

    setattr(simulate, WRAPPED, True)
    return simulate


def checked_step(method):
    """Wrap a simulator's ``step(velocity, dt, rng)``: a finite velocity per tangent direction, a finite positive
    ``dt`` (s).  The first step from a state no checked ``reset`` placed (the one ``bind`` left) checks that state
    as a start (:func:`check_starts`, field ``step``)."""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def step(self, velocity, dt, *args, **kwargs):
        dt = check_duration(dt)
        rng = args[0] if args else kwargs.get("rng")
        if rng is not None:
            check_rng(rng)
        space = _space_of(self)
        if space is not None:
            velocity = check_vector(velocity, space.tangent_dim, field="velocity")
            if not self.__dict__.get(START_CHECKED, False):
                current = np.asarray(self.configuration(), dtype=np.float64).reshape(1, -1)
                check_starts(self, current, field="step", single=True)
                self.__dict__[START_CHECKED] = True
        return method(self, velocity, dt, *args, **kwargs)

    setattr(step, WRAPPED, True)
    return step


def checked_command(method):
    """Wrap a controller's ``command(q, target, dt)``: finite configurations of the space's size and a finite
    positive ``dt`` -- a NaN in means an error, not a NaN command out.  (No bounds check: a measured configuration
    may sit a hair outside a joint limit.)"""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def command(self, q, target, dt, *args, **kwargs):
        dt = check_duration(dt)
        space = _space_of(self)
        size = space.dim if space is not None else np.size(q)
        q = check_vector(q, size, field="q")
        target = check_vector(target, size, field="target")
        return method(self, q, target, dt, *args, **kwargs)

    setattr(command, WRAPPED, True)
    return command


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
        from pliant.interfaces import PlanningProblem
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


def space_label(space) -> str:
    """``"r3"`` for a 3-D real vector space (``"r<d>"`` for others), else the space's kind (``"se2"``...)."""
    return f"r{space.dim}" if space.kind == "rn" else space.kind


def check_planner(planner, context, *, source: str | None = None) -> None:
    """Reject a pipeline whose planner cannot work with what the pipeline has, before planning: a planner that
    forward-simulates without a simulator, one that needs a cost model (with a gradient) without one, one that
    needs the scene without one, or one given a space it does not plan in.  Raises
    :class:`~pliant.errors.PipelineError` naming the field at fault."""
    from pliant.errors import PipelineError

    specs = planner.specs
    name = type(planner).__name__
    if specs.needs_simulator and context.simulator is None:
        raise PipelineError(f"{name} plans by forward simulation and needs a simulator; add a [simulator] table "
                            "(e.g. name = \"kinematic\")", source=source, field="simulator", value=None)
    if specs.needs_cost and context.cost is None:
        raise PipelineError(f"{name} needs a cost model; add cost = \"voxel\"", source=source, field="cost",
                            value=None)
    if specs.needs_gradient and not getattr(context.cost, "has_gradient", False):
        raise PipelineError(f"{name} needs a cost model with a gradient (e.g. the voxel cost)", source=source,
                            field="cost", value=type(context.cost).__name__ if context.cost is not None else None)
    if specs.needs_scene and context.scene is None:
        raise PipelineError(f"{name} needs the scene", source=source, field="scene", value=None)
    if specs.spaces is not None and context.robot is not None:
        space = context.space
        if space_label(space) not in specs.spaces and space.kind not in specs.spaces:
            raise PipelineError(f"{name} plans in {', '.join(specs.spaces)} only; this robot's space is "
                                f"{space_label(space)}", source=source, field="planner", value=space_label(space))
