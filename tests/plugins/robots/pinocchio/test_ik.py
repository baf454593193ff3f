"""Inverse kinematics of a URDF arm (pliant_pinocchio.ik): reachable poses solved within tolerances and limits."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from pliant import load_scene, registry
from pliant.errors import ConfigError
from pliant.interfaces import Context
from pliant_pinocchio.ik import solve_ik

FRAME = "lbr_iiwa_link_7"


@pytest.fixture(scope="module")
def iiwa():
    return registry.create("robot", "pinocchio", Context(scene=load_scene("iiwa-shelf")))


def anything(q):
    return np.ones(len(q), dtype=bool)


def test_reachable_poses_are_solved_within_tolerance_and_limits(iiwa):
    rng = np.random.default_rng(3)
    for _ in range(4):
        q = iiwa.space.sample(rng, 1)[0]
        placement = iiwa.frame_placements(q, FRAME)[0]
        quat = pin.Quaternion(placement[:3, :3])
        result = solve_ik(iiwa, FRAME, placement[:3, 3], [quat.x, quat.y, quat.z, quat.w], rng=rng, solutions=2,
                          valid=anything, diversity=0.2)
        assert len(result.solutions) >= 1
        for s in result.solutions:
            reached = iiwa.frame_placements(s, FRAME)[0]
            assert np.linalg.norm(reached[:3, 3] - placement[:3, 3]) <= 1e-3
            assert np.linalg.norm(pin.log3(placement[:3, :3] @ reached[:3, :3].T)) <= 1e-2
            assert np.all(s >= iiwa.space.lower) and np.all(s <= iiwa.space.upper)
        if len(result.solutions) == 2:                     # diverse: apart in joint space
            assert float(iiwa.space.distance(result.solutions[0], result.solutions[1])) >= 0.2


def test_position_only_several_solutions_and_the_validity_check(iiwa):
    rng = np.random.default_rng(0)
    target = iiwa.frame_placements(iiwa.space.sample(rng, 1)[0], FRAME)[0][:3, 3]
    result = solve_ik(iiwa, FRAME, target, rng=rng, solutions=3, valid=anything)
    assert len(result.solutions) == 3 and np.all(result.orientation_errors == 0.0)
    assert np.allclose(iiwa.frame_position(result.solutions, FRAME), target, atol=1e-3)
    refused = solve_ik(iiwa, FRAME, target, rng=np.random.default_rng(0), solutions=3, attempts=5,
                       valid=lambda q: np.zeros(len(q), dtype=bool))
    assert len(refused.solutions) == 0 and refused.converged > 0
    far = solve_ik(iiwa, FRAME, [5.0, 0.0, 0.0], rng=rng, attempts=2, iterations=30, valid=anything)
    assert len(far.solutions) == 0 and far.attempts == 2


def test_bad_targets_name_the_field(iiwa):
    with pytest.raises(ConfigError) as err:
        solve_ik(iiwa, FRAME, [0.0, 0.0], rng=np.random.default_rng(0))
    assert err.value.field == "position"
    with pytest.raises(ConfigError) as err:
        solve_ik(iiwa, FRAME, [0.0, 0.0, 0.5], [0, 0, 0, 0], rng=np.random.default_rng(0))
    assert err.value.field == "orientation"


def test_a_pipeline_goal_pose_becomes_a_goal_configuration():
    from pliant.errors import PipelineError
    from pliant.pipeline import Pipeline

    pose = '{frame = "lbr_iiwa_link_7", position = [0.5, 0.2, 0.6], solutions = 2}'
    pipeline = Pipeline.from_dict({"scene": "iiwa-shelf", "planner": {"name": "straight", "step": 0.05}},
                                  overrides=[f"goal.pose={pose}"])
    record = pipeline.run(write=False)
    robot, goal = record.context.robot, record.problem.goal
    assert np.allclose(robot.frame_position(goal, FRAME)[0], [0.5, 0.2, 0.6], atol=1e-3)
    assert len(record.goal_states) == 2 and any(np.array_equal(goal, g) for g in record.goal_states)
    assert record.problem.checker.states_valid(record.goal_states).all()        # collision-free goal states
    assert record.result.statistics["goal_states"] == record.goal_states.tolist()
    assert record.problem.goal_states is record.goal_states          # any of them reaches the goal
    with pytest.raises(PipelineError) as err:
        Pipeline.from_dict({"scene": "iiwa-shelf", "planner": "straight"},
                           overrides=['goal.pose={frame = "lbr_iiwa_link_7", position = [0.5, 0.2]}'])
    assert err.value.field == "goal.pose.position"
