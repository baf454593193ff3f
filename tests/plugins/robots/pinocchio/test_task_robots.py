"""The pinocchio robots under a robot-independent task (pliant.task): the base placement moves kinematics, body
points and collisions alike; each of pr2, baxter and iiwa gets its group and tool from the task and a start and goal
solved by inverse kinematics (tool within the pose's tolerance, inside the joint limits, collision-free, the same
for the same seed); a placed base is refused by URDF simulators with a clear error.  Seeded, small scenes."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.components import Context
from pliant.components.validity import ValidityChecker
from pliant.errors import SceneError
from pliant.scene import Scene
from pliant.task import resolve_task

GOAL, START = [0.68, 0.0, 0.72], [0.64, -0.44, 0.76]
TOOLS = {"pr2": ("right_arm", "r_gripper_tool_frame"), "baxter": ("right_arm", "right_gripper"),
         "iiwa": ("arm", "lbr_iiwa_link_7")}


def _robot(scene, **options):
    return registry.create("robot", "pinocchio", Context(scene=scene), **options)


@functools.cache
def _resolved(model: str):
    scene = load_scene("arm-reach")
    robot = _robot(scene, model=model)
    return robot, resolve_task(scene, robot, np.random.default_rng(7), ValidityChecker(scene, robot))


@pytest.mark.parametrize("model", sorted(TOOLS))
def test_each_robot_gets_its_start_and_goal_from_the_task(model):
    robot, scene = _resolved(model)
    group, tool = TOOLS[model]
    assert robot.group == group and scene.task.robot == model
    if model == "pr2":                                  # the scene names the PR2's posture
        assert np.array_equal(scene.start, robot.postures["tuck"])
    else:
        assert np.linalg.norm(robot.frame_position(scene.start[None], tool)[0] - START) <= 0.01
    states = scene.task.goal_states
    assert len(states) >= 2 and any(np.array_equal(scene.goal, s) for s in states)
    assert np.all(np.linalg.norm(robot.frame_position(states, tool) - GOAL, axis=1) <= 0.01)
    checker = ValidityChecker(scene, robot)
    assert checker.states_valid(np.vstack([scene.start[None], states])).all()
    # the goal is the solution nearest the start
    assert robot.space.distance(scene.goal, scene.start) == pytest.approx(
        np.min(robot.space.distance(states, scene.start)))


def test_the_same_seed_gives_the_same_start_and_goal():
    robot, scene = _resolved("baxter")
    again = resolve_task(load_scene("arm-reach"), robot, np.random.default_rng(7), ValidityChecker(scene, robot))
    assert np.array_equal(again.start, scene.start) and np.array_equal(again.goal, scene.goal)


def _placed_scene(position, orientation=(0.0, 0.0, 0.0, 1.0)) -> Scene:
    return Scene.from_dict({
        "name": "placed", "bounds": {"lower": [-2.0, -2.0, 0.0], "upper": [2.0, 2.0, 2.0], "resolution": 0.08},
        "robot": {"kind": "urdf", "model": "iiwa"},
        "task": {"goal": {"position": [0.5, 0.0, 0.8]}, "start": {"position": [0.4, 0.3, 0.9]},
                 "robots": {"iiwa": {"tool": "lbr_iiwa_link_7", "base": {"position": list(position),
                                                                          "orientation": list(orientation)}}}},
    }, source="placed.toml")


def test_the_base_placement_moves_frames_and_body_points_alike():
    origin, placed = _robot(_placed_scene((0.0, 0.0, 0.0))), _robot(_placed_scene((0.3, -0.2, 0.45),
                                                                                 (0.0, 0.0, 1.0, 0.0)))
    q = np.random.default_rng(0).uniform(origin.lower, origin.upper, (3, 7))
    turn = np.diag([-1.0, -1.0, 1.0])                # 180 degrees about z
    shift = np.array([0.3, -0.2, 0.45])
    for frame in ("lbr_iiwa_link_7", "lbr_iiwa_link_3"):
        assert np.allclose(placed.frame_position(q, frame), origin.frame_position(q, frame) @ turn.T + shift)
    assert np.allclose(placed.body_points(q), origin.body_points(q) @ turn.T + shift)
    assert not origin.task.placed and placed.task.placed
    # a URDF simulator is told where the base stands
    assert origin.urdf_description().base_position == (0.0, 0.0, 0.0)
    assert placed.urdf_description().base_position == (0.3, -0.2, 0.45)
    assert placed.urdf_description().base_orientation == (0.0, 0.0, 1.0, 0.0)


def test_pybullet_places_the_base_where_pinocchio_does():
    """The same link in pybullet (loaded from the description) and in pinocchio, at three configurations of the
    placed iiwa: the link frames' world positions agree."""
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    placed = _robot(_placed_scene((0.3, -0.2, 0.45), (0.0, 0.0, np.sin(0.4), np.cos(0.4))))
    description = placed.urdf_description()
    pb = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        body = pb.loadURDF(str(description.urdf), basePosition=list(description.base_position),
                           baseOrientation=list(description.base_orientation), useFixedBase=True)
        joints = {pb.getJointInfo(body, j)[1].decode(): j for j in range(pb.getNumJoints(body))}
        links = {pb.getJointInfo(body, j)[12].decode(): j for j in range(pb.getNumJoints(body))}
        for q in np.random.default_rng(1).uniform(placed.lower, placed.upper, (3, 7)):
            for name, value in zip(description.joint_names, q):
                pb.resetJointState(body, joints[name], float(value))
            for frame in ("lbr_iiwa_link_7", "lbr_iiwa_link_3"):
                world = pb.getLinkState(body, links[frame], computeForwardKinematics=True)[4]
                assert np.allclose(world, placed.frame_position(q[None], frame)[0], atol=1e-6)
    finally:
        pb.disconnect()


def test_an_unreachable_goal_names_the_robot_and_the_pose():
    scene = load_scene("arm-reach", variant="far")
    robot = _robot(scene, model="pr2")
    with pytest.raises(SceneError) as info:
        resolve_task(scene, robot, np.random.default_rng(0), ValidityChecker(scene, robot))
    assert str(info.value).count("\n") == 0 and info.value.field == "task.goal"
    assert "robot 'pr2' (group 'right_arm', tool 'r_gripper_tool_frame') cannot reach the goal pose position " \
           "[1.5, -0.2, 0.8]" in str(info.value)


def test_a_robot_the_task_does_not_list_is_refused():
    scene = _placed_scene((0.0, 0.0, 0.0))
    with pytest.raises(SceneError, match=r"no table for robot 'pr2' \(task.robots: iiwa\)"):
        _robot(scene, model="pr2")


def test_named_postures_per_group_and_an_unknown_one_is_refused():
    scene = load_scene("arm-reach")
    robot = _robot(scene, model="pr2")
    assert sorted(robot.postures) == ["tuck"] and robot.postures["tuck"].shape == (7,)
    assert _robot(scene, model="baxter", group="left_arm").postures["neutral"].tolist() == [0, -0.55, 0, 0.75, 0,
                                                                                            1.26, 0]
    data = {"name": "p", "bounds": {"lower": [-1.0, -1.0, 0.0], "upper": [1.0, 1.0, 1.6], "resolution": 0.08},
            "robot": {"kind": "urdf", "model": "pr2"},
            "task": {"goal": {"position": [0.6, -0.2, 0.8]},
                     "robots": {"pr2": {"group": "right_arm", "tool": "r_gripper_tool_frame", "start": "wave"}}}}
    scene = Scene.from_dict(data, source="p.toml")
    robot = _robot(scene)
    with pytest.raises(SceneError, match=r"not a named posture of pr2's group 'right_arm' \(postures: tuck\)") as info:
        resolve_task(scene, robot, np.random.default_rng(0), ValidityChecker(scene, robot))
    assert info.value.field == "task.robots.pr2.start" and info.value.value == "wave"
