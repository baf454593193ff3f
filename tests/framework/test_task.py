"""Robot-independent tasks (pliant.task): the [task] table's parsing and validation, its resolution for a robot
(a stand-in robot with a known inverse kinematics: no URDF, no pinocchio), and options scaled from a robot's
limits.  The pinocchio robots' own resolution is in tests/plugins/robots/pinocchio/test_task_robots.py."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import PipelineError, SceneError
from pliant.scene import Scene
from pliant.spaces import RealVectorSpace
from pliant.task import RobotTask, TaskPose, resolve_task, robot_scaled, scaled_options


def _scene_data(**task) -> dict:
    data = {
        "name": "task-test",
        "bounds": {"lower": [-1.0, -1.0, 0.0], "upper": [1.0, 1.0, 1.0], "resolution": 0.1},
        "robot": {"kind": "urdf", "model": "arm"},
        "task": {
            "goal": {"position": [0.5, 0.0, 0.5], "position_tolerance": 0.01},
            "start": {"position": [0.3, -0.3, 0.5]},
            "robots": {"arm": {"tool": "hand", "group": "g"},
                       "other": {"tool": {"left": "l_hand", "right": "r_hand"}, "start": [0.1, 0.2],
                                 "base": {"position": [0.0, 0.2, 0.4], "orientation": [0.0, 0.0, 1.0, 0.0]}}},
        },
    }
    data["task"].update(task)
    return data


def _error(data: dict) -> SceneError:
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data, source="t.toml")
    return info.value


def test_a_task_is_read_per_robot_model():
    scene = Scene.from_dict(_scene_data(), source="t.toml")
    task = scene.task
    assert scene.start.size == 0 and scene.goal.size == 0          # resolved per robot by the pipeline
    assert task.goal.position.tolist() == [0.5, 0.0, 0.5] and task.goal.orientation is None
    assert task.goal.position_tolerance == 0.01 and task.goal.orientation_tolerance == 0.01   # default
    assert task.solutions == 4 and task.robot is None and sorted(task.robots) == ["arm", "other"]
    arm, other = task.robots["arm"], task.robots["other"]
    assert arm.tool_for("g") == "hand" and arm.group == "g" and arm.start is None and not arm.placed
    assert other.tool_for("left") == "l_hand" and other.start.tolist() == [0.1, 0.2] and other.placed
    assert other.base_position.tolist() == [0.0, 0.2, 0.4] and other.base_orientation.tolist() == [0, 0, 1, 0]
    with pytest.raises(SceneError, match="no tool frame for other's group 'middle'"):
        other.tool_for("middle")
    with pytest.raises(SceneError, match=r"no table for robot 'iiwa' \(task.robots: arm, other\)"):
        task.for_robot("iiwa")
    assert Scene.from_dict({k: v for k, v in _scene_data().items() if k != "task"} | {
        "start": [0.0], "goal": [1.0]}, source="t.toml").task is None


@pytest.mark.parametrize(("patch", "field", "words"), [
    (lambda d: d.update(start=[0.0, 0.0]), "start", "states its start and goal there"),
    (lambda d: d["robot"].update(kind="rigid", space="r3", parts=[{"shape": "box", "size": [0.1] * 3}]) or
     d["robot"].pop("model"), "task.robots", "needs a URDF robot"),
    (lambda d: d["task"].pop("goal"), "task.goal", "required"),
    (lambda d: d["task"]["goal"].update(orientation=[0.0, 0.0, 0.0, 2.0]), "task.goal.orientation", "unit"),
    (lambda d: d["task"]["goal"].update(position=[0.0, 1.0]), "task.goal.position", ""),
    (lambda d: d["task"]["goal"].update(position_tolerance=0.0), "task.goal.position_tolerance", ""),
    (lambda d: d["task"]["goal"].update(frame="hand"), "task.goal.frame", "not a known field"),
    (lambda d: d["task"].update(solutions=0), "task.solutions", ">= 1"),
    (lambda d: d["task"]["robots"]["arm"].update(elbow=1), "task.robots.arm.elbow", "not a known field"),
    (lambda d: d["task"]["robots"]["arm"].pop("tool"), "task.robots.arm.tool", "required"),
    (lambda d: d["task"]["robots"]["arm"].update(tool={}), "task.robots.arm.tool", "needs a tool frame"),
    (lambda d: d["task"]["robots"]["other"].update(base={"position": [0, 0]}), "task.robots.other.base.position",
     ""),
    (lambda d: d["task"]["robots"]["other"].update(start={"position": [0, 0, 0], "tool": "x"}),
     "task.robots.other.start.tool", "not a known field"),
    (lambda d: d["task"].pop("start"), "task.robots.arm", "has no start"),
    (lambda d: d["task"].update(robots={}), "task.robots", "at least one"),
    (lambda d: d["robot"].update(model="pr2"), "robot.model", "not one the task supports"),
])
def test_bad_tasks_fail_naming_the_field(patch, field, words):
    data = copy.deepcopy(_scene_data())
    patch(data)
    err = _error(data)
    assert err.field == field and words in str(err)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(position=st.lists(st.floats(-5, 5), min_size=3, max_size=3),
       tolerance=st.floats(-1.0, 1.0), angle=st.floats(-3.0, 3.0))
def test_goal_poses_round_trip_or_fail_on_the_tolerance(position, tolerance, angle):
    quat = [0.0, 0.0, float(np.sin(angle / 2)), float(np.cos(angle / 2))]
    data = _scene_data(goal={"position": position, "orientation": quat, "orientation_tolerance": tolerance})
    if tolerance <= 0:
        assert _error(data).field == "task.goal.orientation_tolerance"
        return
    goal = Scene.from_dict(data, source="t.toml").task.goal
    assert np.allclose(goal.position, position) and np.allclose(goal.orientation, quat)
    assert goal.orientation_tolerance == tolerance


# --- resolution ---------------------------------------------------------------------------------------------------


class _Robot:
    """A stand-in robot of two joints in [-1, 1] whose 'tool' sits at (q0, q1, 0.5): IK is exact and known."""

    def __init__(self, model="arm", group="g", blocked=()):
        self.model_name, self.group = model, group
        self.space = RealVectorSpace(np.full(2, -1.0), np.full(2, 1.0))
        self.blocked = blocked
        self.calls = []

    def inverse_kinematics(self, frame, position, orientation=None, *, rng, solutions, position_tolerance,
                           orientation_tolerance, valid=None):
        self.calls.append((frame, tuple(position), solutions))
        q = np.asarray(position[:2], dtype=np.float64)
        found = np.array([q, q + [0.0, 0.3], q - [0.0, 0.3]])[:solutions]      # diverse solutions, some invalid
        found = found[np.all(np.abs(found) <= 1.0, axis=1)]
        if valid is not None and len(found):
            found = found[np.asarray(valid(found), dtype=bool)]
        if abs(position[2] - 0.5) > position_tolerance or tuple(position) in self.blocked:
            return np.zeros((0, 2))
        return found


def test_a_task_resolves_to_the_robot_s_start_and_the_goal_nearest_it():
    scene = Scene.from_dict(_scene_data(), source="t.toml")
    robot = _Robot()
    resolved = resolve_task(scene, robot, np.random.default_rng(0))
    assert resolved is not scene and scene.start.size == 0               # the loaded scene is left as it was
    assert resolved.start.tolist() == [0.3, -0.3]                       # the task's start pose, solved
    assert resolved.task.robot == "arm" and resolved.task.goal_states.shape == (3, 2)
    assert resolved.goal.tolist() == pytest.approx([0.5, -0.3])         # of (0.5, 0), (0.5, 0.3), (0.5, -0.3)
    assert [c[0] for c in robot.calls] == ["hand", "hand"]
    other = resolve_task(scene, _Robot("other", "right"), np.random.default_rng(0))
    data = _scene_data()
    data["task"]["robots"]["other"]["start"] = "rest"                     # a named posture of the robot
    robot_with_postures = _Robot("other", "right")
    robot_with_postures.postures = {"rest": np.array([-0.2, 0.4])}
    named = resolve_task(Scene.from_dict(data, source="t.toml"), robot_with_postures, np.random.default_rng(0))
    assert named.start.tolist() == [-0.2, 0.4]
    with pytest.raises(SceneError, match=r"not a named posture of other's group 'right' \(postures: none\)"):
        resolve_task(Scene.from_dict(data, source="t.toml"), _Robot("other", "right"), np.random.default_rng(0))
    assert other.start.tolist() == [0.1, 0.2] and other.goal.tolist() == pytest.approx([0.5, 0.3])
    plain = Scene.from_dict({k: v for k, v in _scene_data().items() if k != "task"} | {
        "start": [0.0], "goal": [1.0]}, source="t.toml")
    assert resolve_task(plain, robot, np.random.default_rng(0)) is plain


def test_an_unreachable_goal_is_refused_in_one_line_naming_robot_and_pose():
    scene = Scene.from_dict(_scene_data(goal={"position": [0.5, 0.0, 0.9]}), source="t.toml")
    with pytest.raises(SceneError) as info:
        resolve_task(scene, _Robot(), np.random.default_rng(0))
    text = str(info.value)
    assert "\n" not in text and info.value.field == "task.goal"
    assert "robot 'arm' (group 'g', tool 'hand') cannot reach the goal pose position [0.5, 0.0, 0.9]" in text
    blocked = Scene.from_dict(_scene_data(), source="t.toml")
    with pytest.raises(SceneError, match="cannot reach the start pose position") as info:
        resolve_task(blocked, _Robot(blocked=((0.3, -0.3, 0.5),)), np.random.default_rng(0))
    assert info.value.field == "task.start"


@pytest.mark.parametrize(("start", "words"), [([0.1, 0.2, 0.3], "one value per joint"),
                                              ([0.1, 1.5], "outside the joint limits")])
def test_a_start_configuration_must_fit_the_robot(start, words):
    data = _scene_data()
    data["task"]["robots"]["other"]["start"] = start
    with pytest.raises(SceneError, match=words) as info:
        resolve_task(Scene.from_dict(data, source="t.toml"), _Robot("other", "left"), np.random.default_rng(0))
    assert info.value.field == "task.robots.other.start"


def test_a_robot_without_inverse_kinematics_is_refused():
    with pytest.raises(SceneError, match="needs a URDF robot with inverse kinematics"):
        resolve_task(Scene.from_dict(_scene_data(), source="t.toml"), object(), np.random.default_rng(0))


def test_describe_and_placement():
    pose = TaskPose(np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 0.0, 1.0]), 0.02, 0.1)
    assert pose.describe() == "position [1.0, 2.0, 3.0] orientation [0.0, 0.0, 0.0, 1.0] (within 0.02 m, 0.1 rad)"
    assert not RobotTask("x", "tool").placed
    assert RobotTask("x", "tool", base_position=np.array([0.0, 0.0, 0.1])).placed


# --- options scaled from the robot --------------------------------------------------------------------------------


class _Limits:
    velocity_limits = np.array([1.0, 2.0, 4.0])
    acceleration_limits = np.array([4.0, 8.0, 16.0])


def test_options_scale_from_the_robot_s_limits():
    robot = _Limits()
    assert robot_scaled({"robot": "velocity_limits", "scale": 0.25}, robot, "p", "f") == (0.25, 0.5, 1.0)
    assert robot_scaled({"robot": "velocity_limits", "scale": 0.5, "reduce": "min"}, robot, "p", "f") == 0.5
    assert robot_scaled({"robot": "acceleration_limits", "reduce": "max"}, robot, "p", "f") == 16.0
    assert robot_scaled(0.3, robot, "p", "f") == 0.3 and robot_scaled({"a": 1}, robot, "p", "f") == {"a": 1}
    options = {"kp": 1.1, "joint_velocity_limits": {"robot": "velocity_limits", "scale": 0.25}}
    assert scaled_options(options, robot, "p", "simulator") == {"kp": 1.1, "joint_velocity_limits": (0.25, 0.5, 1.0)}
    assert scaled_options({"kp": 1.1}, robot, "p", "simulator") == {"kp": 1.1}


@pytest.mark.parametrize(("value", "field"), [
    ({"robot": "lower"}, "simulator.v.robot"),
    ({"robot": "velocity_limits", "scale": 0}, "simulator.v.scale"),
    ({"robot": "velocity_limits", "scale": True}, "simulator.v.scale"),
    ({"robot": "velocity_limits", "reduce": "median"}, "simulator.v.reduce"),
    ({"robot": "velocity_limits", "factor": 2}, "simulator.v.factor"),
    ({"robot": "jerk_limits"}, "simulator.v.robot"),          # the stand-in declares none
])
def test_bad_scaled_values_fail_naming_the_field(value, field):
    with pytest.raises(PipelineError) as info:
        scaled_options({"v": value}, _Limits(), "p.toml", "simulator")
    assert info.value.field == field
