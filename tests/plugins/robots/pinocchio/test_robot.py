"""URDF robots through pinocchio: Jacobians, forward kinematics, limits, collisions, errors."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from pliant import Scene, load_scene, registry
from pliant.errors import DimensionError, PliantError, PluginError
from pliant.interfaces import Context
from pliant.testing import check_robot


def _robot(model: str, group: str | None = None, resolution: float = 0.05):
    scene = load_scene("iiwa-shelf")
    data = dict(scene.raw)
    data["robot"] = {"kind": "urdf", "model": model, **({"group": group} if group else {})}
    ctx = Context(scene=Scene.from_dict(data, source=scene.source))
    return registry.create("robot", "pinocchio", ctx, resolution=resolution)


@pytest.fixture(scope="module")
def iiwa():
    return _robot("iiwa", "arm", 0.04)


@pytest.fixture(scope="module", params=[("pr2", "left_arm"), ("baxter", "right_arm")])
def big_robot(request):
    return _robot(*request.param, resolution=0.08)


def _finite_differences(robot, q, eps=1e-6):
    cols = [(robot.body_points(q + eps * e) - robot.body_points(q - eps * e)) / (2 * eps)
            for e in np.eye(robot.space.dim)]
    return np.stack(cols, axis=-1)


def test_iiwa_conforms_and_jacobians_match_finite_differences(iiwa):
    assert check_robot(iiwa)
    q = iiwa.space.sample(np.random.default_rng(1), 2)
    assert np.allclose(iiwa.point_jacobians(q), _finite_differences(iiwa, q), atol=1e-6)


def test_pr2_and_baxter_arms(big_robot):
    assert big_robot.space.dim == 7
    q = big_robot.space.sample(np.random.default_rng(2), 1)
    idx = np.arange(0, big_robot.point_count(), 7)
    jac = big_robot.point_jacobians(q, idx)
    fd = np.stack([(big_robot.body_points(q + 1e-6 * e, idx) - big_robot.body_points(q - 1e-6 * e, idx)) / 2e-6
                   for e in np.eye(7)], axis=-1)
    assert np.allclose(jac, fd, atol=1e-6)
    assert np.any(np.abs(jac) > 1e-3)


def test_iiwa_jacobian_matches_pybullet(iiwa):
    import pybullet as pb
    import pybullet_data

    client = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(pybullet_data.getDataPath() + "/kuka_iiwa/model.urdf", useFixedBase=True,
                           physicsClientId=client)
        rng = np.random.default_rng(3)
        for q in iiwa.space.sample(rng, 4):
            for j, value in enumerate(q):
                pb.resetJointState(body, j, value, physicsClientId=client)
            state = pb.getLinkState(body, 6, computeForwardKinematics=True, physicsClientId=client)
            com = np.array(state[0])
            lin, _ = pb.calculateJacobian(body, 6, list(state[2]), q.tolist(), [0.0] * 7, [0.0] * 7,
                                          physicsClientId=client)
            ours = iiwa.jacobian_at(q, "lbr_iiwa_link_7", com)
            assert np.allclose(ours, np.array(lin), atol=1e-9)
            assert np.allclose(iiwa.frame_position(q, "lbr_iiwa_link_7")[0], state[4], atol=1e-9)
    finally:
        pb.disconnect(client)


def test_iiwa_zero_posture_stands_straight_up(iiwa):
    import pybullet_data

    root = ET.parse(pybullet_data.getDataPath() + "/kuka_iiwa/model.urdf").getroot()
    # at zero the arm is straight: every joint offset (expressed in rotated frames) stacks up along z
    height = sum(np.linalg.norm([float(v) for v in j.find("origin").get("xyz").split()])
                 for j in root.findall("joint"))
    flange = iiwa.frame_position(np.zeros(7), "lbr_iiwa_link_7")[0]
    assert np.allclose(flange, [0.0, 0.0, height], atol=1e-9)


def test_iiwa_velocity_limits_are_the_published_ones(iiwa):
    assert np.allclose(iiwa.velocity_limits, np.radians([98, 98, 100, 130, 140, 180, 180]))
    assert np.allclose(iiwa.acceleration_limits, 4.0 * iiwa.velocity_limits)
    assert np.allclose(iiwa.jerk_limits, 20.0 * iiwa.acceleration_limits)
    assert np.allclose(iiwa.space.upper, [2.96705973, 2.0943951, 2.96705973, 2.0943951, 2.96705973, 2.0943951,
                                          3.05432619])


def test_self_collision(iiwa):
    folded = np.array([0.0, 2.0, 0.0, -2.0, 0.0, 2.0, 0.0])
    assert iiwa.self_collision(np.vstack([np.zeros(7), folded])).tolist() == [False, True]


def test_environment_distance(iiwa):
    d = iiwa.environment_distance(np.vstack([np.zeros(7), [0.0, 1.2, 0.0, -0.4, 0.0, 0.0, 0.0]]))
    assert d[0] > 0.3 and d[1] < d[0]


def test_pr2_continuous_joints_are_bounded_to_a_turn():
    pr2 = _robot("pr2", "right_arm", resolution=0.1)
    names = pr2.joint_names
    assert names[4] == "r_forearm_roll_joint" and pr2.continuous[4]
    assert pr2.space.lower[4] == -math.pi and pr2.space.upper[4] == math.pi


@pytest.mark.parametrize(("model", "group", "text"), [
    ("iiwa", "left_arm", "unknown joint group"),
    ("r2d2", None, "unknown robot"),
    ("missing.urdf", None, "URDF file not found"),
])
def test_bad_robots(model, group, text):
    with pytest.raises(PluginError, match=text):
        _robot(model, group)


def test_unloadable_urdf(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'><parent link='a'/></joint></robot>")
    data = dict(load_scene("iiwa-shelf").raw)
    data["robot"] = {"kind": "urdf", "model": "bad.urdf"}
    ctx = Context(scene=Scene.from_dict(data, source=str(tmp_path / "s.toml")))
    with pytest.raises(PliantError):
        registry.create("robot", "pinocchio", ctx)


def test_wrong_configuration_length(iiwa):
    with pytest.raises(DimensionError):
        iiwa.body_points(np.zeros(6))
    with pytest.raises(DimensionError):
        iiwa.body_points(np.full(7, np.nan))


def test_baxter_reach_start_and_goal_are_free_and_the_goal_reaches_into_the_hole():
    from pliant.voxelgrid import VoxelGrid
    from pliant_kinematic.contact import ContactModel

    scene = load_scene("baxter-reach")
    ctx = Context(scene=scene)
    robot = registry.create("robot", "pinocchio", ctx)
    everything = registry.create("robot", "pinocchio", ctx, body="all")
    assert robot.point_count() < everything.point_count()          # static links carry no points
    contact = ContactModel(VoxelGrid.from_scene(scene))
    points = robot.body_points(np.vstack([scene.start, scene.goal]))
    assert not contact.colliding(points).any()
    assert points[1, :, 0].max() > 1.03                             # past the wall's face, inside the hole
    assert np.allclose(robot.space.weights, 1 / np.array([0.27, 0.27, 0.27, 0.27, 0.3, 0.3, 0.5]), rtol=1e-4)
