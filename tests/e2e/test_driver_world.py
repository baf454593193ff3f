"""One setting swaps the execution world: a pipeline executes through a robot driver as through a simulator.

The robot is the core's emulated arm (:mod:`pliant.testing.memory_robot`) behind the real driver stack (command
stream, ruckig, safety layer), registered from Python as the driver ``memory``; the ROS and CANopen drivers have
their own end-to-end tests with their robot peers.  The pipeline plans a straight motion of the iiwa over the
iiwa-shelf scene and executes it with the contact controller, first in the kinematic simulator, then on the robot.
"""

from __future__ import annotations

import numpy as np
import pytest
from pliant import Pipeline, registry
from pliant.cli import main
from pliant.errors import JointMismatch, PipelineError
from pliant.hardware.limits import load_limits
from pliant.testing.memory_robot import MemoryDriver, MemoryRobot

pytestmark = pytest.mark.usefixtures("frozen_heap")      # a command stream with a watchdog runs in this process

IIWA = [f"lbr_iiwa_joint_{i}" for i in range(1, 8)]
START = np.array([0.0, 0.3, 0.0, -1.2, 0.0, 0.6, 0.0])    # the iiwa-shelf scene's start


def _limits_text(names):
    joints = "".join(f'[[joints]]\nname = "{n}"\nlower = -2.9\nupper = 2.9\nvelocity = 1.5\nacceleration = 5.0\n'
                     f'jerk = 50.0\n' for n in names)
    return ('robot = "iiwa"\ncommand_rate = 100.0\nstate_timeout = 0.1\nposition_margin = 0.02\n'
            f'sources = ["test values"]\n{joints}')


@pytest.fixture
def memory_robot(tmp_path):
    path = tmp_path / "iiwa.toml"
    path.write_text(_limits_text(IIWA))
    robot = MemoryRobot(load_limits(path), START).start()
    MemoryDriver.robots[101] = (robot, path)
    registry.register("driver", "memory", MemoryDriver, "the core's emulated arm (tests)")
    yield robot
    registry.default_registry().unregister("driver", "memory")
    MemoryDriver.robots.pop(101, None)
    robot.stop()


def _pipeline(tmp_path, world=None):
    execution = {"period": 0.05, "time_limit": 30.0}
    if world is not None:
        execution["world"] = world
    return Pipeline(scene="iiwa-shelf", name="iiwa-drive", output=tmp_path / "out",
                    planner={"name": "waypoints", "waypoints": [[0.4, 0.45, 0.0, -1.1, 0.0, 0.75, 0.0]]},
                    simulator={"name": "kinematic", "noise": "none", "joint_velocity_limits": [1.0] * 7},
                    controller={"name": "contact", "gain": 4.0, "tolerance": 0.05}, execution=execution)


@pytest.mark.slow
def test_the_same_pipeline_executes_on_the_robot_by_one_setting(memory_robot, tmp_path):
    simulated = _pipeline(tmp_path).run(write=False)
    steps = []
    real = _pipeline(tmp_path, {"name": "memory", "robot_id": 101}).run(on_step=steps.append)
    assert simulated.execution.success and real.execution.success
    assert simulated.execution.world == "kinematic" and real.execution.world == "memory"
    goal = np.array([0.8, 0.6, 0.0, -1.0, 0.0, 0.9, 0.0])
    # a real arm decelerates within its limits after the controller's last command, so it travels on a little;
    # the record ends where it came to rest
    np.testing.assert_allclose(real.execution.configurations[-1], goal, atol=0.15)
    np.testing.assert_allclose(memory_robot.positions, real.execution.configurations[-1], atol=0.005)
    # the per-step hook saw every control step, in order, as it happened
    assert len(steps) == len(real.execution.times) - 1
    assert [s.time for s in steps] == pytest.approx(list(real.execution.times[1:]))
    assert memory_robot.violations() == []
    assert "execution world | memory" in (tmp_path / "out" / "report.md").read_text()


def test_an_unknown_world_fails_before_planning(tmp_path):
    with pytest.raises(PipelineError, match="no simulator or driver of that name"):
        _pipeline(tmp_path, "no-such-robot").run(write=False)


def test_a_driver_for_other_joints_is_refused(memory_robot, tmp_path):
    path = tmp_path / "other.toml"
    path.write_text(_limits_text(["a", "b", "c"]))
    other = MemoryRobot(load_limits(path))
    MemoryDriver.robots[102] = (other, path)
    try:
        with pytest.raises(JointMismatch, match="plans joints"):
            _pipeline(tmp_path, {"name": "memory", "robot_id": 102}).run(write=False)
    finally:
        MemoryDriver.robots.pop(102)


def test_the_override_spelling_is_one_setting(memory_robot, tmp_path):
    pipeline = Pipeline.from_file("baxter-policy", overrides=["execution.world=memory", "execution.world.robot_id=101"])
    assert pipeline.world_spec().name == "memory" and pipeline.world_spec().options == {"robot_id": 101}
    assert "pybullet" not in str(pipeline.to_dict()["execution"])      # the simulator's options went with it


def test_driver_check_prints_the_robot_and_exits_zero(memory_robot, capsys):
    assert main(["robot", "check", "memory", "--set", "robot_id=101"]) == 0
    out = capsys.readouterr().out
    assert "enabled" in out and "lbr_iiwa_joint_7" in out and "ok:" in out


def test_driver_check_says_what_is_wrong_in_one_line(memory_robot, capsys):
    memory_robot.enabled = False
    assert main(["robot", "check", "memory", "--set", "robot_id=101"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "disabled" in err[0]
    memory_robot.enabled = True
    memory_robot.names = tuple(IIWA[:6]) + ("joint_x",)
    assert main(["robot", "check", "memory", "--set", "robot_id=101"]) == 2
    assert "lbr_iiwa_joint_7" in capsys.readouterr().err
