"""Executing a TS-RRT plan (:class:`~pliant_tsrrt.planner.PushPlan`) with monitoring and replanning ("Robot
monitored error and replanned as necessary", poster ICHR 2010): the plan's side of the core's one execution loop
(:func:`pliant.api.follow`).

:class:`PushPlanStrategy` performs each push of the plan as directives the loop carries out -- place the paddle (with
its placement error) and the objects where they were observed, then the push's open-loop velocity commands (a guarded
approach until the object moves, the push, the retreat, the settling time: :func:`pliant_tsrrt.pushing.push_steps`,
the one definition of a push, which the learner applies to its simulator directly) -- and, after each
push, compares the observed arrangement with the one the plan predicted.  It repairs or replans from the observed
arrangement when an object is off by more than ``replan_threshold`` (m) or ``replan_angle`` (rad), or when the plan is
done and the arrangement costs more than ``1 + finish_tolerance`` times the *first* plan's cost, until it does not or a
replanning finds nothing cheaper.  A replanning tree starts with the rest of the plan it replaces as one branch; the
improvement phase of a replanning also connects to the first plan's final arrangement.  A push whose paddle placement
the simulator refuses (a :class:`~pliant.api.SimulationError`: the noisy paddle lands in a wall) is skipped and
replanned.

The loop steps the world, records every control step, keeps the record when something raises and brings the robot to
rest; the record's :class:`PushPlanDetails` hold, per push, the object, the primitive, the predicted and observed
poses, the error (m, rad) and whether it triggered a replan or a repair (``actions``); the replans and repairs
(``adaptations``, ``repair: True`` for repairs); the final arrangement's cost, the arrangement itself and whether it
collides.  The outcome is ``success`` (plan completed, final arrangement collision-free and its cost within
``outcome_tolerance`` of the first plan's), ``above tolerance`` (completed and collision-free, but costlier than
that), ``failure`` (it collides, or a blocked push could not be replanned) or ``action limit``.  The controller is
not used: pushes are the primitives' velocity commands.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace

import numpy as np
from pliant.api import (
    ExecutionDetails,
    ExecutionOutcome,
    ExecutionRecord,
    Place,
    PlanningError,
    ScriptedStrategy,
    SimulationError,
    StepListener,
    Termination,
    follow,
)

from pliant_tsrrt import domain
from pliant_tsrrt.models import footprints_from_scene, object_class, relative
from pliant_tsrrt.planner import PushPlan, build_space, options_from_dict, replan_settings
from pliant_tsrrt.pushing import N_PRIMITIVES, PRIMITIVES
from pliant_tsrrt.pushing import push_steps as push_action
from pliant_tsrrt.refine import finishing_push
from pliant_tsrrt.repair import pose_errors
from pliant_tsrrt.repair import restore as repair_restore
from pliant_tsrrt.repair import retarget as repair_retarget
from pliant_tsrrt.repair import toward_goal as repair_toward_goal
from pliant_tsrrt.search import ObjectSpace, grow

#: most repairs of one object after its last push of the plan (``repair_placed``) in one execution: a noisy turn
#: may need a second one, but not a lottery of them
PLACE_TRIES = 3

#: finishing repairs or replannings (in one execution) that may fail to lower the arrangement's cost before execution
#: stops: their predictions use the models' mean pushes, and a second failure shows the noise outweighs them
FINISH_TRIES = 2

#: closed-loop finishing pushes (``execution.finish_steps``) in a row that may fail to lower the observed cost below
#: the lowest seen before the finishing falls back to a finishing repair or replanning (one: under noise, a second
#: and third such push raised it further)
FINISH_STALE = 1

#: ``adapt_models``: a push after which another object moved farther than this (m) does not update the models
ADAPT_STILL = 0.002

#: margin (m) of the final collision verdict and of replanning from a jammed arrangement: footprints shrunk by 1 mm, so
#: objects that merely touch (pymunk lets resting contacts overlap slightly) do not count as colliding
TOUCH = -0.001


def _room_for(space: ObjectSpace, observed: np.ndarray) -> ObjectSpace:
    """The space to replan in from ``observed``: the planning space, or -- when noise has brought objects closer than
    the clearance margin, so that every push would count as a collision -- the same with the largest margin, in 1 mm
    steps down to :data:`TOUCH`, that ``observed`` satisfies (objects resting against each other in the simulator
    overlap by a fraction of a millimetre)."""
    if not space.checker.in_collision(observed)[0]:
        return space
    margin = space.checker.margin - 0.001
    while margin > TOUCH:
        narrower = replace(space.checker, margin=margin)
        if not narrower.in_collision(observed)[0]:
            return replace(space, checker=narrower)
        margin -= 0.001
    return replace(space, checker=replace(space.checker, margin=TOUCH))


def _adapt(space: ObjectSpace, models, names: list[str], before: np.ndarray, after: np.ndarray, obj: int,
           prim: int) -> None:
    """``execution.adapt_models``: add the displacement of object ``obj`` by primitive ``prim`` observed from
    ``before`` to ``after`` (``(k, 3)``; a whole stroke) to its class's model, and the new mean to ``space`` (every
    object of the class, every stroke), unless another object moved by more than :data:`ADAPT_STILL` (then the push
    touched it, and the displacement is not the model's)."""
    others = np.arange(len(names)) != obj
    if np.any(np.linalg.norm(after[others, :2] - before[others, :2], axis=1) > ADAPT_STILL):
        return
    cls = object_class(names[obj])
    model = models.models[cls][prim]
    model.update(relative(before[obj], after[obj]))
    for i, n in enumerate(names):
        if object_class(n) == cls:
            for s, f in enumerate(space.strokes):       # and the same primitive's fractions of a stroke
                space.means[i, N_PRIMITIVES * s + prim] = f * model.mean


def _replanned(adaptations: list[dict]) -> int:
    """How many of an execution's adaptations were replannings (not repairs)."""
    return sum(1 for a in adaptations if not a.get("repair"))


def _repair_entry(space: ObjectSpace, after: int, cause: str, observed: np.ndarray, fix, names) -> dict:
    """An execution record's adaptation entry for a repair (:mod:`pliant_tsrrt.repair`)."""
    return {"after_action": after, "reason": cause, "repair": True,
            "cost_before": float(space.cost.cost(observed[None])[0]),
            "planned_cost": float(space.cost.cost(fix.states[-1][None])[0]), "actions": len(fix.actions),
            "repair_pushes": fix.pushes, "objects": [names[o] for o in fix.objects]}


@dataclass
class PushPlanDetails(ExecutionDetails):
    """A push plan's execution: the pushes performed (``actions``), the replans and repairs (``adaptations``), the
    final arrangement's cost (``final_cost``), the arrangement ``(k, 3)`` (``final_state``; ``None`` until the
    execution ends) and whether it collides (``collided``)."""

    kind = "tsrrt-push-plan"
    actions: list[dict] = field(default_factory=list)
    adaptations: list[dict] = field(default_factory=list)
    final_cost: float | None = None
    final_state: np.ndarray | None = None
    collided: bool | None = None

    def summary(self) -> list[tuple[str, str]]:
        return [("actions executed", str(len(self.actions)))]


class PushPlanStrategy(ScriptedStrategy):
    """Execute ``plan`` in a world that can place objects, on ``scene``, with monitoring and replanning (see the
    module's description); at most ``action_limit`` pushes; ``noise`` overrides the options' paddle placement noise
    (m)."""

    def __init__(self, plan: PushPlan, scene, *, action_limit: int = 100, noise: float | None = None) -> None:
        super().__init__()
        if scene is None:
            raise PlanningError("executing a TS-RRT plan needs the pipeline's context (its scene)", field="context")
        self.plan, self.scene, self.action_limit, self.noise = plan, scene, action_limit, noise
        self.record = PushPlanDetails()

    def details(self) -> PushPlanDetails:
        return self.record

    def script(self, rng):
        plan, scene = self.plan, self.scene
        # the plan's own strokes decode its actions (a plan saved before plans carried strokes has whole ones only)
        o = options_from_dict(plan.options)
        o = replace(o, planning=replace(o.planning, strokes=plan.strokes))
        if self.noise is not None:
            o = replace(o, push=replace(o.push, placement_noise=self.noise))
        e, imp = o.execution, o.improvement
        yield Place(np.asarray(scene.start, dtype=np.float64), {n: p for n, p in zip(plan.names, plan.start)})
        # adapt_models: the plan's models are updated with every push observed here (a copy: the plan keeps its own)
        models = copy.deepcopy(plan.models) if e.adapt_models else plan.models
        space = build_space(scene, o, models, plan.names)
        space.warm_up()
        push = domain.push_settings(o, scene)
        all_names = domain.movable_names(scene, ())
        fp_all = footprints_from_scene(scene, all_names)
        observed = plan.start.copy()
        actions, expected = list(plan.actions), plan.states
        # the first plan's final arrangement and cost: what every replanning connects back to, and what the arrangement
        # is judged against when a plan is done (a replanned plan may end higher than the first one)
        goal, goal_cost = plan.states[-1], plan.cost
        ceiling = goal_cost * (1 + e.finish_tolerance)     # an arrangement at or below it needs no finishing
        # replan_shortest: a replanning or repair need not end cheaper than the first plan; the fewest pushes win
        enough = goal_cost if e.replan_shortest else None
        records, replans = self.record.actions, self.record.adaptations
        outcome = ExecutionOutcome.SUCCESS
        blocked = 0
        repairs = 0
        stalled = False           # a replanning when the plan was done found nothing cheaper than the arrangement
        placed = [0] * len(plan.names)      # repairs of each object after its last push (repair_placed)
        finishing_from = None     # the arrangement's cost when the last finishing repair or replanning began
        steps_left = e.finish_steps   # closed-loop finishing pushes left (each planned from the observed arrangement)
        step_best, step_stale = np.inf, 0
        stepping = False          # the current action is a closed-loop finishing push: not monitored against a plan
        stroke = 1.0              # the finishing push's stroke, a fraction of its primitive's depth
        fruitless = 0             # finishing repairs and replannings that did not lower the cost
        j = 0
        while True:
            if j == len(actions):
                stepping = False
                # the plan is done: replan if the arrangement is clearly worse than the first plan's
                cost_now = float(space.cost.cost(observed[None])[0])
                if cost_now <= ceiling + 1e-12 or stalled:
                    break
                if steps_left > 0 and step_stale < FINISH_STALE and len(records) < self.action_limit:
                    # closed-loop finishing: the single push (of a whole or a fraction of a stroke) predicted to lower
                    # the cost most, then observe and choose the next one (a fixed plan toward the first plan's end
                    # executes open loop and ends off it by the noise of its own pushes)
                    if cost_now < step_best * (1 - 1e-3):
                        step_best, step_stale = cost_now, 0
                    elif np.isfinite(step_best):
                        step_stale += 1
                    best = finishing_push(_room_for(space, observed), observed, e.finish_scales) \
                        if step_stale < FINISH_STALE else None
                    if best is not None:
                        predicted_cost, action, stroke, after = best
                        steps_left -= 1
                        replans.append({"after_action": len(records), "reason": "finish step", "repair": True,
                                        "cost_before": cost_now, "planned_cost": predicted_cost, "actions": 1,
                                        "repair_pushes": 1, "objects": [plan.names[space.decode(action)[0]]],
                                        "stroke": stroke})
                        actions, expected, j, stepping = [action], [observed, after], 0, True
                        continue
                    # no push is predicted to help, or they stopped helping: the finishing below decides (after
                    # it, the closed-loop finishing may start again from its result)
                if finishing_from is not None and cost_now > finishing_from * (1 - 1e-3):
                    fruitless += 1           # the last finishing repair or replanning did not lower the cost
                if fruitless >= FINISH_TRIES:
                    break
                if len(records) >= self.action_limit:
                    outcome = ExecutionOutcome.ACTION_LIMIT
                    break
                finishing_from = cost_now
                step_best, step_stale = np.inf, 0
                reason = "finish"
                # a finishing repair must be predicted to end within the tolerance: pushes that promise a fraction of a
                # per cent are lost in the noise of their own execution (repeated, they spent the push budget)
                fix = repair_toward_goal(_room_for(space, observed), observed, goal, depth=e.repair_depth,
                                         width=imp.refine_width, yaw_quota=imp.refine_yaw_quota,
                                         push_cost=imp.push_cost,
                                         enough=enough, at_most=ceiling) \
                    if e.repair and repairs < e.max_repairs else None
                if fix is not None:
                    repairs += 1
                    replans.append(_repair_entry(space, len(records), reason, observed, fix, plan.names))
                    actions, expected, j = fix.actions, fix.states, 0
                    continue
                if _replanned(replans) >= e.max_replans:
                    break
            else:
                if len(records) >= self.action_limit:
                    outcome = ExecutionOutcome.ACTION_LIMIT
                    break
                a = actions[j]
                obj, prim, fraction = space.decode(a)
                predicted = expected[j + 1] if stepping else space.step(observed, a)
                if stepping:
                    fraction *= stroke
                made = push if fraction == 1.0 else \
                    replace(push, push_depth=fraction * push.push_depth, turn_depth=fraction * push.turn_depth)
                try:
                    poses = yield from push_action(all_names, fp_all, all_names.index(plan.names[obj]), prim, made, rng,
                                                   self.last)
                except SimulationError as exc:     # e.g. the noisy paddle placement lands in a wall: skip it, replan
                    blocked += 1
                    records.append({"object": plan.names[obj], "primitive": PRIMITIVES[prim], "stroke": fraction,
                                    "skipped": str(exc)})
                    if _replanned(replans) >= e.max_replans:
                        outcome = ExecutionOutcome.FAILURE
                        break
                    reason, stepping = "blocked", False
                    found = grow(_room_for(space, observed), observed, rng, replan_settings(o, reason),
                                 Termination(max_time=o.replan_time, max_iterations=o.replan_iterations),
                                 seed_plan=actions[j + 1:], goal=goal,
                                 enough=enough)
                    replans.append({"after_action": len(records), "reason": reason,
                                    "cost_before": float(space.cost.cost(observed[None])[0]),
                                    "planned_cost": found.cost,
                                    "actions": len(found.actions)})
                    actions, expected, j = found.actions, found.states, 0
                    continue
                before, observed = observed, np.array([poses[n] for n in plan.names])
                if e.adapt_models and fraction == 1.0:      # the models are of whole strokes
                    _adapt(space, models, plan.names, before, observed, obj, prim)
                j += 1
                err_t, dth = pose_errors(space, observed, expected[j])
                step_t, step_th = pose_errors(space, observed, predicted)
                replan = bool(np.any(err_t > e.replan_threshold) or np.any(dth > e.replan_angle)) and not stepping
                records.append({"object": plan.names[obj], "primitive": PRIMITIVES[prim], "stroke": fraction,
                                "predicted": predicted,
                                "observed": observed.copy(), "step_error": float(step_t.max()),
                                "step_angle_error": float(step_th.max()), "plan_error": float(err_t.max()),
                                "plan_angle_error": float(dth.max()),
                                "replanned": replan and _replanned(replans) < e.max_replans})
                if stepping:
                    continue
                if not replan and e.repair and e.repair_placed and repairs < e.max_repairs \
                        and placed[obj] < PLACE_TRIES \
                        and obj not in [a // space.n_prims for a in actions[j:]]:
                    # the object's last push of the plan: is it where the plan leaves it (tighter thresholds)?
                    if err_t[obj] > e.place_threshold or dth[obj] > e.place_angle:
                        placed[obj] += 1
                        fix = repair_retarget(_room_for(space, observed), observed, expected[j], actions[j:],
                                              threshold=2 * e.place_threshold, angle=2 * e.place_angle,
                                              depth=e.repair_depth, width=imp.refine_width,
                                              yaw_quota=imp.refine_yaw_quota,
                                              at_most=ceiling, objects=[obj])
                        if fix is not None and fix.pushes:
                            repairs += 1
                            records[-1]["repaired"] = True
                            replans.append(_repair_entry(space, len(records), "placed", observed, fix, plan.names))
                            actions, expected, j = fix.actions, fix.states, 0
                    continue
                if not replan:
                    continue
                reason = "deviation"
                fix = None
                if e.repair and repairs < e.max_repairs:
                    room = _room_for(space, observed)
                    fixes = [repair_restore(room, observed, expected[j], actions[j:], threshold=e.replan_threshold,
                                            angle=e.replan_angle, depth=e.repair_depth, width=imp.refine_width,
                                            yaw_quota=imp.refine_yaw_quota, at_most=ceiling)]
                    if e.repair_retarget:
                        fixes.append(repair_retarget(room, observed, expected[j], actions[j:],
                                                     threshold=e.replan_threshold, angle=e.replan_angle,
                                                     depth=imp.refine_depth, width=imp.refine_width,
                                                     yaw_quota=imp.refine_yaw_quota,
                                                     at_most=ceiling))
                    fixes = [f for f in fixes if f is not None]
                    fix = min(fixes, key=lambda f: len(f.actions)) if fixes else None
                    fix = fix or repair_toward_goal(room, observed, goal, depth=imp.refine_depth,
                                                    width=imp.refine_width,
                                                    yaw_quota=imp.refine_yaw_quota,
                                                    at_most=ceiling, push_cost=imp.push_cost,
                                                    enough=enough)
                if fix is not None:
                    repairs += 1
                    records[-1]["replanned"] = False
                    records[-1]["repaired"] = True
                    replans.append(_repair_entry(space, len(records), reason, observed, fix, plan.names))
                    actions, expected, j = fix.actions, fix.states, 0
                    continue
                if _replanned(replans) >= e.max_replans:
                    continue
            cost_now = float(space.cost.cost(observed[None])[0])
            found = grow(_room_for(space, observed), observed, rng, replan_settings(o, reason),
                         Termination(max_time=o.replan_time, max_iterations=o.replan_iterations), seed_plan=actions[j:],
                         goal=goal,
                         enough=enough)
            replans.append({"after_action": len(records), "reason": reason, "cost_before": cost_now,
                            "planned_cost": found.cost, "actions": len(found.actions)})
            if reason == "finish" and found.cost >= cost_now - 1e-3 * goal_cost:
                stalled = True
            actions, expected, j = found.actions, found.states, 0
        final_cost = float(space.cost.cost(observed[None])[0])
        # the verdict: overlaps deeper than 2 mm with each other, the obstacles as the scene gives them, or off the
        # table
        exact_fp, exact_poses, _ = domain.obstacles(scene, plan.names, space.checker.table)
        verdict = replace(space.checker, obstacles=exact_fp, obstacle_poses=exact_poses, margin=TOUCH)
        collided = bool(verdict.in_collision(observed)[0])
        if outcome == ExecutionOutcome.SUCCESS and collided:
            outcome = ExecutionOutcome.FAILURE
        elif outcome == ExecutionOutcome.SUCCESS and final_cost > plan.cost * (1 + e.outcome_tolerance) + 1e-12:
            outcome = ExecutionOutcome.ABOVE_TOLERANCE    # completed, but not within the tolerance of the plan
        self.record.final_cost, self.record.final_state, self.record.collided = final_cost, observed, collided
        self.events.append(f"final cost {final_cost:.4g} (first plan {plan.cost:.4g}); {_replanned(replans)} replans; "
                           f"{repairs} repairs; {blocked} pushes skipped; collision-free: {not collided}")
        return outcome


def execute_plan(plan: PushPlan, world, scene, rng: np.random.Generator, *, action_limit: int = 100,
                 on_step: StepListener | None = None, world_name: str = "",
                 noise: float | None = None) -> ExecutionRecord:
    """Execute ``plan`` in ``world`` (a simulator that can place objects) on ``scene``: the core's loop
    (:func:`pliant.api.follow`) with a :class:`PushPlanStrategy`; ``noise`` overrides the options' paddle placement
    noise (m)."""
    if not getattr(world, "can_place_objects", False):
        raise PlanningError("executing a TS-RRT plan needs a world that can place objects (a simulator such as "
                            "pymunk)", field="execution.world", value=type(world).__name__)
    return follow(world, None, PushPlanStrategy(plan, scene, action_limit=action_limit, noise=noise), rng,
                  time_limit=float("inf"), on_step=on_step, world_name=world_name)


def follow_plan(plan: PushPlan, context=None, settings: dict | None = None) -> PushPlanStrategy:
    """The strategy a pipeline follows for ``plan`` (:attr:`PushPlan.follower`): over the pipeline's scene, at most
    its ``[execution]`` ``action_limit`` pushes."""
    scene = context.scene if context is not None else None
    return PushPlanStrategy(plan, scene, action_limit=int((settings or {}).get("action_limit", 100)))


__all__ = ["PushPlanDetails", "PushPlanStrategy", "execute_plan", "follow_plan", "push_action"]
