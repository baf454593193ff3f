"""URDF robots through pinocchio: Jacobians, forward kinematics, limits, collisions, errors."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from pliant import Scene, load_scene, registry
from pliant.errors import ConfigError, DimensionError, PliantError, SceneError
from pliant.interfaces import Context
from pliant.testing import check_robot
from pliant.testing.conformance import check_component

IIWA_LINK_7 = "lbr_iiwa_link_7"
#: a point on the iiwa's flange face, in the link 7 frame (m): the top of link_7.stl
FLANGE = np.array([0.0, 0.0, 0.045])


def _scene(model: str, group: str | None = None, dim: int = 7, source: str | None = None, **robot) -> Scene:
    base = load_scene("iiwa-shelf")
    data = dict(base.raw)
    data["robot"] = {"kind": "urdf", "model": model, **({"group": group} if group else {}), **robot}
    data["start"] = data["goal"] = [0.0] * dim
    return Scene.from_dict(data, source=source or base.source)


def _robot(model: str, group: str | None = None, resolution: float = 0.05, dim: int = 7, **options):
    ctx = Context(scene=_scene(model, group, dim))
    return registry.create("robot", "pinocchio", ctx, resolution=resolution, **options)


def _finite_differences(robot, q, indices=None, eps=1e-6):
    cols = [(robot.body_points(q + eps * e, indices) - robot.body_points(q - eps * e, indices)) / (2 * eps)
            for e in np.eye(robot.space.dim)]
    return np.stack(cols, axis=-1)


@pytest.fixture(scope="module")
def iiwa():
    return registry.create("robot", "pinocchio", Context(scene=load_scene("iiwa-shelf")))


@pytest.fixture(scope="module")
def pr2():
    return _robot("pr2", "left_arm", resolution=0.08)


@pytest.fixture(scope="module")
def baxter():
    return _robot("baxter", "right_arm", resolution=0.08)


# --- conformance and Jacobians -------------------------------------------------------------------


def test_iiwa_passes_the_conformance_kit(iiwa):
    assert check_robot(iiwa)
    assert check_component("robot", "pinocchio")          # in its example scene, from the registry


@pytest.mark.parametrize("name", ["iiwa", "pr2", "baxter"])
def test_point_jacobians_match_central_finite_differences(name, request):
    robot = request.getfixturevalue(name)
    q = robot.space.sample(np.random.default_rng(2), 2)
    idx = np.arange(0, robot.point_count(), 5)
    jac = robot.point_jacobians(q, idx)
    assert jac.shape == (2, len(idx), 3, 7)
    assert np.allclose(jac, _finite_differences(robot, q, idx), atol=1e-6)
    assert np.any(np.abs(jac) > 1e-2)                      # the arm's points do move
    assert np.allclose(robot.point_jacobians(q)[:, idx], jac)


def test_whole_body_jacobians_only_move_what_each_joint_carries():
    pr2 = _robot("pr2", "all", resolution=0.15, dim=30)
    q = pr2.space.sample(np.random.default_rng(6), 1)
    idx = np.arange(0, pr2.point_count(), 3)
    jac = pr2.point_jacobians(q, idx)
    assert np.allclose(jac, _finite_differences(pr2, q, idx), atol=1e-6)
    on_left = np.array([pr2.model.names[int(j)].startswith("l_") for j in pr2.point_joint[idx]])
    right_columns = [k for k, name in enumerate(pr2.joint_names) if name.startswith("r_")]
    assert on_left.any() and np.all(jac[0][on_left][..., right_columns] == 0.0)
    assert np.any(jac[0][on_left][..., pr2.joint_names.index("torso_lift_joint")] != 0.0)


def test_frame_jacobian_matches_finite_differences(baxter):
    q = baxter.space.sample(np.random.default_rng(5), 3)
    jac = baxter.frame_jacobians(q, "right_gripper", [0.01, 0.02, 0.03])
    fd = np.stack([(baxter.frame_position(q + 1e-6 * e, "right_gripper", [0.01, 0.02, 0.03])
                    - baxter.frame_position(q - 1e-6 * e, "right_gripper", [0.01, 0.02, 0.03])) / 2e-6
                   for e in np.eye(7)], axis=-1)
    assert np.allclose(jac, fd, atol=1e-6)


def test_iiwa_jacobian_matches_pybullet(iiwa):
    import pybullet as pb
    import pybullet_data

    client = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(pybullet_data.getDataPath() + "/kuka_iiwa/model.urdf", useFixedBase=True,
                           physicsClientId=client)
        assert pb.getNumJoints(body, physicsClientId=client) == 7
        for q in iiwa.space.sample(np.random.default_rng(3), 5):
            for j, value in enumerate(q):
                pb.resetJointState(body, j, value, physicsClientId=client)
            state = pb.getLinkState(body, 6, computeForwardKinematics=True, physicsClientId=client)
            # pybullet's localPosition is in the URDF link frame (passing the link's centre of mass,
            # getLinkState()[2], gives the velocity of the centre of mass, as in pybullet's jacobian.py)
            lin, _ = pb.calculateJacobian(body, 6, FLANGE.tolist(), q.tolist(), [0.0] * 7, [0.0] * 7,
                                          physicsClientId=client)
            ours = iiwa.frame_jacobians(q, IIWA_LINK_7, FLANGE)[0]
            assert np.allclose(ours, np.array(lin), atol=1e-9)
            link_rotation = np.array(pb.getMatrixFromQuaternion(state[5])).reshape(3, 3)
            flange_world = np.array(state[4]) + link_rotation @ FLANGE
            assert np.allclose(iiwa.frame_position(q, IIWA_LINK_7, FLANGE)[0], flange_world, atol=1e-9)
    finally:
        pb.disconnect(client)


# --- forward kinematics and limits ---------------------------------------------------------------


def test_iiwa_zero_posture_stands_straight_up(iiwa):
    import pybullet_data

    root = ET.parse(pybullet_data.getDataPath() + "/kuka_iiwa/model.urdf").getroot()
    offsets = [np.linalg.norm([float(v) for v in j.find("origin").get("xyz").split()]) for j in root.findall("joint")]
    height = sum(offsets)                     # 0.1575 + 0.2025 + 0.2045 + 0.2155 + 0.1845 + 0.2155 + 0.081
    assert height == pytest.approx(1.261)
    placement = iiwa.frame_placements(np.zeros(7), IIWA_LINK_7)[0]
    assert np.allclose(placement[:3, 3], [0.0, 0.0, height], atol=1e-9)
    assert np.allclose(np.abs(placement[:3, 2]), [0.0, 0.0, 1.0], atol=1e-9)     # the flange axis is vertical
    assert np.allclose(iiwa.frame_position(np.zeros(7), IIWA_LINK_7, FLANGE)[0], [0, 0, height + 0.045])


def test_body_points_follow_their_links(iiwa):
    q = iiwa.space.sample(np.random.default_rng(4), 3)
    pts = iiwa.body_points(q)
    assert pts.shape == (3, iiwa.point_count(), 3) and pts.dtype == np.float64
    assert np.allclose(iiwa.body_points(q[2]), pts[2:3])
    # points of link 7 keep their distances to the flange point under any motion
    on7 = np.flatnonzero(iiwa.point_joint == iiwa.model.getJointId("lbr_iiwa_joint_7"))
    assert len(on7) > 10
    gaps = np.linalg.norm(pts[:, on7] - iiwa.frame_position(q, IIWA_LINK_7, FLANGE)[:, None], axis=-1)
    assert np.allclose(gaps, gaps[0], atol=1e-9)


def test_iiwa_velocity_limits_are_the_published_ones(iiwa):
    assert np.allclose(iiwa.velocity_limits, np.radians([98, 98, 100, 130, 140, 180, 180]))
    assert np.allclose(iiwa.acceleration_limits, 4.0 * iiwa.velocity_limits)
    assert np.allclose(iiwa.jerk_limits, 20.0 * iiwa.acceleration_limits)
    assert np.allclose(iiwa.space.lower, -iiwa.space.upper)
    assert np.allclose(iiwa.space.upper, np.radians([170, 120, 170, 120, 170, 120, 175]))


def test_explicit_limits_and_weights():
    robot = _robot("iiwa", "arm", 0.1, acceleration_limits=[10.0] * 7, jerk_factor=5.0)
    assert np.allclose(robot.acceleration_limits, 10.0) and np.allclose(robot.jerk_limits, 50.0)
    scene = _scene("iiwa", "arm", weights=[2.0, 2, 1, 1, 1, 1, 0.5])
    weighted = registry.create("robot", "pinocchio", Context(scene=scene), resolution=0.1)
    assert weighted.distance(np.zeros(7), [0.1, 0, 0, 0, 0, 0, 0.2])[0] == pytest.approx(math.hypot(0.2, 0.1))


def test_groups_and_continuous_joints(pr2, baxter):
    assert pr2.joint_names[0] == "l_shoulder_pan_joint" and len(pr2.joint_names) == 7
    for robot in (pr2, baxter):
        assert {"all", "left_arm", "right_arm"} <= set(robot.groups)
    assert baxter.joint_names == [f"right_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2")]
    # forearm and wrist roll are continuous: bounded to a turn
    assert pr2.continuous.tolist() == [False] * 4 + [True, False, True]
    assert pr2.space.lower[4] == -math.pi and pr2.space.upper[6] == math.pi
    # a continuous joint is a proper angle: a full turn brings the points back
    q = np.zeros(7)
    turned = q.copy()
    turned[4] = 2 * math.pi - 1e-12
    idx = np.arange(0, pr2.point_count(), 11)
    assert np.allclose(pr2.body_points(q, idx), pr2.body_points(turned, idx), atol=1e-9)


def test_whole_body_group_and_posture():
    robot = _robot("baxter", "all", 0.1, dim=19, posture={"head_pan": 0.5})
    assert robot.space.dim == 19 and "head_pan" in robot.joint_names
    arm = _robot("baxter", "right_arm", 0.1, posture={"left_e1": 1.0})
    assert arm.base_configuration[arm.model.joints[arm.model.getJointId("left_e1")].idx_q] == 1.0


def test_moving_body_only_by_default(pr2):
    everything = _robot("pr2", "left_arm", 0.08, body="all")
    assert pr2.point_count() < everything.point_count()
    assert set(np.unique(pr2.point_joint)) <= pr2.moving_joints()


def test_materials_come_from_the_options():
    soft = _robot("iiwa", "arm", 0.1, deformability=0.3, sensitivity=2.0)
    assert np.allclose(soft.point_materials(), [0.3, 2.0])
    assert np.allclose(_robot("iiwa", "arm", 0.1).point_materials(), [0.0, 1.0])


# --- collision -----------------------------------------------------------------------------------


def test_self_collision(iiwa, pr2, baxter):
    folded = [0.0, 2.0, 0.0, -2.0, 0.0, 2.0, 0.0]               # the wrist folded back onto the base
    assert iiwa.self_collision(np.vstack([np.zeros(7), folded])).tolist() == [False, True]
    pointing_down = [0.0, 1.3, 0.0, 0.0, 0.0, 0.0, 0.0]         # the straight arm pitched into the base
    assert pr2.self_collision(np.vstack([np.zeros(7), pointing_down])).tolist() == [False, True]
    into_pedestal = [1.7, 0.5, 0.0, 1.5, 0.0, 0.0, 0.0]         # the forearm folded down onto the pedestal
    assert baxter.self_collision(np.vstack([np.zeros(7), into_pedestal])).tolist() == [False, True]


def test_environment_distance(iiwa):
    scene = iiwa.context.scene
    q = np.vstack([np.zeros(7), scene.start, scene.goal, [0.0, 1.2, 0.0, -0.4, 0.0, 0.0, 0.0],
                   [0.0, 1.6, 0.0, 0.0, 0.0, 0.0, 0.0]])
    d = iiwa.environment_distance(q)
    assert d.shape == (5,)
    assert d[0] > 0.3 and d[1] > 0 and d[2] > 0          # upright, start and goal are clear of the shelf
    assert 0 < d[3] < d[0]                                # leaning toward the board
    assert d[4] <= 0                                      # the arm laid down across the board
    assert np.allclose([iiwa.environment_distance(x)[0] for x in q], d)
    assert iiwa.in_collision(q).tolist() == [False, False, False, False, True]
    assert not iiwa.self_collision(np.vstack([scene.start, scene.goal])).any()


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


# --- bad input -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("model", "group", "error", "text"), [
    ("iiwa", "left_arm", ConfigError, "unknown joint group"),
    ("pr2", "legs", ConfigError, "unknown joint group"),
    ("r2d2", None, SceneError, "unknown robot"),
    ("missing.urdf", None, SceneError, "URDF file not found"),
])
def test_bad_robots(model, group, error, text):
    with pytest.raises(error, match=text) as info:
        _robot(model, group)
    assert info.value.field in ("robot.model", "robot.group")
    assert info.value.value == (group if "group" in text else model)


def test_bad_group_option():
    with pytest.raises(ConfigError, match="unknown joint group") as info:
        registry.create("robot", "pinocchio", Context(scene=_scene("iiwa")), group="torso")
    assert info.value.value == "torso"


def test_unloadable_urdf(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'><parent link='a'/></joint></robot>")
    broken = tmp_path / "broken.urdf"
    broken.write_text("this is not XML <<<")
    for path in (bad, broken):
        scene = _scene(path.name, source=str(tmp_path / "scene.toml"))
        with pytest.raises(SceneError, match="cannot load the URDF") as info:
            registry.create("robot", "pinocchio", Context(scene=scene))
        assert info.value.field == "robot.model" and info.value.value == path.name


def test_a_urdf_path_works_as_model(tmp_path):
    import pybullet_data

    path = pybullet_data.getDataPath() + "/kuka_iiwa/model.urdf"
    robot = registry.create("robot", "pinocchio", Context(scene=_scene(path)), resolution=0.1)
    assert robot.space.dim == 7 and robot.joint_names[0] == "lbr_iiwa_joint_1"
    assert np.allclose(robot.velocity_limits, 10.0)          # the file's own (placeholder) limits


def test_wrong_configurations(iiwa):
    for bad in (np.zeros(6), np.zeros((2, 8)), np.full(7, np.nan), [0, 0, 0, np.inf, 0, 0, 0]):
        for method in (iiwa.body_points, iiwa.point_jacobians, iiwa.self_collision, iiwa.environment_distance):
            with pytest.raises(DimensionError) as info:
                method(bad)
            assert info.value.field == "configurations"
    with pytest.raises(ConfigError, match="no link"):
        iiwa.frame_position(np.zeros(7), "gripper")


def test_bad_scene_and_options():
    with pytest.raises(SceneError, match="one value per joint") as info:
        registry.create("robot", "pinocchio", Context(scene=_scene("iiwa", "arm", dim=6)))
    assert info.value.field == "start"
    data = dict(load_scene("iiwa-shelf").raw)
    data["goal"] = [0.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    with pytest.raises(SceneError, match="lbr_iiwa_joint_2") as info:
        registry.create("robot", "pinocchio", Context(scene=Scene.from_dict(data)))
    assert info.value.field == "goal"
    with pytest.raises(SceneError, match="one weight per joint"):
        registry.create("robot", "pinocchio", Context(scene=_scene("iiwa", "arm", weights=[1.0, 2.0])))
    with pytest.raises(ConfigError, match="posture"):
        _robot("iiwa", "arm", 0.1, posture={"elbow": 1.0})
    with pytest.raises(ConfigError, match="one value per joint"):
        _robot("iiwa", "arm", 0.1, jerk_limits=[1.0, 2.0])
    with pytest.raises(ConfigError):
        _robot("iiwa", "arm", 0.1, acceleration_factor=-1.0)
    with pytest.raises(PliantError, match="kind is 'urdf'"):
        registry.create("robot", "pinocchio", Context(scene=load_scene("triple-wall")))


def test_mesh_objects_count_like_their_shape(tmp_path, iiwa):
    half = np.array([0.15, 0.4, 0.02])
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    lines = ["solid board"]
    for f in faces:
        lines += ["facet normal 0 0 0", "outer loop", *(f"vertex {x} {y} {z}" for x, y, z in corners[list(f)]),
                  "endloop", "endfacet"]
    (tmp_path / "board.stl").write_text("\n".join([*lines, "endsolid board"]))
    data = dict(load_scene("iiwa-shelf").raw)
    board = next(o for o in data["objects"] if o["name"] == "board")
    data["objects"] = [{"name": "board", "shape": "mesh", "file": "board.stl", "position": board["position"],
                        "deformability": 0.0, "sensitivity": 1.0}]
    meshy = registry.create("robot", "pinocchio", Context(scene=Scene.from_dict(data, base_dir=tmp_path)),
                            resolution=0.1)
    data["objects"] = [board]
    boxy = registry.create("robot", "pinocchio", Context(scene=Scene.from_dict(data)), resolution=0.1)
    q = np.vstack([np.zeros(7), [0.0, 1.2, 0.0, -0.4, 0.0, 0.0, 0.0], [0.3, 1.0, 0.2, -0.8, 0.1, 0.5, 0.0]])
    assert np.allclose(meshy.environment_distance(q), boxy.environment_distance(q), atol=1e-6)
