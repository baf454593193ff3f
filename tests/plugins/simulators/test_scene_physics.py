"""Simulators read their physics from the scene (pliant.physics, issue 36): the values each one builds its bodies
with, damping as the scene defines it, the one-line report of what a simulator ignores, and push-slide's crate
ending in the same place in pymunk and pybullet."""

from __future__ import annotations

import copy
import logging

import numpy as np
import pytest
from pliant import Pipeline, Scene, registry
from pliant.interfaces import Context
from pliant.physics import STANDARD_GRAVITY
from pliant.scene import bundled_scenes_dir
from pliant.validation import read_toml

PUSH = read_toml(bundled_scenes_dir() / "se2-push.toml")
CRATE = {"friction": 0.6, "restitution": 0.3, "rolling_friction": 0.01, "inertia": [0.004, 0.005, 0.006],
         "linear_damping": 0.5, "angular_damping": 0.25}


def _context(crate=None, robot=None, support=0.3, rim=0.9) -> Context:
    data = copy.deepcopy(PUSH)
    data.pop("variants")
    data["objects"][0]["friction"] = rim
    data["objects"][1].update(crate or {})
    data["robot"].update(robot or {"mass": 0.5, "friction": 0.7})
    data["physics"]["support"]["friction"] = support
    ctx = Context(scene=Scene.from_dict(data, source="push.toml"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


def _messages(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "pliant.physics"]


def test_pybullet_builds_its_bodies_from_the_scene():
    sim = registry.create("simulator", "pybullet", _context(CRATE))
    pb = sim.pb
    crate = pb.getDynamicsInfo(sim.objects.bodies[0], -1)
    assert crate[0] == pytest.approx(1.0) and crate[1] == pytest.approx(0.6)
    np.testing.assert_allclose(crate[2], CRATE["inertia"])
    assert crate[5] == pytest.approx(0.3) and crate[6] == pytest.approx(0.01)
    robot = pb.getDynamicsInfo(sim.body.body, -1)
    assert robot[0] == pytest.approx(0.5) and robot[1] == pytest.approx(0.7)
    others = {pb.getBodyUniqueId(k) for k in range(pb.getNumBodies())} - {sim.body.body, *sim.objects.bodies}
    assert others and {round(pb.getDynamicsInfo(b, -1)[1], 6) for b in others} == {0.9}     # the rim's friction


def test_pymunk_builds_its_bodies_from_the_scene():
    sim = registry.create("simulator", "pymunk", _context(CRATE))
    body, shape, slide, spin = sim._object_parts[0]
    assert body.mass == pytest.approx(1.0) and body.moment == pytest.approx(0.006)
    assert shape.friction == pytest.approx(0.6) and shape.elasticity == pytest.approx(0.3)
    assert slide.max_force == pytest.approx(0.3 * 1.0 * STANDARD_GRAVITY)     # the support's mu m g
    assert spin.max_force == pytest.approx(slide.max_force * sim.objects[0].mean_radius())
    assert sim.body.mass == pytest.approx(0.5)
    assert {s.friction for s in sim._robot_objects[1:] if hasattr(s, "friction")} == {0.7}


@pytest.mark.parametrize("name", ["pymunk", "pybullet"])
def test_damping_is_the_fraction_of_velocity_lost_per_second(name):
    """A crate set gliding at 0.2 m/s on a frictionless table with linear damping 0.5 keeps half its speed after a
    second, in both simulators (Bullet's (1 - d)^t, pymunk's kept fraction 1 - d)."""
    sim = registry.create("simulator", name, _context({"linear_damping": 0.5}, support=0.0))
    if name == "pymunk":
        sim._object_parts[0][0].velocity = (0.2, 0.0)
    else:
        sim.pb.resetBaseVelocity(sim.objects.bodies[0], [0.2, 0.0, 0.0], [0.0, 0.0, 0.0])
    start = sim.object_poses()["crate"][0]
    for _ in range(10):
        sim.step(np.zeros(3), 0.1, np.random.default_rng(0))
    travelled = sim.object_poses()["crate"][0] - start
    assert travelled == pytest.approx(0.2 * (0.5 - 1) / np.log(0.5), rel=0.03)     # integral of 0.2 * 0.5^t


@pytest.mark.parametrize(("name", "ignored"), [
    ("pymunk", ["objects.static_friction (crate)", "objects.rolling_friction (crate)"]),
    ("pybullet", ["objects.static_friction (crate)"]),
    ("kinematic", ["objects.mass (crate)", "objects.static_friction (crate)", "robot.mass", "support.friction"]),
])
def test_what_a_simulator_ignores_is_printed_once_per_build(name, ignored, caplog):
    ctx = _context({"static_friction": 0.8, "rolling_friction": 0.01})
    with caplog.at_level(logging.WARNING, logger="pliant.physics"):
        sim = registry.create("simulator", name, ctx)
        if name != "kinematic":              # (its first step compiles kernels: seconds; nothing is reported there)
            sim.reset(ctx.scene.start)
            sim.step(np.zeros(3), 0.1, np.random.default_rng(0))
    messages = _messages(caplog)
    assert len(messages) == 1 and f"simulator {name} ignores" in messages[0]
    for text in ignored:
        assert text in messages[0]
    if name == "pybullet":
        assert "rolling_friction" not in messages[0]


def test_a_scene_stating_only_what_pymunk_represents_prints_nothing(caplog):
    with caplog.at_level(logging.WARNING, logger="pliant.physics"):
        registry.create("simulator", "pymunk", _context({k: v for k, v in CRATE.items() if k != "rolling_friction"}))
    assert _messages(caplog) == []


def test_push_slide_ends_the_crate_in_the_same_place_in_pymunk_and_pybullet():
    """The issue's acceptance: the same plan executed in both, the crate's final poses within 3 cm and 0.1 rad."""
    final = {}
    for name in ("pymunk", "pybullet"):
        record = Pipeline.from_file("push-slide", overrides={"execution.world": {
            "name": name, "velocity_limit": 0.25, "max_force": 50.0}}).run(write=False)
        assert record.outcome.value == "reached"
        final[name] = np.asarray(record.execution.objects["crate"][-1])
    gap = final["pymunk"] - final["pybullet"]
    assert np.hypot(gap[0], gap[1]) < 0.03 and abs(gap[2]) < 0.1
    assert final["pymunk"][0] > 1.0                       # and it was pushed (from 0.6)


def test_the_deprecated_object_damping_option_still_works_with_a_warning():
    with pytest.warns(FutureWarning, match="object_damping' is deprecated: set linear_damping and angular_damping"):
        sim = registry.create("simulator", "pybullet", _context(), object_damping=0.5)
    assert sim.objects.damping == 0.5
