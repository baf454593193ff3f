"""Time-parameterised trajectories of planned paths (pliant.planning.trajectory): known answers, limits, endpoints."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pliant.api import Trajectory, time_parameterize
from pliant.errors import ConfigError
from pliant.planning.trajectory import corners, rest_to_rest


def test_one_dimensional_rest_to_rest_known_answers():
    # trapezoid: 1 m at 1 m/s, 2 m/s^2 -> 0.5 s up (0.25 m), 0.5 s cruise (0.5 m), 0.5 s down: 1.5 s
    trajectory = time_parameterize([[0.0], [1.0]], 1.0, 2.0)
    assert trajectory.duration == pytest.approx(1.5)
    q, v, a = trajectory.state([0.25, 0.75, 0.9, 1.25, 1.5])
    assert q[:, 0] == pytest.approx([0.0625, 0.5, 0.65, 0.9375, 1.0])
    assert v[:, 0] == pytest.approx([0.5, 1.0, 1.0, 0.5, 0.0])
    assert a[:, 0] == pytest.approx([2.0, 0.0, 0.0, -2.0, -2.0])
    # triangle: 0.25 m never reaches 1 m/s: 2 sqrt(0.25 / 2) s, peak speed sqrt(0.25 * 2)
    short = time_parameterize([[0.0], [-0.25]], 1.0, 2.0)
    assert short.duration == pytest.approx(2 * math.sqrt(0.125))
    assert short.state([short.duration / 2])[1][0, 0] == pytest.approx(-math.sqrt(0.5))    # the peak, half way
    assert rest_to_rest(0.0, 1.0, 1.0)[0] == 0.0


def test_limits_hold_at_1khz_and_endpoints_match():
    rng = np.random.default_rng(0)
    path = rng.uniform(-1, 1, (6, 3))
    v, a = np.array([1.0, 0.5, 2.0]), np.array([3.0, 1.0, 4.0])
    trajectory = time_parameterize(path, v, a)
    samples = trajectory.sample(1000)
    assert np.all(np.abs(samples["velocities"]) <= v * (1 + 1e-9))
    assert np.all(np.abs(samples["accelerations"]) <= a * (1 + 1e-9))
    assert np.allclose(samples["positions"][0], path[0]) and np.allclose(samples["positions"][-1], path[-1])
    assert np.allclose(samples["velocities"][[0, -1]], 0.0)
    # it follows the path: every sample lies on its segment between the knots
    q, _, _ = trajectory.state(trajectory.knot_times)
    assert np.allclose(q, path)
    ratio = trajectory.limit_ratio(1000)
    assert 0.9 < max(ratio.values()) <= 1.0 + 1e-9          # time-optimal: some limit is reached


def test_jerk_limited_profile_respects_all_three_limits():
    trajectory = time_parameterize([[0.0, 0.0], [1.0, 0.5]], [1.0, 1.0], [2.0, 2.0], jerk=[10.0, 10.0])
    plain = time_parameterize([[0.0, 0.0], [1.0, 0.5]], [1.0, 1.0], [2.0, 2.0])
    assert trajectory.duration > plain.duration                 # the jerk limit costs time
    s = trajectory.sample(1000)
    assert np.all(np.abs(s["velocities"]) <= 1.0 + 1e-9) and np.all(np.abs(s["accelerations"]) <= 2.0 + 1e-9)
    jerk = np.diff(s["accelerations"], axis=0) / np.diff(s["times"])[:, None]
    assert np.max(np.abs(jerk)) <= 10.0 * (1 + 1e-6)
    assert np.allclose(s["positions"][-1], [1.0, 0.5])


def test_straight_runs_do_not_stop():
    dense = np.linspace([0.0, 0.0], [1.0, 1.0], 11)
    assert len(corners(dense)) == 2
    assert time_parameterize(dense, 1.0, 2.0).duration == pytest.approx(1.5)
    assert isinstance(time_parameterize(dense[:1], 1.0, 1.0), Trajectory)
    assert time_parameterize(dense[:1], 1.0, 1.0).duration == 0.0


def test_bad_limits_name_the_field():
    with pytest.raises(ConfigError) as err:
        time_parameterize([[0.0], [1.0]], 0.0, 1.0)
    assert err.value.field == "velocity"


def test_a_pipeline_with_a_trajectory_table_times_its_plan():
    from pliant.errors import PipelineError
    from pliant.pipeline import Pipeline

    # not written: the report's figures take seconds (docs/trajectories.md shows trajectory.json and trajectory.png)
    pipeline = Pipeline.from_file("straight-demo", overrides={"trajectory.velocity": 0.1,
                                                              "trajectory.acceleration": "0.5,0.5,0.25"})
    record = pipeline.run(write=False)
    assert record.result.solved and record.trajectory is not None
    on_file = record.trajectory.to_dict(pipeline.trajectory["rate"])          # what trajectory.json holds
    assert on_file["rate"] == 100.0 and on_file["duration"] == pytest.approx(record.trajectory.duration)
    assert np.allclose(on_file["positions"][0], record.result.path.configurations[0])
    assert np.allclose(on_file["positions"][-1], record.result.path.configurations[-1])
    assert record.result.statistics["trajectory"]["duration"] == pytest.approx(record.trajectory.duration)
    assert np.max(np.abs(np.array(on_file["velocities"])) / 0.1) <= 1 + 1e-9
    assert np.allclose(record.trajectory.acceleration, [0.5, 0.5, 0.25])
    with pytest.raises(PipelineError) as err:
        Pipeline.from_file("straight-demo", overrides={"trajectory.velocity": -1, "trajectory.acceleration": 1})
    assert err.value.field == "trajectory.velocity"
    with pytest.raises(PipelineError) as err:
        Pipeline.from_file("straight-demo", overrides={"trajectory.velocity": 1})
    assert err.value.field == "trajectory.acceleration"


def test_execution_follows_the_trajectory_in_time():
    from pliant.pipeline import Pipeline

    record = Pipeline.from_file("maze-slide", overrides={"trajectory.velocity": 0.5,
                                                         "trajectory.acceleration": 1.0}).run(write=False)
    execution = record.execution
    assert execution.success and execution.times[-1] == pytest.approx(record.trajectory.duration, abs=0.11)
    planned = record.trajectory.state(np.asarray(execution.times))[0]
    assert np.allclose(execution.configurations, planned, atol=1e-6)     # the kinematic world follows it exactly


def test_limits_from_a_robots_limits_file():
    from pathlib import Path

    from pliant.hardware.limits import load_limits
    from pliant.pipeline import Pipeline
    from pliant.results import Path as PlannedPath
    from pliant.results import PlanResult, Status

    root = Path(__file__).resolve().parents[2]
    limits_file = root / "plugins/drivers/pliant_ros1/limits/iiwa7_r800.toml"
    limits = load_limits(limits_file)
    pipeline = Pipeline("iiwa-shelf", trajectory={"limits": str(limits_file), "acceleration": 1.0})
    path = np.array([np.zeros(7), np.full(7, 0.5), np.linspace(-1, 1, 7)])
    result = PlanResult(Status.SOLVED, path=PlannedPath(path))
    trajectory = pipeline._time_parameterize(result)
    assert np.array_equal(trajectory.velocity, limits.velocity) and np.array_equal(trajectory.jerk, limits.jerk)
    assert np.allclose(trajectory.acceleration, 1.0)               # the table's number replaces the file's
    s = trajectory.sample(1000)
    assert np.all(np.abs(s["velocities"]) <= limits.velocity * (1 + 1e-9))
    assert np.all(np.abs(s["accelerations"]) <= 1.0 + 1e-9)
    assert result.statistics["trajectory"]["duration"] == trajectory.duration


def test_limits_of_the_robot_itself():
    from types import SimpleNamespace

    from pliant.errors import PipelineError
    from pliant.pipeline import Pipeline
    from pliant.results import Path as PlannedPath
    from pliant.results import PlanResult, Status

    robot = SimpleNamespace(velocity_limits=np.array([1.0, 2.0]), acceleration_limits=np.array([4.0, 8.0]),
                            jerk_limits=None)
    pipeline = Pipeline("triple-wall", trajectory={"limits": "robot", "velocity": 0.5})
    result = PlanResult(Status.SOLVED, path=PlannedPath(np.array([[0.0, 0.0], [1.0, 1.0]])))
    trajectory = pipeline._time_parameterize(result, robot)
    assert np.allclose(trajectory.velocity, 0.5) and np.allclose(trajectory.acceleration, [4.0, 8.0])
    assert trajectory.jerk is None
    with pytest.raises(PipelineError) as err:
        Pipeline("triple-wall", trajectory={"limits": "robot"})._time_parameterize(result, SimpleNamespace())
    assert err.value.field == "trajectory.limits"
