"""Hostile demonstrations and options for PIIRL (issue 31): waypoints far outside the workspace (1e6 m once made the
sampler allocate 136 GiB), tasks naming objects the scene lacks, NaN, the wrong dimension, no demonstrations, and
``lower`` above ``upper`` are refused with a ConfigError naming the demonstration, the waypoint or field and the
bounds -- before anything is computed from them; the capture tool never steps out of the workspace."""

from __future__ import annotations

import json

import numpy as np
import pliant
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import ConfigError
from pliant.interfaces import Context
from pliant_piirl.demonstration import (
    Demonstration,
    DemonstrationTask,
    check_demonstrations,
    save_demonstrations,
)

SCENE = pliant.load_scene("hollow-cube")
LOWER, UPPER = SCENE.lower, SCENE.upper          # the probe's workspace: [-0.04, 0.444] m on every axis
UP = np.array([0.7071067811865476, 0.0, 0.0, 0.7071067811865476])   # the scene's start orientation


@pytest.fixture(scope="module")
def context():
    ctx = Context(scene=SCENE)
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    return ctx


def _demo(positions, objects=("L1", "M1")) -> Demonstration:
    path = np.array([np.r_[p, UP] for p in positions], dtype=np.float64)
    return Demonstration(DemonstrationTask(path[0].copy(), np.array([0.202, 0.202, 0.2]), np.zeros((0, 4)),
                                           tuple(objects)), path, "test")


GOOD = _demo([[0.202, 0.202, 0.34], [0.202, 0.202, 0.3], [0.202, 0.202, 0.26]])


def test_a_good_demonstration_passes(context):
    assert check_demonstrations([GOOD], SCENE, context.space) == [GOOD]


def test_a_waypoint_a_million_metres_away_is_refused_naming_it_and_the_bounds(context):
    far = _demo([[0.202, 0.202, 0.34], [1e6, 0.202, 0.3], [0.202, 0.202, 0.26]])
    with pytest.raises(ConfigError) as exc:
        check_demonstrations([GOOD, far], SCENE, context.space)
    assert exc.value.field == "demonstrations[1].path[1]"
    assert "waypoint 1 lies outside the workspace bounds [-0.04, -0.04, -0.04] .. [0.444, 0.444, 0.444] m" in str(
        exc.value)
    assert exc.value.value[0] == 1e6


def test_a_task_naming_an_object_the_scene_lacks_is_refused(context):
    with pytest.raises(ConfigError) as exc:
        check_demonstrations([_demo([[0.2, 0.2, 0.3], [0.2, 0.2, 0.25]], objects=("L1", "mug"))], SCENE,
                             context.space)
    assert exc.value.field == "demonstrations[0].task.objects[1]" and exc.value.value == "mug"
    assert "lacks" in str(exc.value) and "L1, L2, M1" in str(exc.value)


@pytest.mark.parametrize("mangle, field, words", [
    (lambda d: Demonstration(d.task, np.array([d.path[0], [np.nan] * 7]), "x"), "demonstrations[0].path[1]",
     "is not finite"),
    (lambda d: Demonstration(d.task, d.path[:, :5], "x"), "demonstrations[0].path", "7 coordinates"),
    (lambda d: Demonstration(d.task, d.path[:1], "x"), "demonstrations[0].path", "needs 2 to"),
    (lambda d: Demonstration(d.task, np.array([d.path[0], np.r_[0.2, 0.2, 0.2, 0, 0, 0, 2.0]]), "x"),
     "demonstrations[0].path[1]", "unit norm"),
    (lambda d: Demonstration(DemonstrationTask(d.path[0], np.array([0.2, 0.2, 5.0])), d.path, "x"),
     "demonstrations[0].task.target", "inside the scene's bounds"),
    (lambda d: Demonstration(DemonstrationTask(np.r_[0.2, 0.2, -3.0, UP], d.task.target), d.path, "x"),
     "demonstrations[0].task.start", "outside the workspace bounds"),
    (lambda d: Demonstration(DemonstrationTask(d.path[0], d.task.target, goal=np.r_[0.2, 0.2, 0.2]), d.path, "x"),
     "demonstrations[0].task.goal", "7 coordinates"),
])
def test_malformed_demonstrations_are_refused_naming_the_field(context, mangle, field, words):
    with pytest.raises(ConfigError) as exc:
        check_demonstrations([mangle(GOOD)], SCENE, context.space)
    assert exc.value.field == field and words in str(exc.value), str(exc.value)


@pytest.mark.parametrize("data", [[], None, "not a list", [GOOD, "junk"]])
def test_no_demonstrations_or_junk_is_refused(context, data):
    with pytest.raises(ConfigError):
        check_demonstrations(data, SCENE, context.space)


COORD = st.floats(-2.0, 2.0, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(COORD, COORD, COORD), min_size=2, max_size=8))
def test_refused_iff_a_waypoint_lies_outside_and_the_first_such_waypoint_is_named(context, positions):
    positions = np.array(positions)
    outside = np.any((positions < LOWER) | (positions > UPPER), axis=1)
    demo = Demonstration(DemonstrationTask(np.r_[0.2, 0.2, 0.3, UP], np.array([0.2, 0.2, 0.2])),
                         np.array([np.r_[p, UP] for p in positions]), "random")
    if not outside.any():
        check_demonstrations([demo], SCENE, context.space)
        return
    with pytest.raises(ConfigError) as exc:
        check_demonstrations([demo], SCENE, context.space)
    first = int(np.argmax(outside))
    assert exc.value.field == f"demonstrations[0].path[{first}]"
    assert f"waypoint {first} lies outside the workspace bounds" in str(exc.value)


# --- through the learner -----------------------------------------------------------------------------------------

_LEARNERS: dict = {}


def _learner(context, **options):
    """A piirl learner whose sampler fails the test if it is ever reached (one per options, built once)."""
    key = tuple(sorted(options.items()))
    if key not in _LEARNERS:
        learner = pliant.registry.create("learner", "piirl", context, samples=5, rounds=1, **options)

        def no_sampling(*args, **kwargs):
            raise AssertionError("the sampler ran on a demonstration that should have been refused")

        learner.sampler.improve = no_sampling
        _LEARNERS[key] = learner
    return _LEARNERS[key]


def test_the_learner_refuses_a_far_waypoint_before_sampling(context):
    far = _demo([[0.202, 0.202, 0.34], [0.202, 1e6, 0.3]])
    with pytest.raises(ConfigError, match=r"learner.data\[0\].path\[1\]: waypoint 1 lies outside"):
        _learner(context).fit([far], np.random.default_rng(0))


def test_the_learner_refuses_a_file_with_a_far_waypoint_naming_file_and_waypoint(context, tmp_path):
    far = _demo([[0.202, 0.202, 0.34], [0.202, 0.202, 0.3], [0.202, 0.202, -1e6]])
    path = save_demonstrations(tmp_path / "d.json", [GOOD, far], "hollow-cube")
    with pytest.raises(ConfigError) as exc:
        _learner(context).fit(str(path), np.random.default_rng(0))
    assert exc.value.source == str(path) and exc.value.field == "demonstrations[1].path[2]"
    # the option's file the same way
    with pytest.raises(ConfigError, match=r"demonstrations\[1\].path\[2\]: waypoint 2"):
        _learner(context, demonstrations=str(path)).fit(None, np.random.default_rng(0))


def test_the_learner_refuses_unknown_objects(context, tmp_path):
    data = json.loads((save_demonstrations(tmp_path / "d.json", [GOOD], "hollow-cube")).read_text())
    data["demonstrations"][0]["task"]["objects"] = ["L1", "teapot"]
    (tmp_path / "d.json").write_text(json.dumps(data))
    with pytest.raises(ConfigError, match=r"task.objects\[1\]: names an object the scene 'hollow-cube' lacks"):
        _learner(context).fit(str(tmp_path / "d.json"), np.random.default_rng(0))


@pytest.mark.parametrize("name", ["piirl", "active-piirl"])
def test_lower_above_upper_is_refused_naming_both(name):
    with pytest.raises(ConfigError) as exc:
        pliant.registry.create("learner", name, lower=2000.0, upper=1000.0)
    assert exc.value.field == "learner.lower" and "lower (2000) is above upper (1000)" in str(exc.value)
    with pytest.raises(ConfigError, match=r"initial must lie within lower \.\. upper"):
        pliant.registry.create("learner", name, lower=1.0, upper=200.0)
    pliant.registry.create("learner", name, lower=1.0, upper=200.0, initial=100.0)


def test_a_tip_beyond_the_workspace_is_refused_when_bound(context):
    # hollow-cube's workspace diagonal: 0.484 * sqrt(3) = 0.838 m
    with pytest.raises(ConfigError, match=r"learner.tip: the tip lies farther .* \(0.8383 m\)"):
        pliant.registry.create("learner", "piirl", context, tip=(0.0, 0.0, -1e6))


def test_the_capture_tool_never_steps_out_of_the_workspace():
    from pliant_piirl.capture import CaptureSession
    from pliant_piirl.features import DeformationFeatures

    # no collision planes: only the workspace stops the probe, which starts 0.104 m below its top
    task = DemonstrationTask(np.r_[0.202, 0.202, 0.34, UP], np.array([0.202, 0.202, 0.2]))
    session = CaptureSession(DeformationFeatures(SCENE), task, np.array([0.0, 0.0, -0.06]))
    state = session.play("r" * 70)                      # 2 mm up per key: 0.14 m asked
    path = np.array(session.path)
    assert np.all(path[:, 2] <= UPPER[2]) and state["refused"] >= 70 - 52
    assert len(path) - 1 == 70 - state["refused"]
