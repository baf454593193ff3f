"""Movable objects in the pymunk backend: pushing, table friction, mass, reset, determinism, refusals."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from pliant import Pipeline, Scene, registry
from pliant.errors import SimulationError
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import Context
from pliant.scene import bundled_scenes_dir
from pliant.testing import check_component
from pliant.validation import read_toml

PUSH = read_toml(bundled_scenes_dir() / "se2-push.toml")
CRATE = 1                    # index of the crate in se2-push's objects


def _context(patch=None, base_dir=None, support=None) -> Context:
    """se2-push with the crate's table updated by ``patch`` (and the table's friction ``support``, if given)."""
    data = copy.deepcopy(PUSH)
    data.pop("variants")
    if support is not None:
        data["physics"]["support"]["friction"] = support
    data["objects"][CRATE].update(patch or {})
    for key in [k for k, v in (patch or {}).items() if v is None]:
        del data["objects"][CRATE][key]
    ctx = Context(scene=Scene.from_dict(data, source="push.toml", base_dir=base_dir))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


def _push(sim, speed=0.2, push_steps=30, rest_steps=10, seed=0, noise_rng=None):
    """Drive the paddle along +x for ``push_steps`` control steps, then command zero; robot and crate poses."""
    sim.reset(sim.context.scene.start)
    rng = noise_rng or np.random.default_rng(seed)
    robot, crate = [sim.configuration()], [sim.object_poses()["crate"]]
    for k in range(push_steps + rest_steps):
        v = np.array([speed, 0.0, 0.0]) if k < push_steps else np.zeros(3)
        robot.append(sim.step(v, 0.1, rng))
        crate.append(sim.object_poses()["crate"])
    return np.array(robot), np.array(crate)


@pytest.fixture(scope="module")
def push():
    return _context()


def test_the_pushed_crate_moves_along_the_push_and_stops_after_it(push):
    sim = registry.create("simulator", "pymunk", push, max_force=50.0)
    robot, crate = _push(sim, push_steps=30, rest_steps=10)
    start = np.array([0.6, 0.5, 0.0])
    assert np.array_equal(crate[0], start)
    moved = crate[30] - start
    # the paddle (front face 2 cm ahead of its centre) advanced 0.6 m from 0.3 and met the crate's face at 0.52
    assert moved[0] == pytest.approx(robot[30, 0] + 0.02 + 0.08 - 0.6, abs=0.01) and moved[0] > 0.3
    assert abs(moved[1]) < 0.005 and abs(moved[2]) < 0.01        # straight on: no drift, no turn
    # table friction mu g = 4.9 m/s^2 stops a crate at 0.2 m/s within 0.05 s, sliding v^2 / (2 mu g) ~ 4 mm
    assert 0.0 <= crate[32, 0] - crate[30, 0] < 0.01
    assert np.abs(crate[-1] - crate[33]).max() < 1e-9               # at rest: it no longer moves


def test_without_table_friction_the_crate_glides_on():
    sim = registry.create("simulator", "pymunk", _context(support=0.0), max_force=50.0)
    _, crate = _push(sim, push_steps=30, rest_steps=10)
    assert crate[-1, 0] - crate[30, 0] > 0.1                          # keeps its speed after the push


def test_the_deprecated_table_friction_option_still_overrides_the_scene(push):
    with pytest.warns(FutureWarning, match=r"table_friction' is deprecated: set the scene's \[physics.support\]"):
        sim = registry.create("simulator", "pymunk", push, max_force=50.0, table_friction=0.0)
    _, crate = _push(sim, push_steps=30, rest_steps=10)
    assert crate[-1, 0] - crate[30, 0] > 0.1


def test_a_heavier_crate_moves_less_and_a_too_heavy_one_stops_the_pusher():
    light, heavy = _context({"mass": 1.0}), _context({"mass": 10.0})    # table friction 4.9 N and 49 N
    moved = {}
    for name, ctx in (("light", light), ("heavy", heavy)):
        sim = registry.create("simulator", "pymunk", ctx, max_force=50.0)
        _, crate = _push(sim, push_steps=30, rest_steps=0)
        moved[name] = crate[-1, 0] - crate[0, 0]
    assert moved["light"] > moved["heavy"] + 0.05 and moved["heavy"] > 0.0
    # 20 N cannot overcome 49 N of table friction: the paddle stops at the crate's face (x = 0.52 - 0.02)
    sim = registry.create("simulator", "pymunk", heavy, max_force=20.0)
    robot, crate = _push(sim, push_steps=30, rest_steps=0)
    assert np.abs(crate[-1] - crate[0]).max() < 1e-3
    assert robot[-1, 0] == pytest.approx(0.50, abs=0.005) and sim.in_contact()


def test_reset_restores_the_crate_at_rest():
    sim = registry.create("simulator", "pymunk", _context(support=0.0), max_force=50.0)
    _push(sim, push_steps=30, rest_steps=0)
    assert sim.object_poses()["crate"][0] > 0.8
    sim.reset(np.array([0.3, 0.5, 0.0]))
    assert np.array_equal(sim.object_poses()["crate"], [0.6, 0.5, 0.0])
    body = sim._object_parts[0][0]
    assert tuple(body.velocity) == (0.0, 0.0) and body.angular_velocity == 0.0
    # at rest for good: a second of doing nothing (no table friction, so any leftover speed would show)
    for _ in range(10):
        sim.step(np.zeros(3), 0.1, np.random.default_rng(0))
    assert np.array_equal(sim.object_poses()["crate"], [0.6, 0.5, 0.0])


def test_same_seed_same_trajectory_including_the_crate(push):
    sim = registry.create("simulator", "pymunk", push, max_force=50.0, noise="bounded", noise_linear=0.05,
                          noise_angular=0.05)
    a = _push(sim, seed=5)
    _push(sim, speed=0.5, seed=9)                                     # another particle in between
    b = _push(sim, seed=5)
    c = _push(sim, seed=6)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.array_equal(a[1], c[1])
    fresh = registry.create("simulator", "pymunk", push, max_force=50.0, noise="bounded", noise_linear=0.05,
                            noise_angular=0.05)
    d = _push(fresh, seed=5)
    assert np.array_equal(a[1], d[1])


@pytest.mark.parametrize("shape", [{"shape": "cylinder", "radius": 0.08, "length": 0.1, "size": None},
                                   {"shape": "sphere", "radius": 0.1, "position": [0.6, 0.5, 0.06], "size": None}])
def test_round_objects_are_circles_of_their_cross_section(shape):
    ctx = _context(shape)
    sim = registry.create("simulator", "pymunk", ctx, max_force=50.0)
    radius = sim.objects[0].radius
    assert radius == pytest.approx(0.08)                               # the sphere: sqrt(0.1^2 - 0.06^2)
    robot, crate = _push(sim, push_steps=30, rest_steps=5)
    assert crate[-1, 0] - 0.6 == pytest.approx(robot[30, 0] + 0.02 + radius - 0.6, abs=0.01)
    assert abs(crate[-1, 1] - 0.5) < 0.01


def test_object_friction_is_the_objects_own_else_the_option():
    sim = registry.create("simulator", "pymunk", _context({"friction": 0.9}), friction=0.3)
    assert sim._object_parts[0][1].friction == 0.9
    sim = registry.create("simulator", "pymunk", _context({"friction": None}), friction=0.3)
    assert sim._object_parts[0][1].friction == 0.3


def test_static_objects_with_friction_are_walls_of_that_friction():
    data = copy.deepcopy(PUSH)
    data.pop("variants")
    data["objects"][0]["friction"] = 0.0
    ctx = Context(scene=Scene.from_dict(data, source="push.toml"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    sim = registry.create("simulator", "pymunk", ctx, friction=0.7)
    walls = [s for s in sim.world.shapes if s.body is sim.world.static_body]
    boxes = len(VoxelGrid.from_scene(ctx.scene, static_only=True).boxes())
    assert len(walls) == boxes + 4                       # and the four walls closing the bounds
    assert all(s.friction == 0.0 for s in walls[:boxes]) and all(s.friction == 0.7 for s in walls[boxes:])


@pytest.mark.parametrize("patch, field, reason", [
    ({"cutouts": [{"shape": "box", "size": [0.04, 0.04, 0.1], "position": [0.6, 0.5, 0.0]}]},
     r"objects\[1\]\.cutouts", "cut-outs"),
    ({"orientation": [0.0, 0.7071067811865476, 0.0, 0.7071067811865476]}, r"objects\[1\]\.orientation", "about z"),
    ({"position": [0.6, 0.5, 0.058]}, r"objects\[1\]\.position", "layer"),   # in the bounds, off the layer
    ({"position": [0.06, 0.5, 0.0]}, r"objects\[1\]\.position", "inside static geometry"),
    ({"shape": "mesh", "file": "tri.obj", "size": None}, r"objects\[1\]\.shape", "mesh"),
])
def test_what_pymunk_cannot_represent_is_refused_naming_the_field(patch, field, reason, tmp_path):
    (tmp_path / "tri.obj").write_text("v 0 0 -1\nv 1 0 -1\nv 0 1 -1\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n")
    ctx = _context(patch, base_dir=tmp_path)
    with pytest.raises(SimulationError, match=rf"push\.toml:{field}: movable object 'crate': .*{reason}"):
        registry.create("simulator", "pymunk", ctx)


def test_the_push_slide_pipeline_records_the_crate(tmp_path):
    record = Pipeline.from_file("push-slide", overrides=[f'output="{tmp_path}"']).run()
    e = record.execution
    assert e.success and e.objects["crate"].shape == (len(e.times), 3)
    # pushed from 0.6 until the paddle reached x = 1.0 (within 2 cm): the crate ends 10 cm ahead of the paddle's
    # furthest reach (half the paddle's and half the crate's depth), plus a few mm of sliding
    furthest = e.configurations[:, 0].max()
    assert furthest == pytest.approx(1.0, abs=0.02) and e.configurations[-1, 0] == pytest.approx(0.8, abs=0.02)
    assert e.objects["crate"][-1, 0] - furthest == pytest.approx(0.10, abs=0.01)
    assert abs(e.objects["crate"][-1, 1] - 0.5) < 0.01


def test_the_kinematic_simulator_holds_the_crate_fixed(tmp_path):
    record = Pipeline.from_file("push-slide", overrides=["simulator=kinematic", f'output="{tmp_path}"']).run()
    e = record.execution
    assert e.outcome == "stuck" and e.objects == {} and e.to_dict()["objects"] == {}
    assert e.configurations[:, 0].max() < 0.52 - 0.02 + 0.01          # the paddle stops at the crate's face


def test_conformance_on_the_push_scene():
    assert check_component("simulator", "pymunk", scene="se2-push")
