"""The planner ``tsrrt``: TS-RRT (Scholz & Stilman, "Combining Motion Planning and Optimization for Flexible Robot
Manipulation", poster ICHR 2010) -- learn push models of unfamiliar objects, plan in object space toward the
cheapest arrangement, execute with monitoring and replanning.

:meth:`TSRRTPlanner.plan` runs TASK_SPACE_RRT: lines 1-2 (LEARN_MODEL per object class, unless the pipeline's
``push-models`` learner or a models file supplies the models) and lines 3-14 (:mod:`pliant_tsrrt.search`).  The
result holds a :class:`PushPlan` policy: the action sequence with its predicted arrangements (and, as its path, the
paddle's pose before each push, from the scene's start to its goal).  Executing it
(:meth:`PushPlan.execute`, in any simulator that can place objects) performs each push, compares the observed
arrangement with the one the plan predicted after that push, and replans from the observed arrangement when an
object is off by more than ``replan_threshold`` (m) or ``replan_angle`` (rad), or when the plan is done and the
arrangement costs more than ``1 + finish_tolerance`` times the *first* plan's cost, until it does not or a
replanning finds nothing cheaper ("Robot monitored error and replanned as necessary").  A replanning tree starts with
the rest of the plan it replaces as one branch; the improvement phase of a replanning also connects to the first
plan's final arrangement.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import asdict, fields, is_dataclass, replace
from pathlib import Path as FilePath

import numpy as np
from pliant.api import (
    Budget,
    ConfigError,
    Path,
    Planner,
    PlannerSpecs,
    PlanningError,
    PlanningProblem,
    PlanResult,
    PliantError,
    Policy,
    Status,
    Termination,
    warm_up,
)

from pliant_tsrrt import domain
from pliant_tsrrt.learning import LearningArena, learn_models
from pliant_tsrrt.models import PushModels, footprints_from_scene, object_class, scene_pose, wrap
from pliant_tsrrt.options import PushOptions, TSRRTOptions, check_strokes
from pliant_tsrrt.pushing import N_PRIMITIVES, PRIMITIVES, decode_action, paddle_sweeps
from pliant_tsrrt.reference import random_arrangements
from pliant_tsrrt.search import ObjectSpace, grow


class TSRRTPlanner(Planner):
    """TS-RRT over the joint poses of the scene's movable objects (poster ICHR 2010).

    Statistics: ``iterations``, ``nodes`` (tree size), ``time`` (s, tree growth, improvement phase, descent and
    shortcut), ``refine_time``, ``refine_branch``, ``refine_pushes``, ``refine_targets``, ``refine_connects``,
    ``refine_gain`` (the improvement phase, :mod:`pliant_tsrrt.refine`),
    ``tree_time``, ``total_time`` (s, with learning), ``learn_time`` (s, when the models were learned here),
    ``actions``, ``actions_before_shortcut``, ``polish_pushes`` (appended by the final descent), ``beam_pushes``
    (appended by the final beam), ``start_cost``,
    ``tree_best_cost``, ``gd_samples``, ``random_samples``, ``invalid``, ``duplicates``, ``rewired``, ``exhausted``,
    ``cost_history`` (``[[t, best cost], ...]``), ``interrupted`` (Ctrl-C: the best plan so far is returned).
    """

    SPECS = PlannerSpecs(needs_simulator=True, needs_scene=True, returns_policy=True, anytime=True, spaces=("se2",),
                         work_unit="tree extensions")
    DEFAULT_BUDGET = Budget(max_time=5.0)
    Options = TSRRTOptions
    name = "tsrrt"
    example_scene = "tsrrt-table"
    example_components = {"simulator": "pymunk"}
    example_budget = {"max_iterations": 200}
    # the pipelines' paddle: with pymunk's default force cap (2000 N) a 5 cm push throws the 2 kg block 34 cm, and
    # such chaotic pushes depend on the order of pymunk's contact pairs, which changes as bodies are placed
    example_component_options = {"simulator": {"max_force": 50.0}}

    def bind(self, context) -> None:
        """Attach to the pipeline; a scene TS-RRT cannot plan on (:func:`pliant_tsrrt.domain.check_scene`: objects
        rotated out of the plane, off the table or overlapping at the start; ``objects`` naming no movable object)
        is refused here, before anything is learned or planned."""
        super().bind(context)
        if context is not None and context.scene is not None:
            domain.movable_names(context.scene, self.options.objects)
            domain.check_scene(context.scene, self.options)
        if self.options.models in ("auto", ""):     # learned by pushing in this simulator (here or by a learner)
            domain.placing_simulator(getattr(context, "simulator", None), required=False)
        # one-off loading when the pipeline is built, not inside max_time (pliant.planning.warmup)
        warm_up(context)
        if context is not None and context.scene is not None:
            warm_kernels(context.scene, self.options, domain.movable_names(context.scene, self.options.objects))

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        o = self.options
        scene = problem.scene
        if scene is None:
            raise PlanningError("TS-RRT needs the scene (its objects and table)", field="scene")
        t0 = time.perf_counter()
        names = domain.movable_names(scene, o.objects)
        domain.check_scene(scene, o)
        options = self._option_dict()
        if o.start == "scene":
            # before learning: a start without the clearance margin is known at once
            s0 = np.array([scene_pose(scene, n) for n in names])
            table = domain.table_rect(scene, o.table)
            obs_fp, obs_poses, obstacle_names = domain.obstacles(scene, names, table, scene.resolution)
            margin = o.planning.margin
            check = domain.checker(footprints_from_scene(scene, names), obs_fp, obs_poses, table, margin)
            if check.in_collision(s0)[0]:
                why = domain.start_conflicts(check, s0, names, obstacle_names)
                return PlanResult(Status.INVALID_START, planner=self.name, options=options,
                                  message=f"the initial arrangement lacks the clearance margin ({margin} m): {why}")
        models, learn_time = self._models(problem, scene, names, rng)
        space = build_space(scene, o, models, names)
        space.warm_up()
        if o.start == "random":
            s0 = random_arrangements(space, rng, 1, clearance=o.start_clearance)[0]
        # the request's budget bounds the whole call: learning (models "auto" without a learner), the space's set-up
        # and the kernels' warm-up come off its max_time cap; max_iterations counts the tree's extensions, and the
        # improvement phase and the shortcut have their own work bounds (options), their time shares of the cap only
        # guard it (pliant_tsrrt.search.grow; docs/determinism.md)
        termination = self.stop_condition(problem, termination, t0)
        if o.replan_iterations is None:         # replanning during execution gets the request's work budget
            options["replan_iterations"] = getattr(termination, "max_iterations", None)
        found = grow(space, s0, rng, o, termination)
        stats = dict(found.statistics, learn_time=learn_time,
                     start_cost=float(space.cost.cost(s0[None])[0]), total_time=time.perf_counter() - t0)
        policy = PushPlan(names=names, start=s0, actions=found.actions, states=found.states, cost=found.cost,
                          options=options, models=models, strokes=space.strokes)
        return PlanResult(Status.SOLVED, path=paddle_path(space, problem, found.states, found.actions), policy=policy,
                          cost=found.cost, statistics=stats, planner=self.name,
                          options=options, message=f"{len(found.actions)} pushes to an arrangement of cost "
                                                   f"{found.cost:.4g} (start {stats['start_cost']:.4g})")

    def _option_dict(self) -> dict:
        return asdict(self.options)

    def _models(self, problem, scene, names, rng) -> tuple[PushModels, float]:
        o = self.options
        if o.models not in ("auto", ""):
            path = FilePath(o.models)
            if not path.is_file():
                raise ConfigError("no such models file (run the push-models learner first, or models = 'auto')",
                                  field="planner.models", value=o.models)
            return PushModels.load(path), 0.0
        learner = (self.context.extras.get("learner") if self.context is not None else None)
        learned = getattr(learner, "models", None)
        if isinstance(learned, PushModels) and all(object_class(n) in learned.models for n in names):
            return learned, 0.0
        world = domain.placing_simulator(problem.simulator)
        t0 = time.perf_counter()
        models, _ = learn_models(arena(world, scene, o), o.learning, rng, only=names)
        return models, time.perf_counter() - t0


class _StandInModels:
    """Push models for :func:`warm_kernels`: every primitive moves its object 2 cm along x."""

    def means(self, classes: list[str]) -> np.ndarray:
        out = np.zeros((len(classes), 6, 3))
        out[..., 0] = 0.02
        return out


def warm_kernels(scene, o: TSRRTOptions, names: list[str]) -> None:
    """Call TS-RRT's compiled kernels once (:meth:`ObjectSpace.warm_up`) on a stand-in of the planning space (the
    scene's objects, placeholder push models), so that loading them -- some seconds per process -- happens when the
    pipeline is built, not inside ``max_time``; a scene the stand-in cannot describe is left to planning."""
    try:
        build_space(scene, o, _StandInModels(), names).warm_up()
    except PliantError:
        pass


def paddle_path(space: ObjectSpace, problem: PlanningProblem, states: np.ndarray, actions: list[int]) -> Path:
    """The robot's side of a plan: the paddle's pose before each push, from the scene's start to its goal (SE(2))."""
    poses = [np.asarray(problem.start, dtype=np.float64)]
    for j, a in enumerate(actions):
        o, p, _ = space.decode(a)
        start, _, _ = paddle_sweeps(states[j][None], space.fp, space.push)
        q = start[0, o, p].copy()
        q[2] = float(wrap(q[2]))
        poses.append(q)
    poses.append(np.asarray(problem.goal, dtype=np.float64))
    return Path(np.array(poses), space_kind=problem.space.kind)


def replan_settings(o: TSRRTOptions, reason: str) -> TSRRTOptions:
    """The options of a replanning during execution: the improvement phase only when the plan is done (``reason``
    ``finish``) unless ``execution.replan_refine``."""
    if o.execution.replan_refine or reason == "finish":
        return o
    return replace(o, improvement=replace(o.improvement, refine=False))


def arena(world, scene, o: PushOptions) -> LearningArena:
    """The learning arena over every movable object of the scene (all of them may need parking)."""
    names = domain.movable_names(scene, ())
    table = domain.table_rect(scene, o.table)
    fixed_fp, fixed_poses, _ = domain.obstacles(scene, names, table, scene.resolution)
    fixed = [(p[:2].copy(), float(r)) for p, r in zip(fixed_poses, fixed_fp.radius)]
    return LearningArena(world, names, footprints_from_scene(scene, names), table, domain.bounds_rect(scene),
                         domain.push_settings(o, scene), fixed)


def build_space(scene, o: TSRRTOptions, models: PushModels, names: list[str]) -> ObjectSpace:
    """The planning domain for the objects ``names`` of ``scene`` under options ``o``."""
    fp = footprints_from_scene(scene, names)
    table = domain.table_rect(scene, o.table)
    obs_fp, obs_poses, _ = domain.obstacles(scene, names, table, scene.resolution)
    relations = domain.parse_relations(o.cost.relations, names)
    c = o.cost
    cost = domain.task_cost(fp, table, (c.w_orth, c.w_area, c.w_edge, c.w_setting), relations, c.setting_scale)
    check = domain.checker(fp, obs_fp, obs_poses, table, o.planning.margin)
    whole = np.asarray(models.means([object_class(n) for n in names]), dtype=np.float64)
    # a fraction of a stroke moves the object by the model's mean times the fraction, to first order: after the
    # guarded approach the paddle's travel is what moves it (execution.finish_scales measures the same assumption)
    strokes = tuple(float(f) for f in o.planning.strokes)
    means = np.concatenate([f * whole for f in strokes], axis=1)
    return ObjectSpace(fp, means, check, cost, domain.push_settings(o, scene), domain.bounds_rect(scene), strokes)


class PushPlan(Policy):
    """A TS-RRT plan: the planned objects' ``names``, the ``start`` arrangement ``(k, 3)``, the ``actions``
    (``P o + p``, ``P = 6 len(strokes)``: object ``o``, primitive ``p % 6`` of
    :data:`~pliant_tsrrt.pushing.PRIMITIVES` with the stroke ``strokes[p // 6]``, a fraction of the primitive's
    depth), the predicted ``states`` ``(m + 1, k, 3)`` and final ``cost``; with the planner's ``options`` and the
    ``models`` so that execution can replan after a round trip through JSON.  ``strokes`` defaults to the options'
    ``planning.strokes``; a plan saved before plans carried strokes pushes whole strokes only."""

    kind = "tsrrt-push-plan"
    #: executed by the core's one execution loop with :class:`pliant_tsrrt.execution.PushPlanStrategy`
    follower = "pliant_tsrrt.execution:follow_plan"

    def __init__(self, names, start, actions, states, cost, options, models: PushModels,
                 strokes: tuple[float, ...] | None = None) -> None:
        self.names = list(names)
        self.start = np.asarray(start, dtype=np.float64)
        self.actions = [int(a) for a in actions]
        self.states = np.asarray(states, dtype=np.float64)
        self.cost = float(cost)
        self.options = dict(options)
        self.models = models
        if strokes is None:
            planning = self.options.get("planning")
            strokes = planning.get("strokes", (1.0,)) if isinstance(planning, dict) else (1.0,)
        self.strokes = check_strokes(strokes, "policy.strokes")
        n = len(self.names) * self.n_prims
        bad = [a for a in self.actions if not 0 <= a < n]
        if bad:
            raise ConfigError(f"an action must be in [0, {n}) for {len(self.names)} objects and "
                              f"{len(self.strokes)} strokes", field="policy.actions", value=bad[0])

    @property
    def n_prims(self) -> int:
        """Actions per object: the six primitives per stroke."""
        return N_PRIMITIVES * len(self.strokes)

    def decode(self, action: int) -> tuple[int, int, float]:
        """Action ``a`` as ``(object, primitive of PRIMITIVES, stroke)`` (:func:`decode_action`)."""
        return decode_action(action, self.strokes)

    def describe(self) -> list[str]:
        """The actions as ``object primitive`` strings, with the stroke when it is a fraction (``fork-1 turn+ (0.25
        stroke)``)."""
        out = []
        for a in self.actions:
            o, p, f = self.decode(a)
            out.append(f"{self.names[o]} {PRIMITIVES[p]}" + ("" if f == 1.0 else f" ({f:g} stroke)"))
        return out

    def to_dict(self) -> dict:
        return {"kind": self.kind, "names": self.names, "start": self.start.tolist(), "actions": self.actions,
                "strokes": list(self.strokes), "steps": self.describe(), "states": self.states.tolist(),
                "cost": self.cost,
                "options": {k: list(v) if isinstance(v, tuple) else v for k, v in self.options.items()},
                "models": self.models.to_dict()}

    @classmethod
    def from_dict(cls, data: dict) -> PushPlan:
        try:
            return cls(data["names"], data["start"], data["actions"], data["states"], data["cost"], data["options"],
                       PushModels.from_dict(data["models"]), strokes=data.get("strokes"))
        except KeyError as exc:
            raise ConfigError("a TS-RRT plan needs names, start, actions, states, cost, options and models",
                              field=f"policy.{exc.args[0]}") from None


def options_from_dict(values: dict) -> TSRRTOptions:
    """A plan's options (as :meth:`PushPlan.to_dict` stores them; a plan saved before the options were grouped
    stores them flat, read without a warning)."""
    from pliant.api import build_options

    defaults = TSRRTOptions()
    groups = [getattr(defaults, f.name) for f in fields(defaults) if is_dataclass(getattr(defaults, f.name))]
    known = {f.name for f in fields(defaults)} | {f.name for g in groups for f in fields(g)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        return build_options(TSRRTOptions, {k: v for k, v in values.items() if k in known}, source="<plan>")


__all__ = ["PushPlan", "TSRRTOptions", "TSRRTPlanner", "build_space"]
