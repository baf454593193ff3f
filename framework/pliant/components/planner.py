"""The planner kind, its declared capabilities (:class:`PlannerSpecs`), and the core's checks around ``plan``:
the problem and generator going in, the final validity and goal check of the result coming out (DESIGN rule 11).
"""

from __future__ import annotations

import functools
import math
import time
from abc import abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from pliant.components.base import Component
from pliant.components.checks import WRAPPED, check_rng, space_label
from pliant.components.problem import PlanningProblem
from pliant.errors import (
    PipelineError,
    PlanningError,
)
from pliant.results import PlanResult, Status
from pliant.termination import Budget, Condition, Termination, budget, budget_deprecation


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

        if not isinstance(problem, PlanningProblem):
            raise PlanningError("must be a pliant.interfaces.PlanningProblem (PlanningProblem.from_context(context))",
                                field="problem", value=type(problem).__name__)
        check_rng(rng)
        started = time.perf_counter()
        self.last_termination = None
        if problem.checker is None and problem.scene is not None and problem.robot is None and problem.scene.objects:
            raise PlanningError("the scene has obstacles, and without the robot no path can be checked against them "
                                "(PlanningProblem.from_context(context) sets both)", field="robot", value=None)
        if problem.checker is None and problem.scene is not None and problem.robot is not None:
            from pliant.components.validity import ValidityChecker

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
        given = args[0] if args else kwargs.get("termination")
        _record_budget(self, result, given if given is not None else getattr(self, "last_termination", None),
                       time.perf_counter() - started, problem, explicit=given is not None)
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

    from pliant.results import PlanResult

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


def _record_budget(planner, result, termination, seconds: float, problem=None, *, explicit: bool = False) -> None:
    """Put the budget the plan ran under on the result (``statistics["budget"]``: ``max_time`` s, ``max_iterations``
    in the planner's ``unit``, ``binding`` -- what stopped the planner: ``"iterations"``, ``"time"`` (a wall-clock
    budget: the result depends on the machine), ``"solution"``, ``"interrupted"``, or ``"done"`` when the search
    ended on its own -- and ``source``: ``"request"``, ``"termination"`` for a condition passed to ``plan``, or
    ``"options"`` for a planner that builds its own) and the wall time of the whole ``plan`` call
    (``statistics["planning_time"]``, s), for reports and budget benchmarks (docs/determinism.md)."""
    from pliant.results import PlanResult

    if not isinstance(result, PlanResult):
        return
    if termination is not None:
        request = getattr(termination, "request", None)
        limits = budget(termination) if request is None else {"max_time": request.max_time,
                                                               "max_iterations": request.max_iterations}
        binding = termination.stopped_by if isinstance(termination, Condition) else None
        source = "termination" if explicit else "request"
    else:
        options = getattr(planner, "options", None)
        limits = {key: getattr(options, key, None) for key in ("max_time", "max_iterations")}
        binding, source = None, "options"
    limits["unit"] = getattr(getattr(planner, "specs", None), "work_unit", "iterations")
    limits["binding"] = binding or ("interrupted" if result.statistics.get("interrupted") is True else "done")
    limits["source"] = source
    result.statistics["budget"] = limits
    result.statistics["planning_time"] = seconds


def check_planner(planner, context, *, source: str | None = None) -> None:
    """Reject a pipeline whose planner cannot work with what the pipeline has, before planning: a planner that
    forward-simulates without a simulator, one that needs a cost model (with a gradient) without one, one that
    needs the scene without one, or one given a space it does not plan in.  Raises
    :class:`~pliant.errors.PipelineError` naming the field at fault."""

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


@dataclass(frozen=True)
class PlannerSpecs:
    """What a planner handles and needs (after OMPL's ``PlannerSpecs``), so a pipeline that cannot work is rejected
    when it is built (:func:`pliant.contracts.check_planner`) instead of when it plans.

    needs_simulator: plans by forward-simulating (the pipeline must have a ``[simulator]``).
    needs_cost: needs a cost model (``[cost]``); needs_gradient: one whose ``has_gradient`` is true.
    needs_scene: needs the scene itself (e.g. its voxel lattice), not only the space and the checks.
    returns_policy: the result holds a policy rather than (only) a path.
    anytime: keeps improving its result until the termination condition stops it.
    spaces: the configuration spaces it plans in, as ``"r3"`` (a space kind and dimension) or a kind (``"rn"``,
    ``"se2"``, ``"se3"``, ``"compound"``); ``None``: any.
    work_unit: what one iteration of its work budget (``planning.max_iterations``) is, in words (``"samples"``,
    ``"extensions"``); recorded with the result's budget.
    """

    needs_simulator: bool = False
    needs_cost: bool = False
    needs_gradient: bool = False
    needs_scene: bool = False
    returns_policy: bool = False
    anytime: bool = False
    spaces: tuple[str, ...] | None = None
    work_unit: str = "iterations"


class Planner(Component):
    """Finds a path (or a policy) for a :class:`PlanningProblem`.

    ``SPECS`` declares what the planner handles and needs (:class:`PlannerSpecs`); a planner whose needs depend on
    its options overrides :attr:`specs`.
    """

    kind = "planner"
    SPECS: ClassVar[PlannerSpecs] = PlannerSpecs()
    #: the budget a request that sets none gets (the request's ``[planning]`` fields replace it field by field)
    DEFAULT_BUDGET: ClassVar[Budget] = Budget(max_time=60.0)
    #: the :class:`~pliant.termination.Condition` the last :meth:`plan` call ran under (set by :meth:`stop_condition`)
    last_termination: Condition | None = None

    @property
    def specs(self) -> PlannerSpecs:
        """This planner's :class:`PlannerSpecs` (with its options applied)."""
        return self.SPECS

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # the core checks plan's problem and rng before the plugin's code runs
        super().__init_subclass__(**kwargs)
        if "plan" in cls.__dict__:
            cls.plan = checked_plan(cls.__dict__["plan"])

    def request_budget(self, problem: PlanningProblem) -> Budget:
        """The budget of a ``plan`` call on ``problem``: the request's (:attr:`PlanningProblem.budget`, a pipeline's
        ``[planning]`` table), replaced field by field by the planner's deprecated ``max_time`` / ``max_iterations``
        options where they are set (with a :class:`~pliant.termination.BudgetDeprecationWarning` naming
        ``planning.max_iterations``); a request that sets neither a work nor a time budget gets
        :attr:`DEFAULT_BUDGET` (a work budget alone runs without a time cap, as it always did)."""
        options = getattr(self, "options", None)
        old = budget_deprecation(options) if options is not None else Budget()
        asked = (problem.budget or Budget()).merged(old)
        if asked.max_iterations is None and asked.max_time is None:
            return self.DEFAULT_BUDGET.merged(asked)
        return asked

    def stop_condition(self, problem: PlanningProblem, termination: Condition | None = None,
                    started: float | None = None, **rules) -> Condition:
        """The stop condition of a ``plan`` call: ``termination`` when the caller passed one, else the request's
        budget (:meth:`request_budget`) for the whole call since ``started`` (its ``time.perf_counter()``; the
        set-up comes off ``max_time``).  ``rules``: the planner's own defaults (``stop_on_first=...``, used when the
        request leaves them unset).  Remembered as :attr:`last_termination` for the result's budget record."""
        if termination is None:
            request = self.request_budget(problem)
            termination = request.termination(started, **rules)
            termination.request = request       # what the result records (max_time as asked, not what was left)
        self.last_termination = termination
        return termination

    def goal_region(self, problem: PlanningProblem) -> Callable[[np.ndarray], np.ndarray] | None:
        """The goal test the last :meth:`plan` aimed at when the planner replaces ``problem``'s goal (a task-space
        target given as a planner option): ``(n, d) -> bool (n,)``; ``None`` (the default): the problem's own.  The
        core's final check (:func:`pliant.contracts.validated_result`) judges "solved" against it."""
        return None

    @abstractmethod
    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        """Solve ``problem``; never returns ``None`` (see :class:`~pliant.results.Status`).  ``termination``: any
        :class:`pliant.termination.Condition` -- a :class:`Termination` or a combination (``any_of`` / ``all_of``);
        None: the planner's own from its options."""
