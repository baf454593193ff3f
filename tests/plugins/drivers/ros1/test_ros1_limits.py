"""The ROS drivers' robots without ROS: joint names read from the URDFs (and equal to the pinocchio robot model's
groups, so a pipeline's robot binds to the driver), and the limits files against their sources."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.hardware.limits import load_limits
from pliant.interfaces import Context
from pliant_ros1 import robots
from pliant_ros1.robots import ROBOTS, SIDES, arm_joints, joint_limits_from_urdf, limits_file, urdf_path

ARMS = [("pr2", "right"), ("pr2", "left"), ("baxter", "right"), ("baxter", "left"), ("iiwa", "right")]


def test_arm_joints_are_read_from_the_urdfs_root_to_tip():
    assert arm_joints("pr2", "right") == ("r_shoulder_pan_joint", "r_shoulder_lift_joint", "r_upper_arm_roll_joint",
                                          "r_elbow_flex_joint", "r_forearm_roll_joint", "r_wrist_flex_joint",
                                          "r_wrist_roll_joint")
    assert arm_joints("pr2", "left")[0] == "l_shoulder_pan_joint"
    assert arm_joints("baxter", "left") == tuple(f"left_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2"))
    assert arm_joints("iiwa") == tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8))
    # the PR2's state message names far more joints than one arm: both arms, torso, head, grippers
    assert set(arm_joints("pr2", "right")) | set(arm_joints("pr2", "left")) < set(robots.state_joints("pr2"))
    assert len(robots.state_joints("pr2")) >= 30
    assert set(arm_joints("baxter", "right")) | set(arm_joints("baxter", "left")) | {"head_pan"} <= \
        set(robots.BAXTER_STATE_JOINTS)
    with pytest.raises(Exception, match="side"):
        arm_joints("baxter", "middle")


@pytest.mark.parametrize(("robot", "side"), ARMS)
def test_the_driver_joints_equal_the_pinocchio_model_group(robot, side):
    spec = robots.ros_robot(robot, side)
    scene = load_scene(spec.scene)
    robot_model = registry.create("robot", "pinocchio", Context(scene), group=spec.group)
    assert tuple(robot_model.urdf_description().joint_names) == spec.joints


@pytest.mark.parametrize(("robot", "side"), ARMS)
def test_every_limits_file_loads_cites_its_sources_and_covers_the_arm(robot, side):
    limits = load_limits(limits_file(robot, side))
    assert limits.names == arm_joints(robot, side)
    assert limits.command_rate == 100.0
    assert limits.state_timeout == pytest.approx(0.1)
    assert limits.command_timeout == (0.2 if robot == "baxter" else None)
    assert limits.max_state_rate >= 5 * robots.ros_robot(robot, side).state_rate
    assert len(limits.sources) >= 3 and all(len(s) > 40 for s in limits.sources)
    assert np.all(limits.velocity > 0) and np.all(limits.acceleration > 0) and np.all(limits.jerk > 0)
    # full speed takes at least 0.1 s and full acceleration at least 10 ms: no absurd numbers
    assert np.all(limits.velocity / limits.acceleration >= 0.1) and np.all(limits.acceleration / limits.jerk >= 0.01)


@pytest.mark.parametrize("side", SIDES)
def test_pr2_limits_are_the_urdf_soft_limits_inside_the_hard_ones(side):
    limits = load_limits(limits_file("pr2", side))
    path = urdf_path("pr2")
    for i, name in enumerate(limits.names):
        urdf = joint_limits_from_urdf(path, name)
        assert limits.velocity[i] == pytest.approx(urdf["velocity"])
        if urdf["type"] == "continuous":            # a wide finite range instead of none
            assert (limits.lower[i], limits.upper[i]) == pytest.approx((-2 * math.pi, 2 * math.pi))
            continue
        assert (limits.lower[i], limits.upper[i]) == pytest.approx((urdf["soft_lower"], urdf["soft_upper"]))
        assert urdf["lower"] < limits.lower[i] < limits.upper[i] < urdf["upper"]
    assert "soft" in " ".join(limits.sources) and "moveit_pr2" in " ".join(limits.sources)


@pytest.mark.parametrize("side", SIDES)
def test_baxter_limits_are_the_urdf_limits(side):
    limits = load_limits(limits_file("baxter", side))
    path = urdf_path("baxter")
    for i, name in enumerate(limits.names):
        urdf = joint_limits_from_urdf(path, name)
        assert (limits.lower[i], limits.upper[i], limits.velocity[i]) == \
            pytest.approx((urdf["lower"], urdf["upper"], urdf["velocity"]))
    # the two arms are mirror images with the same ranges
    other = load_limits(limits_file("baxter", "left" if side == "right" else "right"))
    np.testing.assert_allclose(limits.lower, other.lower)
    np.testing.assert_allclose(limits.jerk, other.jerk)


def test_iiwa_limits_are_the_data_sheet_values_and_the_urdf_ranges():
    limits = load_limits(limits_file("iiwa"))
    np.testing.assert_allclose(np.degrees(limits.upper), [170, 120, 170, 120, 170, 120, 175])
    np.testing.assert_allclose(np.degrees(limits.lower), [-170, -120, -170, -120, -170, -120, -175])
    np.testing.assert_allclose(np.degrees(limits.velocity), [98, 98, 100, 130, 140, 180, 180])
    path = urdf_path("iiwa")
    for i, name in enumerate(limits.names):
        urdf = joint_limits_from_urdf(path, name)
        assert (limits.lower[i], limits.upper[i]) == pytest.approx((urdf["lower"], urdf["upper"]), abs=1e-8)
    assert any("data sheet" in s or "Specifications" in s for s in limits.sources)


def test_every_robot_has_a_limits_file_per_arm():
    for robot in ROBOTS:
        for side in SIDES if robot != "iiwa" else ("right",):
            assert limits_file(robot, side).is_file()
