"""The robot pipelines ``pr2-policy`` and ``iiwa-policy``: belief policies planned with the kinematic simulator and
executed in pybullet, as ``baxter-policy`` (scenes/pipelines/*.toml explain every number).

Fast tests check what the files promise: seven planned joints, start and goal inside the joint limits (the PR2's
soft limits too) and collision-free for the robot model (coal), the kinematic simulator's voxels and its contact
check; the straight motion between them is not (the arm must go around or through something); the execution world
has the planning model's limits and noise, and one setting swaps it for the robot's driver.  The slow tests run each
pipeline end to end from seed 0 (planning stops at its first solution within the pipeline's work budget, so the
run is the same under any load) and require the pybullet execution to reach the goal.
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from pliant import Pipeline, registry
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.hardware.limits import load_limits

PR2_ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "upper_arm_roll_joint", "elbow_flex_joint",
           "forearm_roll_joint", "wrist_flex_joint", "wrist_roll_joint")
#: pipeline -> (scene, planned joints, the driver that executes it on the robot)
PIPELINES = {
    "pr2-policy": ("pr2-reach", tuple(f"r_{j}" for j in PR2_ARM), "pr2-ros"),
    "iiwa-policy": ("iiwa-shelf-reach", tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8)), "iiwa-ros"),
}
NAMES = sorted(PIPELINES)


@functools.cache
def _built(name: str):
    pipeline = Pipeline.from_file(name)
    return pipeline, pipeline.build()


def _endpoints(context) -> np.ndarray:
    return np.array([context.scene.start, context.scene.goal], dtype=np.float64)


@pytest.mark.parametrize("name", NAMES)
def test_the_pipeline_builds_with_seven_planned_joints(name):
    pipeline, context = _built(name)
    scene, joints, _ = PIPELINES[name]
    assert context.scene.name == scene
    assert tuple(context.robot.joint_names) == joints and context.space.dim == 7
    assert _endpoints(context).shape == (2, 7) and context.scene.goal_tolerance > 0
    assert type(context.simulator).__name__ == "KinematicSimulator"
    assert pipeline.components["planner"].name == "belief" and pipeline.components["controller"].name == "contact"
    assert pipeline.components["controller"].options["mode"] == "track"


@pytest.mark.parametrize("name", NAMES)
def test_execution_is_in_pybullet_with_the_planning_model_s_limits_and_noise(name):
    pipeline, context = _built(name)
    world, planning = pipeline.world_spec(), pipeline.components["simulator"].options
    assert world.name == "pybullet"
    for key in ("frequency", "joint_velocity_limits", "noise", "noise_linear"):
        assert world.options[key] == planning[key], key
    assert pipeline.execution["period"] == pytest.approx(1.0 / planning["frequency"])
    # a quarter of the published speeds (the PR2's URDF; the iiwa's data sheet, which the robot model uses)
    limits = np.array(planning["joint_velocity_limits"])
    assert limits == pytest.approx(0.25 * np.asarray(context.robot.velocity_limits), rel=1e-3)


@pytest.mark.parametrize("name", NAMES)
def test_start_and_goal_are_inside_the_joint_limits(name):
    _, context = _built(name)
    robot, q = context.robot, _endpoints(context)
    assert np.all(q >= robot.lower) and np.all(q <= robot.upper)
    assert np.all(q >= context.space.lower) and np.all(q <= context.space.upper)


def test_the_pr2_start_and_goal_are_inside_the_soft_limits():
    """The URDF's safety-controller limits (those of the pr2-ros driver); continuous joints within +-pi."""
    _, context = _built("pr2-policy")
    robot, q = context.robot, _endpoints(context)
    joints = {j.get("name"): j for j in ET.parse(robot.urdf_description().urdf).getroot().findall("joint")}
    for k, name in enumerate(robot.joint_names):
        joint = joints[name]
        if joint.get("type") == "continuous":
            assert np.all(np.abs(q[:, k]) <= math.pi), name
            continue
        soft = joint.find("safety_controller")
        lower, upper = float(soft.get("soft_lower_limit")), float(soft.get("soft_upper_limit"))
        assert np.all(q[:, k] >= lower) and np.all(q[:, k] <= upper), (name, q[:, k], lower, upper)


@pytest.mark.parametrize("name", NAMES)
def test_start_and_goal_are_collision_free(name):
    _, context = _built(name)
    robot, q = context.robot, _endpoints(context)
    # the robot model (coal, every link): the scenes are boxes and cylinders without cut-outs, so this is exact
    assert not robot.in_collision(q).any()
    assert np.all(robot.environment_distance(q) > 0.03)
    # the planning model: no body point in an occupied voxel, and holding still is free of contact
    grid = VoxelGrid.from_scene(context.scene)
    flat = grid.flat_index(robot.body_points(q))
    assert np.all(flat >= 0) and not grid.occupied.reshape(-1)[flat].any()
    for configuration in q:
        held = context.simulator.simulate(configuration[None], configuration, np.random.default_rng(0), 0.4)
        assert not held.in_contact[0] and context.space.distance(held.final[0], configuration) < 1e-6


@pytest.mark.parametrize("name", NAMES)
def test_the_straight_motion_from_start_to_goal_collides(name):
    """Not trivial: the arm must go around or through an obstacle."""
    _, context = _built(name)
    start, goal = _endpoints(context)
    segment = start + np.linspace(0.0, 1.0, 61)[:, None] * (goal - start)
    assert context.robot.environment_distance(segment).min() < -0.02


@pytest.mark.parametrize("name", NAMES)
def test_one_setting_executes_on_the_robot_s_driver(name):
    """``execution.world=<driver>`` swaps pybullet for the robot (the driver is created, not connected)."""
    driver = PIPELINES[name][2]
    if driver not in registry.available("driver"):
        pytest.skip(f"the {driver} driver is not available here")
    pipeline = Pipeline.from_file(name, overrides=[f"execution.world={driver}"])
    context = pipeline.build()
    world = pipeline.execution_world(context)
    assert pipeline.world_spec().name == driver
    assert tuple(world.joint_names()) == tuple(context.robot.joint_names)


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_the_pipeline_plans_and_its_policy_reaches_the_goal_in_pybullet(name):
    # the pipeline's work budget ([planning] max_iterations; its max_time is only a generous cap) and the first
    # solution: the same plan on any machine under any load (a 30 s budget once planned 2 iterations on CI: timeout)
    record = Pipeline.from_file(name, overrides=["seed=0", "planning.stop_on_first=true"]).run(write=False)
    assert record.result.statistics["budget"].get("binding") != "time", record.result.statistics["budget"]
    assert record.result.solved, record.result.statistics
    execution = record.execution
    assert execution.world == "pybullet"
    assert execution.success, (execution.outcome, execution.events[-3:])
    space, scene = record.context.space, record.context.scene
    assert space.distance(execution.configurations[-1], np.array(scene.goal)) <= scene.goal_tolerance
    # what the robot's driver would have accepted: every executed configuration inside its limits file's positions
    # less its margin (the PR2's are the URDF's soft limits, tighter than the hard limits the planner samples in)
    driver = PIPELINES[name][2]
    if driver in registry.available("driver"):
        robot = registry.create("driver", driver)
        limits = load_limits(robot.default_limits_file()).select(robot.joint_names())
        q = execution.configurations
        assert np.all(q >= limits.command_lower) and np.all(q <= limits.command_upper)
