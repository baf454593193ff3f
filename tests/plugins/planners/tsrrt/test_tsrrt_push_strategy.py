"""A TS-RRT push executed through the core's one execution loop (pliant_tsrrt.pushing.push_steps as directives)
moves the world exactly as APPLY_ACTION applied to the simulator directly (learning's push), draw for draw; the plan's
strategy is what a pipeline finds for a push plan."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.execution.loop import follow
from pliant.execution.strategy import Place, ScriptedStrategy, policy_strategy_factory
from pliant.interfaces import Context
from pliant_tsrrt.execution import PushPlanStrategy, follow_plan, push_action
from pliant_tsrrt.models import footprints_from_scene
from pliant_tsrrt.planner import PushPlan
from pliant_tsrrt.pushing import PRIMITIVES, PushSettings, apply_action


def _world(noise: str = "bounded"):
    scene = load_scene("tsrrt-table")
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.simulator = registry.create("simulator", "pymunk", ctx, max_force=50.0, noise=noise,
                                    noise_linear=0.01, noise_angular=0.01)
    return scene, ctx.simulator


class OnePush(ScriptedStrategy):
    """Place the paddle and the objects, then one push (push_action), as a pipeline's push plan would."""

    def __init__(self, place, names, fp, index, primitive, settings):
        super().__init__()
        self.args = (names, fp, index, primitive, settings)
        self.place, self.after = place, None

    def script(self, rng):
        yield self.place
        self.after = yield from push_action(*self.args, rng, self.last)
        return "success"


@pytest.mark.parametrize(("primitive", "guard"), [("push+x", 0.001), ("turn+", 0.001), ("push-y", 0.0)])
def test_a_push_through_the_loop_moves_the_world_as_apply_action_does(primitive, guard):
    scene, direct = _world()
    names = [o.name for o in scene.objects if o.movable]
    fp = footprints_from_scene(scene, names)
    settings = PushSettings(placement_noise=0.004, guard_step=guard)
    start = {"block-1": np.array([0.5, 0.4, 0.3])}
    index, p = names.index("block-1"), PRIMITIVES.index(primitive)

    direct.reset(np.asarray(scene.start, dtype=np.float64))
    direct.set_object_poses(start)
    expected = apply_action(direct, names, fp, index, p, settings, np.random.default_rng(7))

    _, world = _world()
    strategy = OnePush(Place(np.asarray(scene.start, dtype=np.float64), start), names, fp, index, p, settings)
    record = follow(world, None, strategy, np.random.default_rng(7))
    assert set(strategy.after) == set(expected)
    for name in expected:
        np.testing.assert_array_equal(strategy.after[name], expected[name])
    np.testing.assert_array_equal(record.configurations[-1], direct.configuration())
    assert len(record.times) > 10 and record.outcome == "success"


def test_a_push_plan_names_its_strategy():
    scene, _ = _world()
    plan = PushPlan(["can-1"], np.zeros((1, 3)), [], np.zeros((1, 1, 3)), 0.0, {}, models=None)
    assert policy_strategy_factory(plan) is follow_plan
    strategy = follow_plan(plan, Context(scene=scene), {"action_limit": 7})
    assert isinstance(strategy, PushPlanStrategy) and strategy.action_limit == 7
    assert not hasattr(plan, "execute")
