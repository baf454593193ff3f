"""URDF robots through pinocchio: Jacobians, forward kinematics, limits, collisions, errors."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from pliant import Scene, load_scene, registry
from pliant.errors import ConfigError, DimensionError, PliantError, SceneError
from pliant.interfaces import Context
from pliant.testing import check_robot
from pliant.testing.conformance import check_component
from pliant_pinocchio.kinematics import PRISMATIC, JointChain

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
    # the batched chain with a prismatic group joint (the torso) and unaligned finger joints
    assert pr2._chain is not None and pr2._chain.kind[1] == PRISMATIC
    assert np.allclose(jac, pr2._point_jacobians_reference(q, idx), rtol=0, atol=1e-10)
    assert np.allclose(pr2.body_points(q), pr2._body_points_reference(q), rtol=0, atol=1e-10)
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


# --- batched kinematics (pliant_pinocchio.kinematics) against pinocchio ---------------------------


def _pinocchio_points(robot, q, indices):
    """World points ``(n, k, 3)`` from pinocchio's forward kinematics, one configuration at a time."""
    out = []
    for x in robot.full_configurations(q):
        pin.forwardKinematics(robot.model, robot.data, x)
        rot = np.array([robot.data.oMi[int(j)].rotation for j in robot.point_joint[indices]])
        pos = np.array([robot.data.oMi[int(j)].translation for j in robot.point_joint[indices]])
        out.append(np.einsum("kij,kj->ki", rot, robot.local_points[indices]) + pos)
    return np.array(out)


def _pinocchio_jacobians(robot, q, indices):
    """``(n, k, 3, d)`` from pinocchio's joint Jacobians (LOCAL_WORLD_ALIGNED, at each joint's origin)."""
    out = []
    for x, world in zip(robot.full_configurations(q), _pinocchio_points(robot, q, indices)):
        pin.computeJointJacobians(robot.model, robot.data, x)
        rows = []
        for j, p in zip(robot.point_joint[indices], world):
            jac = pin.getJointJacobian(robot.model, robot.data, int(j), pin.LOCAL_WORLD_ALIGNED)[:, robot.idx_v]
            lever = p - robot.data.oMi[int(j)].translation
            rows.append(jac[:3] + np.cross(jac[3:].T, lever).T)           # v_o + w x (p - o), per column
        out.append(rows)
    return np.array(out)


@pytest.mark.parametrize("name", ["iiwa", "pr2", "baxter"])
def test_batched_body_points_and_jacobians_equal_pinocchio(name, request):
    robot = request.getfixturevalue(name)
    assert robot._chain is not None                         # the batched path, not the fallback loop
    rng = np.random.default_rng(11)
    q = np.vstack([robot.space.sample(rng, 4), robot.space.lower, robot.space.upper])
    every = np.arange(robot.point_count())
    assert np.allclose(robot.body_points(q), _pinocchio_points(robot, q, every), rtol=0, atol=1e-10)
    assert np.allclose(robot.body_points(q), robot._body_points_reference(q), rtol=0, atol=1e-10)
    assert np.allclose(robot.point_jacobians(q), robot._point_jacobians_reference(q), rtol=0, atol=1e-10)
    # unsorted, repeated and negative point indices, and a single configuration (d,)
    idx = np.concatenate([rng.integers(0, robot.point_count(), 40), [-1, 0, 0]])
    wrapped = idx % robot.point_count()
    assert np.allclose(robot.body_points(q, idx), _pinocchio_points(robot, q, wrapped), rtol=0, atol=1e-10)
    jac = robot.point_jacobians(q, idx)
    assert jac.shape == (len(q), len(idx), 3, robot.space.dim)
    assert np.allclose(jac, _pinocchio_jacobians(robot, q, wrapped), rtol=0, atol=1e-10)
    assert np.allclose(jac, robot._point_jacobians_reference(q, idx), rtol=0, atol=1e-10)
    assert np.allclose(robot.body_points(q[1], idx), robot.body_points(q, idx)[1:2], rtol=0, atol=0)
    assert robot.body_points(q, []).shape == (len(q), 0, 3)
    assert robot.point_jacobians(q, np.zeros(0, dtype=int)).shape == (len(q), 0, 3, robot.space.dim)


_ODD_LINKS = """<robot name="odd">
  <link name="base"/>
  <link name="upper"><collision><origin xyz="0 0 0.15"/><geometry><box size="0.06 0.05 0.3"/></geometry>
  </collision></link>
  <link name="lower"><collision><origin xyz="0.1 0 0" rpy="0 1.57 0"/><geometry><cylinder radius="0.03"
  length="0.2"/></geometry></collision></link>
"""


def _odd_robot(tmp_path, joints: str, dim: int):
    path = tmp_path / "odd.urdf"
    path.write_text(_ODD_LINKS + joints + "</robot>")
    scene = _scene(path.name, dim=dim, source=str(tmp_path / "scene.toml"))
    return registry.create("robot", "pinocchio", Context(scene=scene), resolution=0.04)


def test_floating_and_planar_joints_off_the_group_are_fixed_in_the_batched_chain(tmp_path):
    # free-flyer and planar joints (not in any group: nv > 1) at their posture, then unaligned revolute and
    # prismatic group joints
    robot = _odd_robot(tmp_path, """
  <link name="floating_link"/><link name="planar_link"/>
  <joint name="float" type="floating"><parent link="base"/><child link="floating_link"/>
    <origin xyz="0.1 0.2 0.3" rpy="0.1 0.2 0.3"/></joint>
  <joint name="slide" type="planar"><parent link="floating_link"/><child link="planar_link"/>
    <origin xyz="0 0 0.1" rpy="0.3 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="shoulder" type="revolute"><parent link="planar_link"/><child link="upper"/>
    <origin xyz="0 0 0.05" rpy="0 0.2 0"/><axis xyz="0.6 0 0.8"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="reach" type="prismatic"><parent link="upper"/><child link="lower"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 0.6 0.8"/><limit lower="-0.1" upper="0.2" effort="1" velocity="1"/></joint>
""", dim=2)
    kinds = [robot.model.joints[j].shortname() for j in range(1, robot.model.njoints)]
    assert kinds == ["JointModelFreeFlyer", "JointModelPlanar", "JointModelRevoluteUnaligned",
                     "JointModelPrismaticUnaligned"]
    assert robot._chain is not None and robot._chain.joints.tolist() == [0, 1, 2, 3, 4]
    q = robot.space.sample(np.random.default_rng(1), 5)
    every = np.arange(robot.point_count())
    assert np.allclose(robot.body_points(q), _pinocchio_points(robot, q, every), rtol=0, atol=1e-10)
    assert np.allclose(robot.point_jacobians(q), _pinocchio_jacobians(robot, q, every), rtol=0, atol=1e-10)
    assert np.allclose(robot.point_jacobians(q), _finite_differences(robot, q), atol=1e-6)


def test_an_unsupported_group_joint_falls_back_to_the_pinocchio_loop(tmp_path):
    # URDF has no helical joint: swap the first revolute joint of a bound robot for pinocchio's helical one
    robot = _odd_robot(tmp_path, """
  <joint name="twist" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="bend" type="revolute"><parent link="upper"/><child link="lower"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
""", dim=2)
    assert robot._chain is not None
    helical = pin.Model()
    first = helical.addJoint(0, pin.JointModelHZ(0.05), robot.model.jointPlacements[1], "twist")
    helical.addJoint(first, pin.JointModelRY(), robot.model.jointPlacements[2], "bend")
    robot.model, robot.data = helical, helical.createData()
    robot._chain = JointChain.build(helical, robot.joint_ids, robot._used, robot.base_configuration)
    assert robot._chain is None                               # S = (0, 0, pitch, 0, 0, 1): neither kind
    q = robot.space.sample(np.random.default_rng(2), 4)
    every = np.arange(robot.point_count())
    points = robot.body_points(q)
    assert np.allclose(points, _pinocchio_points(robot, q, every), rtol=0, atol=1e-10)
    on_twist = robot.point_joint == 1
    assert np.ptp(points[:, on_twist, 2], axis=0).max() > 0.01  # the helix lifts the upper link
    assert np.allclose(robot.point_jacobians(q), _finite_differences(robot, q), atol=1e-6)


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


def test_selected_points_are_remembered_by_value_and_equal_fresh_ones(iiwa):
    from pliant_pinocchio.robot import SELECTIONS_KEPT

    q = iiwa.space.sample(np.random.default_rng(5), 4)
    every = iiwa.body_points(q)
    rng = np.random.default_rng(6)
    picks = [rng.choice(iiwa.point_count(), size, replace=False) for size in (1, 7, 40, iiwa.point_count())]
    for _ in range(2):                     # the first pass selects, the second is answered from memory
        for pick in picks:
            np.testing.assert_array_equal(iiwa.body_points(q, pick), every[:, pick])
            np.testing.assert_array_equal(iiwa.body_points(q, pick.tolist()), every[:, pick])   # same values
            np.testing.assert_array_equal(iiwa.point_jacobians(q[:1], pick), iiwa.point_jacobians(q[:1])[:, pick])
    # another array with the same values is the same selection; a changed one is not
    changed = picks[2].copy()
    changed[0] = np.setdiff1d(np.arange(iiwa.point_count()), changed)[0]
    np.testing.assert_array_equal(iiwa.body_points(q, changed), every[:, changed])
    local, _ = iiwa._select(picks[1])
    assert not local.flags.writeable                # shared between callers: nobody may write into it
    for k in range(3 * SELECTIONS_KEPT):            # bounded
        iiwa._select(np.array([k]))
    assert len(iiwa._selections) <= SELECTIONS_KEPT
    with pytest.raises(DimensionError, match="indices"):
        iiwa.body_points(q, [iiwa.point_count()])   # out of range: refused, as before, every time
    with pytest.raises(DimensionError, match="indices"):
        iiwa.body_points(q, [iiwa.point_count()])


def test_a_urdf_is_parsed_once_per_process_and_every_robot_gets_its_own_models(monkeypatch):
    """The second iiwa parses nothing and samples nothing, yet equals a robot built from scratch; placing one
    robot's base (arm-reach: 0.45 m up, 0.2 m right) moves no other."""
    from pliant_pinocchio import robot as module

    parses, samples = [], []
    parse, sample = pin.buildModelFromUrdf, module.PinocchioRobot._sample_geometries
    monkeypatch.setattr(module.pin, "buildModelFromUrdf", lambda *a: parses.append(a) or parse(*a))
    monkeypatch.setattr(module.PinocchioRobot, "_sample_geometries",
                        lambda self, *a: samples.append(a) or sample(self, *a))
    module._parsed.clear()
    module._sampled.clear()
    q = np.random.default_rng(3).uniform(-1.0, 1.0, (4, 7))
    fresh = registry.create("robot", "pinocchio", Context(scene=load_scene("iiwa-shelf")))
    points, jacobians = fresh.body_points(q), fresh.point_jacobians(q)
    placed = registry.create("robot", "pinocchio", Context(scene=load_scene("arm-reach")), model="iiwa")
    again = registry.create("robot", "pinocchio", Context(scene=load_scene("iiwa-shelf")))
    assert len(parses) == 1 and len(samples) == 1
    assert again.model is not fresh.model and again.geometry is not fresh.geometry
    np.testing.assert_array_equal(again.local_points, fresh.local_points)
    np.testing.assert_array_equal(again.body_points(q), points)
    np.testing.assert_array_equal(again.point_jacobians(q), jacobians)
    np.testing.assert_array_equal(fresh.body_points(q), points)             # unmoved by the placed one
    np.testing.assert_allclose(placed.body_points(q), points + [0.0, -0.2, 0.45], atol=1e-12)
    assert len(again.geometry.collisionPairs) == len(fresh.geometry.collisionPairs)
    np.testing.assert_array_equal(again.collisions(q), fresh.collisions(q))
    # another spacing is another sampling; the memory is bounded
    registry.create("robot", "pinocchio", Context(scene=load_scene("iiwa-shelf")), resolution=0.07)
    assert len(samples) == 2
    for k in range(module.PARSED_KEPT + 2):
        _robot("iiwa", resolution=0.05 + 0.001 * k)
    assert len(module._parsed) <= module.PARSED_KEPT and len(module._sampled) <= module.PARSED_KEPT


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


def test_collisions_are_self_collisions_deeper_than_a_quarter_voxel_and_the_checker_uses_them(iiwa, pr2, baxter):
    from pliant.planning.validity import ValidityChecker

    assert pr2.self_tolerance == pytest.approx(0.25 * pr2.context.scene.resolution)          # 0.01 m
    deep = [0.0, 1.2, 0.0, 0.0, 0.0, 0.0, 0.0]                  # the arm pitched 3.3 cm into the base
    grazing = [0.0, 1.3, 0.0, 0.0, 0.0, 0.0, 0.0]               # 2-3.5 mm: within the contact slop
    assert pr2.self_collision(np.array([deep, grazing])).tolist() == [True, True]
    assert pr2.collisions(np.array([np.zeros(7), deep, grazing])).tolist() == [False, True, False]
    into_pedestal = [1.7, 0.5, 0.0, 1.5, 0.0, 0.0, 0.0]         # mesh pairs: coal gives no depth, so it counts
    assert baxter.collisions(np.array([into_pedestal]))[0]
    # every collision is a self-collision (the tolerance only forgives)
    q = iiwa.space.sample(np.random.default_rng(0), 60)
    assert not (iiwa.collisions(q) & ~iiwa.self_collision(q)).any()
    checker = ValidityChecker(pr2.context.scene, pr2)
    assert checker._has_collisions
    assert checker.states_valid(np.array([np.zeros(7), deep])).tolist() == [True, False]


@pytest.mark.parametrize("name", ["pr2", "baxter"])
def test_broad_phase_self_contacts_equal_every_pairs_narrow_phase(name, request):
    # self_contacts narrows the pairs by coal's sweep and prune; brute force: every pair's narrow phase
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(3)
    data = pin.GeometryData(robot.geometry)
    colliding = 0
    for q in rng.uniform(robot.lower, robot.upper, (60, robot.space.dim)):
        pin.computeCollisions(robot.model, robot.model.createData(), robot.geometry, data,
                              robot.full_configurations(q[None])[0], False)
        hits = [k for k, result in enumerate(data.collisionResults) if result.isCollision()]
        depths = sorted(max(0.0, -data.collisionResults[k].getContact(0).penetration_depth) for k in hits)
        contacts = robot.self_contacts(q)
        assert len(contacts) == len(hits) and np.allclose(sorted(contacts.depth), depths)
        assert robot.self_collision(q[None])[0] == bool(hits)
        colliding += bool(hits)
    assert 5 < colliding < 55                                   # both cases were exercised


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
    from pliant.geometry.voxelgrid import VoxelGrid
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
