"""The arm-reach pipeline: one task-space reach for the iiwa, the PR2 and Baxter (scenes/arm-reach.toml,
scenes/pipelines/arm-reach.toml), the robot swapped with ``robot.model`` alone.

Baxter runs end to end (plan and execute in the kinematic simulator, the execution reaches the goal); the iiwa and
the PR2 build (their start and goal solved by inverse kinematics) and plan within a small iteration budget (their
end-to-end runs cost 5-10 s of CPU each: `pliant run arm-reach --set robot.model=NAME`, docs/scenes.md).  An
out-of-reach goal is refused at build time in one line naming the robot and the pose.  Seeded; work budgets only.
"""

from __future__ import annotations

import numpy as np
import pytest
from pliant import Pipeline
from pliant.components import PlanningProblem
from pliant.errors import SceneError
from pliant.results import Outcome, Status
from pliant.seeds import Streams


def _pipeline(tmp_path, *overrides):
    return Pipeline.from_file("arm-reach", overrides=[*overrides, f'output="{tmp_path}"'])


def test_baxter_runs_the_reach_end_to_end(tmp_path):
    record = _pipeline(tmp_path, "robot.model=baxter").run(write=False)
    assert record.outcome is Outcome.REACHED, record.error
    context = record.context
    assert context.robot.model_name == "baxter" and context.robot.group == "right_arm"
    final = record.execution.configurations[-1]
    goal_states = context.scene.task.goal_states        # the planner plans to every IK solution; any one counts
    assert len(goal_states) >= 2 and record.result.statistics["goal_states"] == goal_states.tolist()
    assert np.min(context.space.distance(goal_states, final)) <= context.scene.goal_tolerance + 0.05
    tool = context.robot.frame_position(final[None], "right_gripper")[0]
    assert np.linalg.norm(tool - [0.68, 0.0, 0.72]) < 0.1            # the tool ends near the task's goal pose
    # the simulator's joint speeds are a quarter of Baxter's own limits (scaled, not tuned per robot)
    assert np.allclose(context.simulator.options.joint_velocity_limits, 0.25 * context.robot.velocity_limits)


@pytest.mark.parametrize(("model", "tool"), [("iiwa", "lbr_iiwa_link_7"), ("pr2", "r_gripper_tool_frame")])
def test_the_iiwa_and_the_pr2_build_and_plan_the_same_task(tmp_path, model, tool):
    pipeline = _pipeline(tmp_path, f"robot.model={model}", "planning.max_iterations=10", "execution.time_limit=0.04")
    context = pipeline.build()
    scene, robot = context.scene, context.robot
    assert robot.model_name == model and scene.start.shape == scene.goal.shape == (7,)
    assert np.linalg.norm(robot.frame_position(scene.goal[None], tool)[0] - [0.68, 0.0, 0.72]) <= 0.01 + 1e-9
    if model == "pr2":                                  # a named posture
        assert np.array_equal(scene.start, robot.postures["tuck"])
    else:                                               # the task's start pose, solved
        assert np.linalg.norm(robot.frame_position(scene.start[None], tool)[0] - [0.64, -0.44, 0.76]) <= 0.01 + 1e-9
    assert np.allclose(context.simulator.options.joint_velocity_limits, 0.25 * robot.velocity_limits)
    problem = PlanningProblem.from_context(context, budget=pipeline.budget)
    problem.goal_states = scene.task.goal_states        # as the pipeline's run does
    result = context.extras["planner"].plan(problem, Streams(pipeline.seed).rng("planning"))    # the run's stream
    assert result.status is Status.SOLVED, result.message
    last = result.path.configurations[-1]
    assert np.min(context.space.distance(scene.task.goal_states, last)) <= scene.goal_tolerance + 1e-9


def test_an_out_of_reach_goal_is_refused_at_build_naming_robot_and_pose(tmp_path):
    with pytest.raises(SceneError) as info:
        _pipeline(tmp_path, "robot.model=iiwa", "scene.variant=far").build()
    text = str(info.value)
    assert "\n" not in text and info.value.field == "task.goal"
    assert "robot 'iiwa' (group 'arm', tool 'lbr_iiwa_link_7') cannot reach the goal pose position [1.5, -0.2, 0.8]" \
        in text


def test_a_separate_execution_world_starts_where_the_plan_starts(tmp_path):
    pipeline = _pipeline(tmp_path, "robot.model=baxter", "execution.world=kinematic")
    context = pipeline.build()
    world = pipeline.execution_world(context)
    assert world is not context.simulator and world.context.robot is not context.robot
    assert np.array_equal(world.context.scene.start, context.scene.start)
    assert np.array_equal(world.context.scene.goal, context.scene.goal)
    assert world.context.scene.task.robot == "baxter"
