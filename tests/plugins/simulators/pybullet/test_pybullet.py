"""The pybullet backend: rest on a box, compliant contact with bounded force, agreement, swapping."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.errors import SimulationError
from pliant.interfaces import Context
from pliant.testing import check_component


def pose(x, y, z):
    return np.array([x, y, z, 0.0, 0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def peg():
    ctx = Context(scene=load_scene("se3-peg-in-hole"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


def test_a_body_dropped_on_a_box_comes_to_rest_on_it(peg):
    sim = registry.create("simulator", "pybullet", peg, gravity=9.81, max_force=0.0)
    sim.reset(pose(7, 7, 4.5))
    rng = np.random.default_rng(0)
    for _ in range(40):
        q = sim.step(np.zeros(6), 0.1, rng)
    assert q[2] == pytest.approx(3.5, abs=0.02) and sim.in_contact()
    assert np.allclose(q[:2], [7, 7], atol=0.01)


def test_commanded_into_the_block_it_stops_with_bounded_force(peg):
    sim = registry.create("simulator", "pybullet", peg, max_force=100.0)
    sim.reset(pose(7, 7, 3.6))
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = sim.step(np.array([0, 0, -1.0, 0, 0, 0]), 0.1, rng)
        assert sim.body.pulling_force() <= 100.0 * 1.01
    assert sim.in_contact() and q[2] == pytest.approx(3.5, abs=0.02)


def test_free_motion_and_the_hole_agree_with_the_kinematic_simulator(peg):
    pb = registry.create("simulator", "pybullet", peg, kp=1.0, angular_velocity_limit=0.25)
    kin = registry.create("simulator", "kinematic", peg, kp=1.0, angular_velocity_limit=0.25)
    for start, target, duration in ((pose(8, 8, 8), pose(7, 7.5, 6), 6.0), (pose(5, 5, 3.6), pose(5, 5, 0.625), 6.0)):
        a = pb.simulate(start[None], target, np.random.default_rng(0), duration)
        b = kin.simulate(start[None], target, np.random.default_rng(0), duration)
        assert a.reached[0] and b.reached[0]
        assert np.allclose(a.final[0, :3], b.final[0, :3], atol=0.02)


def test_same_seed_same_trajectory(peg):
    sim = registry.create("simulator", "pybullet", peg, noise="bounded", noise_linear=0.125, noise_angular=0.03)
    starts = np.repeat(pose(6, 6, 3.6)[None], 2, axis=0)
    a = sim.simulate(starts, pose(5, 5, 2), np.random.default_rng(3), 1.0)
    b = sim.simulate(starts, pose(5, 5, 2), np.random.default_rng(3), 1.0)
    assert np.array_equal(a.final, b.final)


@pytest.fixture(scope="module")
def iiwa():
    ctx = Context(scene=load_scene("iiwa-shelf"))
    ctx.robot = registry.create("robot", "pinocchio", ctx)
    return ctx


IIWA_START = np.array([0.0, 0.3, 0.0, -1.2, 0.0, 0.6, 0.0])


def test_an_arm_commanded_into_the_board_stops_at_contact_with_bounded_torques(iiwa):
    sim = registry.create("simulator", "pybullet", iiwa, effort_scale=0.5)
    caps = 0.5 * iiwa.robot.urdf_description().effort_limits
    sim.reset(IIWA_START)
    rng = np.random.default_rng(0)
    touched = False
    for _ in range(30):
        q = sim.step(np.array([0.0, 1.0, 0.0, 0.5, 0.0, 0.0, 0.0]), 0.1, rng)
        assert np.all(sim.body.joint_efforts() <= caps * (1 + 1e-6))
        touched |= sim.in_contact()
    assert touched and q[1] < 1.7                 # free, shoulder joint 2 would have reached 0.3 + 3.0 * 1.0 / ...
    assert iiwa.robot.environment_distance(q[None])[0] > -iiwa.scene.resolution


def test_arm_free_motion_agrees_with_the_kinematic_simulator(iiwa):
    target = np.array([0.0, 1.2, 0.0, 0.3, 0.0, 1.2, 0.0])
    a, b = (registry.create("simulator", name, iiwa).simulate(IIWA_START[None], target, np.random.default_rng(0), 4.0)
            for name in ("pybullet", "kinematic"))
    assert a.reached[0] and b.reached[0] and not a.in_contact[0]
    assert np.allclose(a.final, b.final, atol=0.02)


def test_arm_noise_same_seed_same_trajectory(iiwa):
    sim = registry.create("simulator", "pybullet", iiwa, noise="proportional", noise_linear=0.1)
    a = sim.simulate(IIWA_START[None], np.zeros(7), np.random.default_rng(5), 1.0, record=True)
    b = sim.simulate(IIWA_START[None], np.zeros(7), np.random.default_rng(5), 1.0, record=True)
    c = sim.simulate(IIWA_START[None], np.zeros(7), np.random.default_rng(6), 1.0, record=True)
    assert np.array_equal(a.trajectories, b.trajectories) and not np.array_equal(a.trajectories, c.trajectories)


PR2_ARM = [0.0, 0.0, 0.0, -0.5, 0.0, -0.5, 0.0]
BAXTER_ARM = [0.119, 1.047, -0.275, -0.05, -1.293, -1.218, -0.292]       # baxter-reach's start


@pytest.mark.parametrize(("model", "group", "start"),
                         [("baxter", "right_arm", BAXTER_ARM), ("pr2", "left_arm", PR2_ARM)])
def test_named_robots_load_with_their_posture(model, group, start):
    scene = load_scene("iiwa-shelf").__class__.from_dict({
        "name": f"{model}-free", "start": start, "goal": start,
        "bounds": {"lower": [-2.0, -2.0, -1.0], "upper": [2.0, 2.0, 2.0], "resolution": 0.1},
        "robot": {"kind": "urdf", "model": model, "group": group}})
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "pinocchio", ctx)
    sim = registry.create("simulator", "pybullet", ctx)
    q = ctx.robot.space.lower + 0.25 * (ctx.robot.space.upper - ctx.robot.space.lower)
    sim.reset(q)
    assert np.allclose(sim.configuration(), q, atol=1e-9)
    held = sim.body.held
    assert len(held) == len(ctx.robot.urdf_description().posture) > 0
    # the same configuration puts the arm's last link at the same place in pinocchio and in pybullet
    link = sim.pb.getJointInfo(sim.body.body, sim.body.joints[-1])[12].decode()
    state = sim.pb.getLinkState(sim.body.body, sim.body.joints[-1], computeForwardKinematics=True)
    assert np.allclose(state[4], ctx.robot.frame_position(q[None], link)[0], atol=1e-6)


def test_a_collision_mesh_pybullet_cannot_read_is_refused(tmp_path):
    import pybullet
    from pliant.interfaces import UrdfDescription
    from pliant_pybullet.articulated import ArticulatedRobot

    (tmp_path / "broken.stl").write_text("not a mesh")
    (tmp_path / "arm.urdf").write_text(
        '<robot name="arm"><link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>'
        '</link><link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" '
        'ixz="0" iyz="0"/></inertial><collision><geometry><mesh filename="broken.stl"/></geometry></collision>'
        '</link><joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint></robot>')
    description = UrdfDescription(tmp_path / "arm.urdf", (tmp_path,), ("j1",), {}, np.ones(1), np.full(1, 10.0))
    from pybullet_utils.bullet_client import BulletClient

    pb = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        with pytest.raises(SimulationError, match=r"link 'l1': broken\.stl"):
            ArticulatedRobot(pb, description, [-1.0], [1.0], effort_scale=1.0, position_gain=0.3, velocity_gain=1.0,
                             friction=0.5, self_collision=False, source="test")
        missing = UrdfDescription(tmp_path / "nowhere.urdf", (tmp_path,), ("j1",), {}, np.ones(1), np.ones(1))
        with pytest.raises(SimulationError, match="cannot load the URDF"):
            ArticulatedRobot(pb, missing, [-1.0], [1.0], effort_scale=1.0, position_gain=0.3, velocity_gain=1.0,
                             friction=0.5, self_collision=False, source="test")
    finally:
        pb.disconnect()


def test_a_robot_model_without_a_urdf_description_is_refused(iiwa, monkeypatch):
    monkeypatch.setattr(type(iiwa.robot), "urdf_description", lambda self: None)
    with pytest.raises(SimulationError, match="no URDF description"):
        registry.create("simulator", "pybullet", iiwa)


@pytest.mark.parametrize("scene", ["se3-peg-in-hole", "se2-maze", "iiwa-shelf"])
def test_conformance(scene):
    assert check_component("simulator", "pybullet", scene=scene)


def _push(variant, steps=30):
    scene = load_scene("se2-push", variant=variant)
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "rigid", ctx)
    sim = registry.create("simulator", "pybullet", ctx, max_force=20.0)      # the scene's table friction holds it
    sim.reset(np.array(scene.start))
    rng = np.random.default_rng(0)
    for _ in range(steps):
        q = sim.step(np.array([0.2, 0.0, 0.0]), 0.1, rng)
    return sim, q


def test_a_pushed_movable_object_moves_along_the_push_and_reset_restores_it():
    sim, q = _push(None)
    crate = sim.object_poses()["crate"]
    assert crate[0] > 0.6 + 0.2 and abs(crate[1] - 0.5) < 0.05          # pushed in +x, barely sideways
    assert crate[0] - 0.08 >= q[0] + 0.02 - 0.01                            # the paddle stays behind the crate
    _, heavy_q = _push("heavy")
    assert heavy_q[0] < q[0]                                                # a 10 kg crate holds the paddle back
    sim.reset(np.array([0.3, 0.5, 0.0]))
    assert np.allclose(sim.object_poses()["crate"], [0.6, 0.5, 0.0])           # planar: (x, y, theta)


def test_a_movable_object_pybullet_cannot_represent_is_refused():
    scene = load_scene("se2-push")
    data_objects = [{"name": "ring", "shape": "box", "size": [0.1, 0.1, 0.02], "position": [0.6, 0.8, 0.0],
                     "mass": 1.0, "deformability": 0.0, "sensitivity": 1.0,
                     "cutouts": [{"shape": "box", "size": [0.04, 0.04, 0.04]}]}]
    bad = scene.__class__.from_dict({
        "name": "bad", "planar": True, "start": [0.3, 0.5, 0.0], "goal": [0.8, 0.5, 0.0],
        "bounds": {"lower": [0.0, 0.0, -0.01], "upper": [1.6, 1.0, 0.01], "resolution": 0.02},
        "objects": data_objects,
        "robot": {"kind": "rigid", "space": "se2", "parts": [{"shape": "box", "size": [0.04, 0.16, 0.02]}]}})
    ctx = Context(scene=bad)
    ctx.robot = registry.create("robot", "rigid", ctx)
    with pytest.raises(SimulationError, match="cut-outs") as error:
        registry.create("simulator", "pybullet", ctx)
    assert "objects[0].cutouts" in str(error.value)


def test_contact_points_lie_on_the_block_with_upward_normals_and_bounded_forces(peg):
    sim = registry.create("simulator", "pybullet", peg, max_force=100.0)
    sim.reset(pose(7, 7, 3.6))
    rng = np.random.default_rng(0)
    for _ in range(10):
        sim.step(np.array([0, 0, -1.0, 0, 0, 0]), 0.1, rng)
    contacts = sim.contact_points()
    assert contacts.shape[1] == 7 and len(contacts) >= 3                 # the peg's square foot on the block top
    assert np.allclose(contacts[:, 2], 3.0, atol=0.02)                   # on the block's top face (z = 3)
    assert np.allclose(contacts[:, 3:6], [0, 0, 1], atol=1e-3)           # pushing the peg up
    assert np.all(contacts[:, 6] >= 0) and contacts[:, 6].sum() <= 100.0 * 1.05
    sim.reset(pose(8, 8, 8))
    sim.step(np.zeros(6), 0.1, rng)
    assert sim.contact_points().shape == (0, 7)


def _tilt(q):
    return 2 * np.arccos(np.clip(abs(q[6]), 0.0, 1.0))


def test_a_separate_torque_cap_turns_the_body_to_the_commanded_orientation_in_free_space(peg):
    sim = registry.create("simulator", "pybullet", peg, kp=1.0, angular_velocity_limit=0.25, max_torque=5.0)
    start = pose(8, 8, 8)
    target = np.array([7.5, 8.0, 7.5, np.sin(0.15), 0.0, 0.0, np.cos(0.15)])     # 0.3 rad about x
    result = sim.simulate(start[None], target, np.random.default_rng(0), 6.0)
    assert result.reached[0]
    assert _tilt(result.final[0]) == pytest.approx(0.3, abs=0.01)
    assert np.allclose(result.final[0, :3], target[:3], atol=0.02)


def test_a_zero_torque_cap_leaves_the_orientation_alone(peg):
    sim = registry.create("simulator", "pybullet", peg, kp=1.0, max_torque=0.0)
    sim.reset(pose(8, 8, 8))
    rng = np.random.default_rng(0)
    for _ in range(10):
        q = sim.step(np.array([0.0, 0.0, -0.5, 0.25, 0.0, 0.0]), 0.1, rng)       # translate down, ask to turn
    assert q[2] == pytest.approx(7.5, abs=0.1)                                  # the pull lags a little
    assert _tilt(q) < 1e-6


def test_the_torque_cap_bounds_how_fast_a_turn_accelerates(peg):
    """A torque capped at T turns a body of inertia I about x by at most T t^2 / (2 I) in t seconds (from rest)."""
    cap = 1e-3
    sim = registry.create("simulator", "pybullet", peg, kp=1.0, angular_velocity_limit=1.0, max_torque=cap)
    sim.reset(pose(8, 8, 8))
    inertia = sim.pb.getDynamicsInfo(sim.body.body, -1)[2][0]
    q = sim.step(np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0]), 0.1, np.random.default_rng(0))
    assert 0 < _tilt(q) <= cap * 0.1 ** 2 / (2 * inertia) * 1.05
