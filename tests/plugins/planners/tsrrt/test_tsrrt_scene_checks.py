"""Hostile TS-RRT scenes (issue 31): objects that overlap at the start, reach off the table or are rotated out of the
table's plane are refused with a ConfigError naming the object(s), when the planner or the push-models learner is
bound -- before any push is learned -- and a start that merely lacks the clearance margin is an ``invalid start``
whose message names the objects.  The overlap depth is checked against known answers and, for random pairs, against
the planner's own overlap test."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import load_scene, registry
from pliant.errors import ConfigError
from pliant.interfaces import Context, PlanningProblem
from pliant.results import Status
from pliant_tsrrt.domain import PushOptions, check_scene, penetration
from pliant_tsrrt.geometry import BOX, CIRCLE, Footprints, pair_overlap


def _scene(tmp_path, replace: dict[str, str], name: str = "hostile.toml"):
    """tsrrt-table (or tsrrt-obstacles) with text replacements, loaded from a file."""
    from pliant.scene import resolve_scene_path

    base = replace.pop("__base__", "tsrrt-table")
    text = resolve_scene_path(base).read_text()
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text)
    return load_scene(path)


BLOCK_AT = "position = [0.8, 0.18, 0.0]"
BLOCK_TURN = "orientation = [0.0, 0.0, -0.173648, 0.984808]"


@pytest.mark.parametrize("name", ["tsrrt-table", "tsrrt-obstacles", "tsrrt-setting"])
def test_the_bundled_tsrrt_scenes_pass(name):
    check_scene(load_scene(name), PushOptions())


def test_overlapping_objects_are_refused_naming_both(tmp_path):
    # the block (10 cm square, -20 degrees) moved onto the book's centre
    scene = _scene(tmp_path, {BLOCK_AT: "position = [0.22, 0.58, 0.0]"})
    with pytest.raises(ConfigError) as exc:
        check_scene(scene, PushOptions())
    text = str(exc.value)
    assert "'book-1' and 'block-1' overlap by" in text and "at the start" in text
    assert exc.value.field == "objects[1].position" and exc.value.value == [0.22, 0.58, 0.0]


def test_the_overlap_depth_is_stated_in_millimetres(tmp_path):
    # the can (r 5 cm) at 0.85 from the block's centre on its x axis, the block unturned: 0.05 + 0.05 - 0.04 = 6 cm
    scene = _scene(tmp_path, {BLOCK_TURN: "orientation = [0.0, 0.0, 0.0, 1.0]",
                              "position = [0.72, 0.62, 0.0]": "position = [0.84, 0.18, 0.0]"})
    with pytest.raises(ConfigError, match=r"'block-1' and 'can-1' overlap by 60\.0 mm at the start"):
        check_scene(scene, PushOptions())


def test_objects_that_touch_are_accepted(tmp_path):
    scene = _scene(tmp_path, {BLOCK_TURN: "orientation = [0.0, 0.0, 0.0, 1.0]",
                              "position = [0.72, 0.62, 0.0]": "position = [0.9, 0.18, 0.0]"})
    check_scene(scene, PushOptions())


def test_an_object_off_the_table_is_refused_naming_it(tmp_path):
    # inside the scene's bounds (which reach 0.2 m beyond the table), but beyond the table's edge x = 1
    scene = _scene(tmp_path, {BLOCK_AT: "position = [1.12, 0.18, 0.0]"})
    with pytest.raises(ConfigError) as exc:
        check_scene(scene, PushOptions())
    assert "object 'block-1' reaches" in str(exc.value) and "off the table" in str(exc.value)
    assert exc.value.field == "objects[1].position"


def test_the_table_is_the_named_region(tmp_path):
    # a table region that ends at x = 0.5: the block at x = 0.8 is off it
    scene = _scene(tmp_path, {"upper = [1.0, 0.8]": "upper = [1.0, 0.8]\n\n[[regions]]\nname = \"small\"\n"
                              "lower = [0.0, 0.0]\nupper = [0.5, 0.8]"})
    check_scene(scene, PushOptions())
    with pytest.raises(ConfigError, match="'block-1' reaches"):
        check_scene(scene, PushOptions(table="small"))


def test_an_object_rotated_out_of_the_plane_is_refused_naming_it(tmp_path):
    scene = _scene(tmp_path, {BLOCK_TURN: "orientation = [0.707107, 0.0, 0.0, 0.707107]"})
    with pytest.raises(ConfigError) as exc:
        check_scene(scene, PushOptions())
    assert "object 'block-1' is rotated out of the table's plane" in str(exc.value)
    assert exc.value.field == "objects[1].orientation"


def test_a_fixed_obstacle_on_the_table_rotated_out_of_the_plane_is_refused(tmp_path):
    scene = _scene(tmp_path, {"__base__": "tsrrt-obstacles",
                              'size = [0.3, 0.04, 0.04]\nposition = [0.3, 0.2, 0.0]':
                              'size = [0.3, 0.04, 0.04]\nposition = [0.3, 0.2, 0.0]\n'
                              'orientation = [0.0, 0.382683, 0.0, 0.92388]'})
    with pytest.raises(ConfigError, match="object 'wall' is rotated out"):
        check_scene(scene, PushOptions())


def test_an_object_overlapping_a_fixed_obstacle_is_refused(tmp_path):
    scene = _scene(tmp_path, {"__base__": "tsrrt-obstacles", BLOCK_AT: "position = [0.5, 0.45, 0.0]"})
    with pytest.raises(ConfigError, match="object and fixed obstacle 'block-1' and 'post' overlap by"):
        check_scene(scene, PushOptions())


def _bound(scene, kind, name):
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "rigid", ctx)
    return registry.create(kind, name, ctx)


@pytest.mark.parametrize("kind,name", [("planner", "tsrrt"), ("learner", "push-models")])
def test_the_planner_and_the_learner_refuse_when_bound(tmp_path, kind, name):
    scene = _scene(tmp_path, {BLOCK_AT: "position = [0.26, 0.58, 0.0]"})
    with pytest.raises(ConfigError, match="'book-1' and 'block-1' overlap"):
        _bound(scene, kind, name)


def test_plan_refuses_a_hostile_scene_before_learning(tmp_path):
    # plan() on a problem whose scene the planner was not bound to: refused before any push (no simulator here --
    # learning would need one, so reaching it would be a PlanningError about the simulator instead)
    planner = registry.create("planner", "tsrrt")
    scene = _scene(tmp_path, {BLOCK_AT: "position = [1.12, 0.18, 0.0]"})
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "rigid", ctx)
    with pytest.raises(ConfigError, match="'block-1' reaches"):
        planner.plan(PlanningProblem.from_context(ctx), np.random.default_rng(0))


def test_a_start_without_the_clearance_margin_is_an_invalid_start_naming_the_objects(tmp_path):
    # the block unturned with its right side 5 mm from the can's left: closer than 2 x margin (1 cm), not touching;
    # the answer comes before learning (no simulator in the problem)
    scene = _scene(tmp_path, {BLOCK_TURN: "orientation = [0.0, 0.0, 0.0, 1.0]",
                              "position = [0.72, 0.62, 0.0]": "position = [0.905, 0.18, 0.0]"})
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "rigid", ctx)
    planner = registry.create("planner", "tsrrt", ctx, start="scene")
    result = planner.plan(PlanningProblem.from_context(ctx), np.random.default_rng(0))
    assert result.status == Status.INVALID_START
    assert "'block-1' and 'can-1' too close" in result.message
    assert "book-1" not in result.message


# --- the overlap depth ------------------------------------------------------------------------------------------

def test_penetration_known_answers():
    box, circle = np.array([0.05, 0.02]), np.array([0.03, 0.03])
    zero = np.zeros(3)
    # two axis-aligned boxes 8 cm apart along x: 2 x 5 cm reach, 2 cm overlap
    assert penetration(zero, BOX, box, np.array([0.08, 0.0, 0.0]), BOX, box) == pytest.approx(0.02)
    # along y they are only 4 cm tall: 3 cm apart -> 1 cm
    assert penetration(zero, BOX, box, np.array([0.0, 0.03, 0.0]), BOX, box) == pytest.approx(0.01)
    # circles 5 cm apart, radii 3 cm: 1 cm; 7 cm apart: -1 cm
    assert penetration(zero, CIRCLE, circle, np.array([0.05, 0.0, 0.0]), CIRCLE, circle) == pytest.approx(0.01)
    assert penetration(zero, CIRCLE, circle, np.array([0.07, 0.0, 0.0]), CIRCLE, circle) == pytest.approx(-0.01)
    # a circle off the box's corner (5, 2) cm by (3, 4) cm -> 5 cm away: 3 - 5 = -2 cm; swapped the same
    c = np.array([0.08, 0.06, 0.0])
    assert penetration(zero, BOX, box, c, CIRCLE, circle) == pytest.approx(-0.02)
    assert penetration(c, CIRCLE, circle, zero, BOX, box) == pytest.approx(-0.02)
    # a circle centred inside the box, 1 cm below its top face: 3 + 1 cm
    assert penetration(zero, BOX, box, np.array([0.0, 0.01, 0.0]), CIRCLE, circle) == pytest.approx(0.04)


KINDS = st.sampled_from([BOX, CIRCLE])


def _brute_depth(pa, ka, ha, pb, kb, hb) -> float:
    """The least distance b must move (over 240 directions, in 0.5 mm steps up to 0.3 m) to stop overlapping a,
    by the planner's own overlap test: the penetration depth, up to the grid."""
    angles = np.linspace(0, 2 * np.pi, 240, endpoint=False)
    steps = np.arange(0, 0.3, 0.0005)
    d = np.stack([np.cos(angles), np.sin(angles)], -1)
    moved = pb[None, None, :2] + steps[None, :, None] * d[:, None, :]           # (720, steps, 2)
    poses = np.concatenate([moved, np.full(moved.shape[:2] + (1,), pb[2])], -1).reshape(1, -1, 3)
    m = poses.shape[1]
    hit = pair_overlap(np.broadcast_to(pa, (1, m, 3)), Footprints(np.full(m, ka), np.tile(ha, (m, 1))), poses,
                       Footprints(np.full(m, kb), np.tile(hb, (m, 1))))[0].reshape(len(angles), len(steps))
    first_free = np.where(hit.all(axis=1), np.inf, steps[np.argmin(hit, axis=1)])   # per direction
    return float(first_free.min())


@settings(max_examples=30, deadline=None)
@given(KINDS, KINDS, st.floats(-0.15, 0.15), st.floats(-0.15, 0.15), st.floats(-np.pi, np.pi),
       st.floats(-np.pi, np.pi), st.floats(0.01, 0.1), st.floats(0.01, 0.1), st.floats(0.01, 0.1),
       st.floats(0.01, 0.1))
def test_penetration_is_the_least_separating_translation(ka, kb, x, y, ta, tb, ax, ay, bx, by):
    pa, pb = np.array([0.0, 0.0, ta]), np.array([x, y, tb])
    ha = np.array([ax, ay]) if ka == BOX else np.array([ax, ax])
    hb = np.array([bx, by]) if kb == BOX else np.array([bx, bx])
    depth = penetration(pa, ka, ha, pb, kb, hb)
    assert penetration(pb, kb, hb, pa, ka, ha) == pytest.approx(depth, abs=1e-12)
    hit = pair_overlap(pa[None, None], Footprints([ka], [ha]), pb[None, None], Footprints([kb], [hb]))[0, 0]
    if abs(depth) > 1e-9:
        assert hit == (depth > 0)
    if depth > 0:
        assert _brute_depth(pa, ka, ha, pb, kb, hb) == pytest.approx(depth, abs=0.0006)


def test_overlap_messages_parse_as_one_line(tmp_path):
    scene = _scene(tmp_path, {BLOCK_AT: "position = [0.26, 0.58, 0.0]"})
    with pytest.raises(ConfigError) as exc:
        check_scene(scene, PushOptions())
    assert "\n" not in str(exc.value) and re.search(r"overlap by \d+\.\d mm", str(exc.value))
