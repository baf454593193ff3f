"""The contact motion controller (thesis app. C) and execution through a simulator."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import Pipeline, load_scene, registry
from pliant.errors import PlanningError
from pliant.execution.loop import execute
from pliant.interfaces import Context
from pliant.results import Path


@pytest.fixture(scope="module")
def peg():
    ctx = Context(scene=load_scene("se3-peg-in-hole"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.simulator = registry.create("simulator", "kinematic", ctx, kp=1.0, angular_velocity_limit=0.25)
    return ctx


def pose(x, y, z):
    return np.array([x, y, z, 0.0, 0.0, 0.0, 1.0])


def test_stuck_detection_and_eq_8_6_adjustment(scene_context):
    ctx = scene_context("se2-maze")
    ctrl = registry.create("controller", "contact", ctx, window=2, stuck_distance=0.01, eps_adjust=0.1)
    target = np.array([5.0, 5.0, 0.0])
    # sliding along the wall y = 2 (theta = 0), slowing down until stuck at x = 4.0
    for x in (3.0, 3.5, 3.9):
        ctrl.command(np.array([x, 2.0, 0.0]), target, 0.1)
    assert not ctrl.is_stuck()
    for x in (3.997, 3.999, 4.0):
        ctrl.command(np.array([x, 2.0, 0.0]), target, 0.1)
    assert ctrl.is_stuck() and ctrl.stuck_iterations == 1
    adjusted = ctrl.adjusted_target
    # eq. 8.6: the target moves toward the line y = 2 by i * eps_adjust = 0.1 of the way, x unchanged
    assert adjusted[1] == pytest.approx(5.0 - 0.1 * 3.0) and adjusted[0] == pytest.approx(5.0)


def test_gives_up_after_eps_adjust_max(scene_context):
    ctx = scene_context("se2-maze")
    ctrl = registry.create("controller", "contact", ctx, window=2, eps_adjust=0.25, eps_adjust_max=1.0)
    q = np.array([4.0, 2.0, 0.0])
    for _ in range(10):
        ctrl.command(q, np.array([5.0, 5.0, 0.0]), 0.1)
    assert ctrl.gave_up
    ctrl.reset()
    assert not ctrl.gave_up and ctrl.stuck_iterations == 0


def test_moving_without_progress_keeps_counting_toward_giving_up(scene_context):
    # pressed against the wall y = 2 below a target straight behind it: each adjustment lets the robot slide
    # sideways and back (it moves, so the window is not stuck) without coming closer to the target
    ctx = scene_context("se2-maze")
    ctrl = registry.create("controller", "contact", ctx, window=2, stuck_distance=0.01, eps_adjust=0.1)
    target = np.array([4.0, 5.0, 0.0])
    wall = np.array([4.0, 2.0, 0.0])
    for _ in range(3):
        ctrl.command(wall, target, 0.1)
    assert ctrl.stuck_iterations == 1
    for _ in range(6):
        for dx in (0.0, 0.0, 0.0, 0.3, 0.0):         # stuck, then an excursion along the wall and back
            ctrl.command(wall + [dx, 0.0, 0.0], target, 0.1)
    assert ctrl.gave_up
    # coming closer to the target than ever before resets the count
    ctrl = registry.create("controller", "contact", ctx, window=2, stuck_distance=0.01, eps_adjust=0.1)
    for _ in range(3):
        ctrl.command(wall, target, 0.1)
    assert ctrl.stuck_iterations == 1
    ctrl.command(np.array([4.0, 2.5, 0.0]), target, 0.1)
    assert ctrl.stuck_iterations == 0 and not ctrl.gave_up


def test_execution_slides_the_peg_into_the_hole(peg):
    ctrl = registry.create("controller", "contact", peg, gain=2.0)
    path = Path(np.array([pose(7, 7, 5), pose(5.6, 5.6, 3.5), pose(5, 5, 3.3), pose(5, 5, 0.625)]))
    record = execute(peg.simulator, ctrl, path, np.random.default_rng(0), period=0.1, time_limit=60)
    assert record.success and record.details.waypoints_reached == 3
    assert record.contacts.any()
    assert record.configurations[-1, 2] == pytest.approx(0.625, abs=0.06)


def test_execution_into_the_block_gets_stuck(peg):
    ctrl = registry.create("controller", "contact", peg, gain=2.0, eps_adjust=0.1)
    path = Path(np.array([pose(7, 7, 4), pose(7, 7, 1)]))
    record = execute(peg.simulator, ctrl, path, np.random.default_rng(0), period=0.1, time_limit=60)
    assert record.outcome == "stuck" and record.details.waypoints_reached == 0 and record.events


def test_execution_time_limit(peg):
    ctrl = registry.create("controller", "contact", peg, gain=0.1)
    record = execute(peg.simulator, ctrl, Path(np.array([pose(8, 8, 8), pose(2, 2, 8)])), np.random.default_rng(0),
                     period=0.1, time_limit=1.0)
    assert record.outcome == "timeout" and record.times[-1] == pytest.approx(1.0)


def test_predict_mode_needs_a_simulator(scene_context):
    with pytest.raises(PlanningError, match="predict"):
        registry.create("controller", "contact", scene_context("se2-maze"), mode="predict")


def test_predict_mode_uses_the_simulator(peg):
    ctrl = registry.create("controller", "contact", peg, mode="predict", window=2, eps_adjust=0.5)
    q = pose(7, 7, 3.5)
    for _ in range(4):
        ctrl.command(q, pose(6, 7, 1.0), 0.1)
    # the kinematic simulator predicts sliding toward -x on the surface: the adjusted target moves there
    assert ctrl.adjusted_target[2] > 1.0


def test_peg_slide_pipeline_end_to_end(tmp_path):
    record = Pipeline.from_file("peg-slide", overrides=[f'output="{tmp_path}"']).run()
    assert record.execution is not None and record.execution.success
    assert (tmp_path / "execution.json").is_file() and (tmp_path / "path.png").is_file()
    assert "| execution | reached |" in (tmp_path / "report.md").read_text()


def test_track_mode_commands_the_simulators_prediction(peg):
    # model-predictive tracking: every step the command aims at where the kinematic simulator says the robot
    # gets in one period (here pressed onto the block, it slides instead of pushing into it)
    ctrl = registry.create("controller", "contact", peg, gain=2.0, mode="track")
    q, target = pose(7, 7, 3.55), pose(6, 7, 0.0)         # on the block (its top at z = 3), target inside it below
    predicted = peg.simulator.simulate(q[None], target, np.random.default_rng(0), 0.1).final[0]
    command = ctrl.command(q, target, 0.1)
    space = peg.robot.space
    assert np.allclose(command, 2.0 * space.difference(predicted, q))
    assert not np.allclose(command, 2.0 * space.difference(target, q))
    with pytest.raises(PlanningError, match="track"):
        registry.create("controller", "contact", Context(scene=peg.scene, robot=peg.robot), mode="track")


def test_track_mode_aims_at_the_target_when_the_simulator_refuses_the_measured_start(peg):
    # measured 5 cm into the block's top (a dynamic world's contact, deeper than the kinematic simulator's quarter
    # voxel): nothing to predict from, so this period commands the target, and the refusal is counted
    ctrl = registry.create("controller", "contact", peg, gain=2.0, mode="track")
    q, target = pose(7, 7, 3.45), pose(6, 7, 0.0)
    command = ctrl.command(q, target, 0.1)
    assert np.allclose(command, 2.0 * peg.robot.space.difference(target, q))
    assert ctrl.refused_predictions == 1
    ctrl.command(pose(7, 7, 3.55), target, 0.1)                  # on the block: predicted again
    assert ctrl.refused_predictions == 1


def test_track_mode_slides_the_peg_into_the_hole(peg):
    ctrl = registry.create("controller", "contact", peg, gain=2.0, mode="track", horizon=0.1)
    path = Path(np.array([pose(7, 7, 5), pose(5.6, 5.6, 3.5), pose(5, 5, 3.3), pose(5, 5, 0.625)]))
    record = execute(peg.simulator, ctrl, path, np.random.default_rng(0), period=0.1, time_limit=60)
    assert record.success and record.contacts.any()
