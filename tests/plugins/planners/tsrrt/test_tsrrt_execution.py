"""Execution with monitoring and replanning (poster: "Robot monitored error and replanned as necessary"): when the
plan is done, the arrangement is judged against the *first* plan's cost, and the replanning connects back to the
first plan's final arrangement.  The pushes and the replanning are scripted here (the world follows the models
exactly except where a test moves an object), so only the monitoring logic is under test.  The replanning tests turn
the repairs off; the repair tests check that a repair comes first and replanning only when it cannot help."""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pliant_tsrrt.execution as execution_module
import pytest
from pliant import load_scene, registry
from pliant.errors import ConfigError
from pliant.execution.strategy import Place
from pliant.interfaces import Context
from pliant_tsrrt.execution import execute_plan
from pliant_tsrrt.models import Displacement, PushModels, compose, footprints_from_scene, object_class, scene_pose
from pliant_tsrrt.options import CostOptions, ExecutionOptions, PlanningOptions, TSRRTOptions
from pliant_tsrrt.planner import PushPlan, build_space
from pliant_tsrrt.search import SearchResult

NAMES = ["book-1", "block-1", "can-1"]
MEANS = [[0.045, 0, 0], [-0.045, 0, 0], [0, 0.045, 0], [0, -0.045, 0], [0, 0.002, 0.2], [0, -0.002, -0.2]]


def _setup(repair: bool = False, finish_tolerance: float = 0.05, **more):
    """The scene, world, models, options and space; ``more``: further ``execution`` options."""
    scene = load_scene("tsrrt-table")
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "rigid", ctx)
    world = registry.create("simulator", "pymunk", ctx, max_force=50.0)
    fp = footprints_from_scene(scene, NAMES)
    models = PushModels()
    for i, name in enumerate(NAMES):
        per = []
        for mean in MEANS:
            d = Displacement()
            for _ in range(2):
                d.update(np.array(mean, dtype=float))
            per.append(d)
        models.models[object_class(name)] = per
        models.footprints[object_class(name)] = (int(fp.kind[i]), fp.half[i].copy())
    more.setdefault("replan_threshold", 0.02)
    more.setdefault("finish_steps", 0)          # the finishing repairs and replannings; closed-loop steps: own test
    more.setdefault("adapt_models", False)      # the scripted kicks are disturbances, not what a push does
    # whole strokes only: the scripted plans below are written as actions 6 o + p
    options = TSRRTOptions(planning=PlanningOptions(strokes=(1.0,)),
                           execution=ExecutionOptions(finish_tolerance=finish_tolerance, repair=repair, **more))
    space = build_space(scene, options, models, NAMES)
    return scene, world, models, options, space


def _result(space, s0, actions):
    states, ok = space.rollout(s0, actions)
    assert ok
    cost = float(space.cost.cost(states[-1][None])[0])
    return SearchResult(list(actions), states, cost, states, np.zeros(len(states), int), np.zeros(len(states)), {})


def _script(monkeypatch, space, kick, replans, stuck_from=None):
    """Pushes follow the models, except push number ``kick[0]`` (0-based), after which object ``kick[1]`` lies
    ``kick[2]`` (m, along y; or a pose offset ``(dx, dy, dtheta)``) off, and pushes from number ``stuck_from`` on,
    which move nothing; each replanning returns the next plan of ``replans`` (a function of the observed
    arrangement) and records its reason and goal."""
    calls = {"pushes": 0, "grow": []}

    def fake_push(names, fp, index, primitive, settings, rng, seen):
        now = {n: np.asarray(p, float) for n, p in seen.objects.items()}
        s = np.array([now[n] for n in NAMES])
        if stuck_from is None or calls["pushes"] < stuck_from:
            moved = space.step(s, space.n_prims * NAMES.index(names[index]) + primitive)
            # a shorter stroke (a finishing push, or a planned fraction) moves the object that fraction of the model's
            stroke = settings.push_depth / space.push.push_depth
            assert settings.turn_depth == pytest.approx(stroke * space.push.turn_depth)
            calls.setdefault("strokes", []).append(stroke)
            s = s + stroke * (moved - s)
        if calls["pushes"] == kick[0]:
            if np.ndim(kick[2]):
                s[kick[1]] += kick[2]
            else:
                s[kick[1], 1] += kick[2]
        calls["pushes"] += 1
        yield Place(seen.configuration, {n: p for n, p in zip(NAMES, s)})     # the world, told where they went
        return {n: p for n, p in zip(NAMES, s)}

    def fake_grow(space_, s0, rng, settings, termination=None, seed_plan=None, goal=None, enough=None):
        calls["grow"].append({"refine": settings.improvement.refine, "goal": goal, "enough": enough})
        return _result(space, s0, replans[len(calls["grow"]) - 1](s0))

    monkeypatch.setattr(execution_module, "push_action", fake_push)
    monkeypatch.setattr(execution_module, "grow", fake_grow)
    return calls


def _execute_can_plan(monkeypatch, kick, replans, actions=(15, 15, 15), stuck_from=None, **setup):
    """The first plan pushes the can -y three times, away from the table's edge; it is executed in the scripted world
    (``kick``, ``replans`` and ``stuck_from`` as in :func:`_script`).  Returns the first plan, the calls and the
    record."""
    scene, world, models, options, space = _setup(**setup)
    s0 = np.array([scene_pose(scene, n) for n in NAMES])
    first = _result(space, s0, list(actions))
    calls = _script(monkeypatch, space, kick, replans, stuck_from)
    plan = PushPlan(NAMES, s0, first.actions, first.states, first.cost, asdict(options), models)
    return first, calls, execute_plan(plan, world, scene, np.random.default_rng(0))


def test_a_done_plan_is_judged_against_the_first_plans_cost_and_replanned_toward_its_end(monkeypatch):
    # the first push leaves the can 6 cm back toward the edge (a deviation); the replanning after it (the tree
    # alone) finds nothing to do, which ends more than 5 % above the first plan's cost; the replanning when that
    # plan is done (with the improvement phase) pushes the can -y three times again
    first, calls, record = _execute_can_plan(monkeypatch, (0, 2, 0.06), [lambda s: [], lambda s: [15, 15, 15]],
                                             replan_refine=False)
    reasons = [r["reason"] for r in record.details.adaptations]
    assert reasons == ["deviation", "finish"]
    assert record.details.adaptations[0]["planned_cost"] > 1.05 * first.cost   # the replanned plan ended higher ...
    assert calls["grow"][0]["refine"] is False and calls["grow"][1]["refine"] is True
    # with replan_refine (the default) the replanning after the deviation runs the improvement phase too
    _, calls, _ = _execute_can_plan(monkeypatch, (0, 2, 0.06), [lambda s: [], lambda s: [15, 15, 15]])
    assert [call["refine"] for call in calls["grow"]] == [True, True]
    for call in calls["grow"]:                                         # ... and every replanning knows the goal
        assert np.allclose(call["goal"], first.states[-1])
    assert record.details.final_cost <= 1.05 * first.cost + 1e-9


def test_with_replan_shortest_every_replanning_counts_the_first_plans_cost_as_enough(monkeypatch):
    first, calls, record = _execute_can_plan(monkeypatch, (0, 2, 0.06), [lambda s: [], lambda s: [15, 15, 15]],
                                             replan_shortest=True)
    assert [r["reason"] for r in record.details.adaptations] == ["deviation", "finish"]
    assert [call["enough"] for call in calls["grow"]] == [first.cost, first.cost]
    first, calls, record = _execute_can_plan(monkeypatch, (0, 2, 0.06), [lambda s: [], lambda s: [15, 15, 15]],
                                             replan_shortest=False)
    assert [call["enough"] for call in calls["grow"]] == [None, None]       # off: the cheapest plan wins


def test_a_replanning_that_finds_nothing_cheaper_ends_the_execution(monkeypatch):
    # the last push leaves the can 12 cm back toward the edge; no replanning finds a push that helps
    first, calls, record = _execute_can_plan(monkeypatch, (2, 2, 0.12), [lambda s: []] * 5)
    reasons = [r["reason"] for r in record.details.adaptations]
    assert reasons == ["deviation", "finish"]          # not max_replans finish replannings
    assert len(calls["grow"]) == 2 and record.details.final_cost > 1.05 * first.cost


def test_execution_stops_after_two_finishing_attempts_that_did_not_lower_the_cost(monkeypatch):
    # the last push leaves the can 12 cm back (not monitored: a replan_threshold of 1 m); every finishing replanning
    # promises the three pushes -y again, but from then on the can is stuck: pushes move nothing, so no attempt
    # lowers the cost
    first, calls, record = _execute_can_plan(monkeypatch, (2, 2, 0.12), [lambda s: [15, 15, 15]] * 10, stuck_from=3,
                                             replan_threshold=1.0)
    assert [r["reason"] for r in record.details.adaptations] == ["finish", "finish"] and len(calls["grow"]) == 2
    assert len(record.details.actions) == 3 + 3 + 3                 # not max_replans (20) rounds of three pushes
    assert record.details.final_cost > 1.05 * first.cost


def test_replanning_from_a_jammed_arrangement_keeps_the_largest_margin_it_allows():
    from pliant_tsrrt.execution import TOUCH, _room_for

    space = _setup()[-1]
    s = np.array([[0.3, 0.4, 0.0], [0.5, 0.4, 0.0], [0.8, 0.4, 0.0]])
    s[1, 0] = 0.3 + 0.12 + 0.05 + 0.005              # the block 5 mm from the book: inside the 10 mm margin
    assert _room_for(space, s) is not space
    assert np.isclose(_room_for(space, s).checker.margin, 0.002)      # 2 x 2 mm fits in the 5 mm gap, 2 x 3 does not
    free = np.array([[0.3, 0.4, 0.0], [0.6, 0.4, 0.0], [0.8, 0.4, 0.0]])
    assert _room_for(space, free) is space
    s[1, 0] = 0.3 + 0.12 + 0.05 - 0.004              # overlapping by 4 mm: nothing but touching is left
    assert _room_for(space, s).checker.margin == TOUCH


def test_a_deviation_is_repaired_by_pushing_the_object_back_and_the_plan_goes_on(monkeypatch):
    # the first push leaves the can one push length (4.5 cm) back toward the edge: one push -y brings it back
    first, calls, record = _execute_can_plan(monkeypatch, (0, 2, 0.045), [], repair=True)
    assert calls["grow"] == []                                          # no replanning
    (repair,) = record.details.adaptations
    assert repair["repair"] and repair["reason"] == "deviation" and repair["objects"] == ["can-1"]
    assert repair["repair_pushes"] == 1 and repair["actions"] == 3     # the push back, then the plan's last two
    assert [a["object"] for a in record.details.actions] == ["can-1"] * 4
    assert record.details.actions[0]["repaired"] and not record.details.actions[0]["replanned"]
    assert np.allclose(record.details.final_state, first.states[-1], atol=1e-9)
    assert record.details.final_cost == pytest.approx(first.cost)


def test_a_deviation_no_push_can_undo_is_repaired_toward_the_first_plans_end_when_that_ends_within_tolerance(
        monkeypatch):
    # 6 cm back: pushes of 4.5 cm leave 1.5 or 3 cm, more than half the 2 cm threshold, so the plan cannot be
    # restored; pushing the can toward the first plan's final arrangement ends 1.5 cm from it, within 5 % of its cost
    first, calls, record = _execute_can_plan(monkeypatch, (0, 2, 0.06), [], repair=True, repair_retarget=False)
    assert calls["grow"] == []
    repair = record.details.adaptations[0]
    assert repair["reason"] == "deviation" and repair["repair"] and repair["objects"] == ["can-1"]
    assert repair["planned_cost"] <= 1.05 * first.cost
    assert np.isclose(record.details.final_state[2, 1], first.states[-1][2, 1] + 0.015, atol=1e-9)
    assert record.details.final_cost <= 1.05 * first.cost


    # with repair_retarget (the default) the can's remaining pushes are re-planned instead: its glancing pushes (2 mm
    # along y each) bring it to within a millimetre of where the plan leaves it
    first, calls, record = _execute_can_plan(monkeypatch, (0, 2, 0.06), [], repair=True)
    assert calls["grow"] == [] and record.details.adaptations[0]["objects"] == ["can-1"]
    assert abs(record.details.final_state[2, 1] - first.states[-1][2, 1]) < 0.001


def test_a_placed_box_off_its_final_yaw_is_turned_there_at_once_with_repair_placed(monkeypatch):
    # the plan turns the book once (+0.2 rad), then pushes the can twice; the book's turn ends 0.15 rad too far:
    # below replan_angle (0.3), so no deviation, but it is the book's last push and 0.15 > place_angle (0.07):
    # one turn- (-0.2 rad) leaves it 0.05 rad off, and the plan goes on
    kick = (0, 0, np.array([0.0, 0.0, 0.15]))
    first, calls, record = _execute_can_plan(monkeypatch, kick, [], actions=(4, 15, 15), repair=True,
                                             replan_angle=0.3, repair_placed=True)
    assert calls["grow"] == []
    (fix,) = record.details.adaptations
    assert fix["reason"] == "placed" and fix["repair"] and fix["objects"] == ["book-1"] and fix["repair_pushes"] == 1
    assert [(a["object"], a["primitive"]) for a in record.details.actions] == [("book-1", "turn+"), ("book-1", "turn-"),
                                                                        ("can-1", "push-y"), ("can-1", "push-y")]
    assert np.isclose(record.details.final_state[0, 2] - first.states[-1][0, 2], -0.05, atol=1e-9)
    # without repair_placed the book stays 0.15 rad off
    first, calls, record = _execute_can_plan(monkeypatch, kick, [], actions=(4, 15, 15), repair=True,
                                             replan_angle=0.3, repair_placed=False)
    assert record.details.adaptations == []
    assert np.isclose(record.details.final_state[0, 2] - first.states[-1][0, 2], 0.15)


def test_the_outcome_tells_completed_within_tolerance_from_completed_above_it(monkeypatch):
    # undisturbed: the plan ends where it predicted, 'success'
    first, _, record = _execute_can_plan(monkeypatch, (99, 2, 0.0), [])
    assert record.outcome == "success" and record.outcome.success
    assert record.details.final_cost == pytest.approx(first.cost)
    # the last push leaves the can 12 cm back and nothing helps: completed, collision-free, but above the tolerance
    first, _, record = _execute_can_plan(monkeypatch, (2, 2, 0.12), [lambda s: []] * 5, outcome_tolerance=0.05)
    ratio = record.details.final_cost / first.cost
    assert ratio > 1.05 and not record.details.collided
    assert record.outcome == "above tolerance" and not record.outcome.success
    # the same execution judged with a tolerance it meets is a success
    first, _, record = _execute_can_plan(monkeypatch, (2, 2, 0.12), [lambda s: []] * 5,
                                         outcome_tolerance=ratio - 1 + 1e-6)
    assert record.outcome == "success"


def test_a_done_plan_above_tolerance_is_finished_closed_loop_one_push_at_a_time(monkeypatch):
    # the last push leaves the can 12 cm back toward the edge (not monitored: a replan_threshold of 1 m); the
    # closed-loop finishing plans a beam from the observed arrangement, executes its first push, observes, and so
    # on, until the arrangement is within the tolerance: no replanning, no fixed finishing plan
    first, calls, record = _execute_can_plan(monkeypatch, (2, 2, 0.12), [lambda s: [15, 15, 15]] * 10,
                                             replan_threshold=1.0, finish_steps=10)
    steps = [a for a in record.details.adaptations if a["reason"] == "finish step"]
    assert steps and all(a["actions"] == 1 for a in steps)
    assert not calls["grow"]
    assert len(record.details.actions) == 3 + len(steps) <= 3 + 10
    assert record.details.final_cost <= 1.05 * first.cost + 1e-9 and record.outcome == "success"


def test_closed_loop_finishing_takes_a_fraction_of_a_stroke_where_a_whole_push_would_overshoot(monkeypatch):
    # orthogonality alone; the plan turns the book from 30 degrees to -0.0764 rad and the block from -20 degrees to
    # 0.0509 rad (sin^2(2 theta): 0.0232 + 0.0103); its last push leaves the book at -0.1464 rad (0.0829 + 0.0103,
    # 2.8 times the plan's cost).  Turning the book back by a whole turn (0.2 rad) leaves 0.0536 rad (0.0114 +
    # 0.0103), by a quarter -0.0964 (0.0364 + 0.0103), by a half -0.0464 (0.0085 + 0.0103 = 0.0188, below the plan's
    # own cost): the finishing takes one half-stroke turn and is done
    scene, world, models, _, _ = _setup()
    options = TSRRTOptions(cost=CostOptions(w_orth=1.0, w_area=0.0, w_edge=0.0),
                           planning=PlanningOptions(strokes=(1.0,)),
                           execution=ExecutionOptions(repair=False, replan_threshold=1.0, finish_steps=10,
                                                      finish_scales=(0.25, 0.5, 1.0), adapt_models=False))
    space = build_space(scene, options, models, NAMES)
    s0 = np.array([scene_pose(scene, n) for n in NAMES])
    first = _result(space, s0, [5, 5, 5, 10, 10])
    np.testing.assert_allclose(first.states[-1][:2, 2], [-0.0764, 0.0509], atol=1e-4)
    calls = _script(monkeypatch, space, (4, 0, (0.0, 0.0, -0.07)), [lambda s: []] * 5)
    plan = PushPlan(NAMES, s0, first.actions, first.states, first.cost, asdict(options), models)
    record = execute_plan(plan, world, scene, np.random.default_rng(0))
    steps = [a for a in record.details.adaptations if a["reason"] == "finish step"]
    assert [(a["objects"], a["stroke"]) for a in steps] == [(["book-1"], 0.5)] and not calls["grow"]
    assert [a["primitive"] for a in record.details.actions][-1] == "turn+"
    assert record.details.final_state[0, 2] == pytest.approx(first.states[-1][0, 2] - 0.07 + 0.1, abs=1e-9)
    assert record.details.final_cost == pytest.approx(np.sin(2 * (-0.0464))**2 + np.sin(2 * 0.0509)**2, abs=1e-3)
    assert record.details.final_cost < first.cost and record.outcome == "success"


def test_finish_scales_must_be_fractions_of_a_stroke():
    for bad in ((), (0.0,), (1.5,), (0.5, -0.1)):
        with pytest.raises(ConfigError, match="finish_scales"):
            ExecutionOptions(finish_scales=bad).validate()


def test_adapt_models_adds_an_observed_push_to_its_class_unless_it_moved_another_object():
    from pliant_tsrrt.execution import _adapt

    _, _, models, _, space = _setup()
    can = NAMES.index("can-1")
    before = np.array([[0.2, 0.6, 0.5], [0.8, 0.2, 0.0], [0.7, 0.6, 0.0]])
    after = before.copy()
    after[can] = (0.7, 0.6 - 0.03, 0.0)              # push-y moved the can 3 cm (the model: 4.5 cm)
    model = models.models[object_class("can-1")][3]
    n0 = model.n
    _adapt(space, models, NAMES, before, after, can, 3)
    assert model.n == n0 + 1
    assert model.mean[1] == pytest.approx((-0.045 * n0 - 0.03) / (n0 + 1))
    np.testing.assert_allclose(space.means[can, 3], model.mean)
    moved = after.copy()
    moved[0, 0] += 0.01                               # the book moved too: the push touched it
    _adapt(space, models, NAMES, before, moved, can, 3)
    assert model.n == n0 + 1


def _stroke_setup():
    """The scripted set-up with plans that may push whole strokes, halves and quarters (``planning.strokes``)."""
    scene, world, models, _, _ = _setup()
    options = TSRRTOptions(planning=PlanningOptions(strokes=(1.0, 0.5, 0.25)),
                           execution=ExecutionOptions(repair=False, replan_threshold=0.02, finish_steps=0,
                                                      adapt_models=False))
    return scene, world, models, options, build_space(scene, options, models, NAMES)


def test_a_space_with_strokes_has_each_primitive_again_scaled_by_each_fraction():
    space = _stroke_setup()[-1]
    assert space.n_prims == 18 and space.strokes == (1.0, 0.5, 0.25)
    np.testing.assert_allclose(space.means[:, 6:12], 0.5 * space.means[:, :6])
    np.testing.assert_allclose(space.means[:, 12:], 0.25 * space.means[:, :6])
    np.testing.assert_allclose(space.means[0, 4], MEANS[4])
    # action 18 o + 6 s + p: object o, primitive p, stroke s
    assert space.decode(10) == (0, 4, 0.5) and space.decode(2 * 18 + 15) == (2, 3, 0.25) and space.decode(18) == \
        (1, 0, 1.0)


def test_a_plan_with_fractions_of_a_stroke_pushes_each_action_with_its_stroke(monkeypatch):
    # the book turns + by half a stroke (0.1 rad), the can goes -y by a quarter (1.125 cm), the block +x by a whole
    # push (4.5 cm); the scripted world moves each object by that fraction of its model's push, so the execution
    # follows the plan exactly when each push is made with its own stroke
    scene, world, models, options, space = _stroke_setup()
    s0 = np.array([scene_pose(scene, n) for n in NAMES])
    actions = [0 * 18 + 6 + 4, 2 * 18 + 12 + 3, 1 * 18 + 0]
    first = _result(space, s0, actions)
    expected = [compose(s0[0], 0.5 * np.array(MEANS[4])), compose(s0[1], np.array(MEANS[0])),
                compose(s0[2], 0.25 * np.array(MEANS[3]))]
    np.testing.assert_allclose(first.states[-1], expected, atol=1e-12)
    assert first.states[-1][0, 2] - s0[0, 2] == pytest.approx(0.1)
    calls = _script(monkeypatch, space, (99, 0, 0.0), [])
    plan = PushPlan(NAMES, s0, first.actions, first.states, first.cost, asdict(options), models,
                    strokes=space.strokes)
    record = execute_plan(plan, world, scene, np.random.default_rng(0))
    assert calls["strokes"] == pytest.approx([0.5, 0.25, 1.0])
    assert [a["stroke"] for a in record.details.actions] == [0.5, 0.25, 1.0]
    assert [a["primitive"] for a in record.details.actions] == ["turn+", "push-y", "push+x"]
    assert not record.details.adaptations and not calls["grow"]
    np.testing.assert_allclose(record.details.final_state, first.states[-1], atol=1e-9)
    assert record.outcome == "success"


def test_a_plan_carries_its_strokes_through_json_and_an_old_plan_has_whole_strokes_only():
    scene, _, models, options, space = _stroke_setup()
    s0 = np.array([scene_pose(scene, n) for n in NAMES])
    first = _result(space, s0, [10, 51])
    plan = PushPlan(NAMES, s0, first.actions, first.states, first.cost, asdict(options), models,
                    strokes=space.strokes)
    assert plan.describe() == ["book-1 turn+ (0.5 stroke)", "can-1 push-y (0.25 stroke)"]
    data = plan.to_dict()
    again = PushPlan.from_dict(data)
    assert again.strokes == (1.0, 0.5, 0.25) and again.decode(51) == (2, 3, 0.25)
    assert PushPlan(NAMES, s0, first.actions, first.states, first.cost, asdict(options), models).strokes == \
        (1.0, 0.5, 0.25)                            # from the options' planning.strokes
    old = {k: v for k, v in data.items() if k != "strokes"}
    old["actions"] = [4, 15]
    old["options"] = {k: v for k, v in data["options"].items() if k != "planning"}
    assert PushPlan.from_dict(old).strokes == (1.0,)
    assert PushPlan.from_dict(old).describe() == ["book-1 turn+", "can-1 push-y"]
    with pytest.raises(ConfigError, match=r"policy\.actions.*54"):
        PushPlan.from_dict({**data, "actions": [10, 54]})       # 3 objects x 18 actions: 54 is out of range
    with pytest.raises(ConfigError, match=r"policy\.strokes"):
        PushPlan.from_dict({**data, "strokes": [0.5, 1.0]})


def test_planning_strokes_must_start_with_the_whole_stroke_and_be_distinct_fractions():
    for bad in ((), (0.5,), (0.5, 1.0), (1.0, 1.0), (1.0, 0.0), (1.0, 1.5)):
        with pytest.raises(ConfigError, match="strokes"):
            PlanningOptions(strokes=bad).validate()
    PlanningOptions(strokes=(1.0, 0.5)).validate()


def test_adapt_models_updates_a_primitives_fractions_with_its_whole_stroke():
    from pliant_tsrrt.execution import _adapt

    _, _, models, _, space = _stroke_setup()
    can = NAMES.index("can-1")
    before = np.array([[0.2, 0.6, 0.5], [0.8, 0.2, 0.0], [0.7, 0.6, 0.0]])
    after = before.copy()
    after[can] = (0.7, 0.6 - 0.03, 0.0)
    _adapt(space, models, NAMES, before, after, can, 3)
    mean = models.models[object_class("can-1")][3].mean
    np.testing.assert_allclose(space.means[can, [3, 9, 15]], [mean, 0.5 * mean, 0.25 * mean])
