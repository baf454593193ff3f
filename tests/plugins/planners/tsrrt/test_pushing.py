"""APPLY_ACTION and LEARN_MODEL (poster ICHR 2010) in pymunk through the core's Simulator interface, the push-models
learner, and the plan's execution with monitoring."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.errors import PliantError, SimulationError
from pliant.interfaces import Context
from pliant_tsrrt.learning import learn_models
from pliant_tsrrt.models import footprints_from_scene, object_class
from pliant_tsrrt.options import LearningOptions, TSRRTOptions
from pliant_tsrrt.planner import arena
from pliant_tsrrt.pushing import PRIMITIVES, PushSettings, apply_action


def _world(scene_name="tsrrt-table", **options):
    scene = load_scene(scene_name)
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.simulator = registry.create("simulator", "pymunk", ctx, max_force=50.0, **options)
    return scene, ctx


def test_set_object_poses_places_objects_and_names_bad_input():
    _, ctx = _world()
    sim = ctx.simulator
    sim.set_object_poses({"can-1": np.array([0.5, 0.4, 0.3])})
    poses = sim.object_poses()
    assert np.allclose(poses["can-1"], [0.5, 0.4, 0.3]) and np.allclose(poses["book-1"][:2], [0.22, 0.58])
    with pytest.raises(SimulationError, match="set_object_poses"):
        sim.set_object_poses({"table": np.zeros(3)})
    with pytest.raises(SimulationError, match=r"set_object_poses\.can-1"):
        sim.set_object_poses({"can-1": np.array([0.5, np.nan, 0.0])})
    kinematic = registry.create("simulator", "kinematic", ctx)
    assert not kinematic.can_place_objects
    with pytest.raises(SimulationError, match="cannot place"):
        kinematic.set_object_poses({"can-1": np.zeros(3)})


def test_a_push_moves_the_object_along_its_own_axis():
    scene, ctx = _world()
    names = [o.name for o in scene.objects if o.movable]
    fp = footprints_from_scene(scene, names)
    sim = ctx.simulator
    sim.set_object_poses({"block-1": np.array([0.5, 0.4, np.pi / 2])})
    before = sim.object_poses()
    after = apply_action(sim, names, fp, names.index("block-1"), PRIMITIVES.index("push+x"), PushSettings(),
                         np.random.default_rng(0))
    moved = after["block-1"] - before["block-1"]
    # push+x along the block's own x axis, which points along world +y at 90 degrees; depth 5 cm
    assert 0.03 < moved[1] < 0.055 and abs(moved[0]) < 0.005 and abs(moved[2]) < 0.02
    assert np.allclose(after["book-1"], before["book-1"]) and np.allclose(after["can-1"], before["can-1"])


@pytest.mark.parametrize("primitive", ["push+x", "turn+"])
def test_a_fraction_of_a_stroke_moves_the_object_about_that_fraction_of_a_whole_push(primitive):
    # what planning with fractions (planning.strokes) assumes to first order: after the guarded approach the paddle's
    # travel is what moves the object, so half the depth moves it about half as far (or turns it half as much)
    from dataclasses import replace

    scene, ctx = _world()
    names = [o.name for o in scene.objects if o.movable]
    fp = footprints_from_scene(scene, names)
    sim, whole = ctx.simulator, PushSettings()
    moved = {}
    for fraction in (1.0, 0.5):
        sim.set_object_poses({"block-1": np.array([0.5, 0.4, 0.0])})
        made = replace(whole, push_depth=fraction * whole.push_depth, turn_depth=fraction * whole.turn_depth)
        after = apply_action(sim, names, fp, names.index("block-1"), PRIMITIVES.index(primitive), made,
                             np.random.default_rng(0))
        d = after["block-1"] - np.array([0.5, 0.4, 0.0])
        moved[fraction] = d[0] if primitive == "push+x" else d[2]
    assert abs(moved[1.0]) > (0.03 if primitive == "push+x" else 0.05)
    assert 0.35 < moved[0.5] / moved[1.0] < 0.65


def _push_lengths(guard: float, seeds=range(6)) -> np.ndarray:
    """How far push+x moves the block (m) from one pose, with a 4 mm paddle placement error, per seed."""
    scene, ctx = _world()
    names = [o.name for o in scene.objects if o.movable]
    fp = footprints_from_scene(scene, names)
    sim = ctx.simulator
    settings = PushSettings(placement_noise=0.004, guard_step=guard)
    lengths = []
    for seed in seeds:
        sim.set_object_poses({"block-1": np.array([0.5, 0.4, 0.0])})
        after = apply_action(sim, names, fp, names.index("block-1"), PRIMITIVES.index("push+x"), settings,
                             np.random.default_rng(seed))
        lengths.append(after["block-1"][0] - 0.5)
    return np.array(lengths)


def test_a_guarded_push_does_not_carry_the_placement_error_along_the_push():
    blind, guarded = _push_lengths(0.0), _push_lengths(0.001)
    # the same placement errors (seeds): a blind push travels gap + depth from wherever the paddle was put, so its
    # length varies with the error along the push (4 mm sd); the guarded push travels the depth from the contact
    assert np.std(blind) > 0.002
    assert np.std(guarded) < 0.001 and np.std(guarded) < np.std(blind) / 3
    assert np.all((guarded > 0.035) & (guarded < 0.05))


def test_push_settings_defaults_are_the_options_defaults():
    from dataclasses import fields

    from pliant import load_scene
    from pliant_tsrrt.domain import PushOptions, push_settings

    from_options = push_settings(PushOptions(), load_scene("tsrrt-table"))
    for f in fields(PushSettings):
        assert getattr(from_options, f.name) == getattr(PushSettings(), f.name), f.name


def test_learn_model_stops_at_sigma_ref_and_restores_the_objects():
    scene, ctx = _world()
    sim = ctx.simulator
    before = sim.object_poses()
    o = TSRRTOptions(learning=LearningOptions(min_pushes=3, max_pushes=6))
    models, report = learn_models(arena(sim, scene, o), o.learning, np.random.default_rng(0), holdout=2,
                                  only=["can-1"])
    assert list(models.models) == ["can"]
    # without noise pymunk repeats itself: the variance is ~0 after the fewest pushes
    assert all(d.n == 3 for d in models.models["can"])
    push = models.models["can"][PRIMITIVES.index("push+y")].mean
    assert 0.03 < push[1] < 0.055
    assert report["holdout"]["can"]["push+x"]["translation_error"] < 0.005
    after = sim.object_poses()
    assert all(np.allclose(before[n], after[n]) for n in before)


def test_learner_component_fits_and_refuses_empty_data():
    _, ctx = _world()
    learner = registry.create("learner", "push-models", ctx, min_pushes=2, max_pushes=3, holdout=1)
    out = learner.fit(["can-1"], np.random.default_rng(0))
    assert set(out) == {"can"} and out["can"]["pushes"] == 12
    assert object_class("can-1") in learner.models.models
    with pytest.raises(PliantError, match="data"):
        learner.fit([], np.random.default_rng(0))


@pytest.mark.slow
def test_pipeline_runs_end_to_end(tmp_path):
    from pliant.pipeline import Pipeline

    # work budgets (tree extensions; the pipeline's time caps stay generous): the same run under any load
    record = Pipeline.from_file("tsrrt-demo", overrides=[f'output="{tmp_path}"', "planning.max_iterations=150",
                                                           "learner.max_pushes=4", "learner.holdout=0",
                                                           "planner.replan_iterations=40",
                                                           "planner.execution.max_replans=2",
                                                           "planner.execution.max_repairs=2"]).run()
    assert record.result.status.success
    plan = record.result.policy
    assert record.result.cost < record.result.statistics["start_cost"]
    assert record.execution is not None and record.execution.outcome in ("success", "above tolerance", "failure")
    assert len(record.execution.details.actions) >= 1
    for name in ("tsrrt.png", "push-models.png", "report.md", "result.json", "execution.json", "learned.json"):
        assert (tmp_path / name).is_file()
    from pliant.results import PlanResult

    again = PlanResult.load(tmp_path / "result.json")
    assert again.policy.actions == plan.actions and np.allclose(again.policy.states, plan.states)
    # the default plans with fractions of a stroke: the plan carries them, and each push is executed with its own
    assert plan.strokes == again.policy.strokes == TSRRTOptions().planning.strokes
    planned = [plan.decode(a)[2] for a in plan.actions]
    details = record.execution.details
    first = min([a["after_action"] for a in details.adaptations], default=len(planned))   # until a repair or replan
    assert first > 0 and min(planned[:first]) < 1.0
    assert [a["stroke"] for a in details.actions[:first]] == planned[:first]


def test_planner_options_are_checked():
    from pliant.errors import ConfigError

    with pytest.raises(ConfigError, match=r"planner\.planning\.epsilon"):
        registry.create("planner", "tsrrt", None, planning={"epsilon": 2.0})
    with pytest.raises(ConfigError, match=r"planner\.learning\.min_pushes"):
        registry.create("planner", "tsrrt", None, learning={"min_pushes": 30, "max_pushes": 10})
    with pytest.raises(ConfigError, match="models"):
        registry.create("planner", "tsrrt", None, models="nowhere.txt")


def test_grouped_options_from_tables_dotted_keys_and_old_flat_names(tmp_path):
    """TS-RRT's options come in groups: a nested table, a dotted --set key, or (deprecated, with a warning naming
    the new spelling) the old flat name; errors name the full dotted field."""
    from pliant.errors import ConfigError
    from pliant.options import OptionDeprecationWarning
    from pliant.pipeline import Pipeline

    nested = registry.create("planner", "tsrrt", None, improvement={"refine_share": 0.5},
                             push={"placement_noise": 0.004})
    dotted = registry.create("planner", "tsrrt", None, **{"improvement.refine_share": 0.5,
                                                          "push.placement_noise": 0.004})
    with pytest.warns(OptionDeprecationWarning) as warned:
        flat = registry.create("planner", "tsrrt", None, refine_share=0.5, placement_noise=0.004)
    assert sorted(str(w.message) for w in warned) == [
        "option 'planner.placement_noise' is deprecated: use 'planner.push.placement_noise'",
        "option 'planner.refine_share' is deprecated: use 'planner.improvement.refine_share'"]
    assert nested.options == dotted.options == flat.options
    assert flat.options.improvement.refine_share == 0.5 and flat.options.push.placement_noise == 0.004
    with pytest.raises(ConfigError, match=r"planner\.improvement\.refine_share"):
        registry.create("planner", "tsrrt", None, **{"improvement.refine_share": 2.0})
    with pytest.raises(ConfigError, match=r"planner\.improvement\.nothing"):
        registry.create("planner", "tsrrt", None, improvement={"nothing": 1})
    # a pipeline file with the new tables, overridden from the command line in either spelling (the later wins)
    pipeline = tmp_path / "p.toml"
    pipeline.write_text('scene = "tsrrt-table"\n[simulator]\nname = "pymunk"\n[planner]\nname = "tsrrt"\n'
                        '[planner.improvement]\nrefine_share = 0.25\nbeam_depth = 2\n')
    built = Pipeline.from_file(pipeline, overrides=["planner.improvement.refine_share=0.5"])
    planner = registry.create("planner", "tsrrt", None, **built.components["planner"].options)
    assert planner.options.improvement.refine_share == 0.5 and planner.options.improvement.beam_depth == 2
