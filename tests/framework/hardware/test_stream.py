"""The command stream end to end with an emulated robot: motion, blending, stops, and faults.

Every test ends by checking every command the robot received against the limits: nothing unsafe is ever sent.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from pliant.errors import (
    DriverError,
    EmergencyStop,
    JointMismatch,
    LimitViolation,
    NonFiniteCommand,
    RobotDisabled,
    StaleState,
    StateError,
    StepTooLarge,
)
from pliant.results import Path


def _settled(robot, timeout=30.0):
    """Whether the robot came to rest once the stream ended: the last command it received is at rest (zero
    velocity) and its servo reaches that command.  Polled, not timed: the robot's own thread steps its servo as
    slowly as a loaded machine runs it (a fixed 0.5 s wait failed at load 13); the deadline only ends a broken run."""
    if not robot.commands or np.any(np.abs(robot.commands[-1][2]) > 1e-6):
        return False
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if np.allclose(robot.positions, robot.command, atol=1e-6):
            return True
        time.sleep(0.01)
    return False


def test_move_to_arrives_within_limits(robot_and_driver):
    robot, driver = robot_and_driver
    with driver:
        reached = driver.move_to([0.5, -1.0, 1.0])
        np.testing.assert_allclose(reached, [0.5, -1.0, 1.0], atol=0.01)
        np.testing.assert_allclose(driver.state(), robot.positions, atol=0.01)
    assert robot.violations() == []
    assert len(robot.commands) > 100


def test_context_exit_stops_a_moving_robot(robot_and_driver):
    robot, driver = robot_and_driver
    with driver:
        driver.move_to([0.9, 1.9, 1.4], wait=False)
        time.sleep(0.3)
    assert _settled(robot)
    assert abs(robot.positions[1]) < 1.9            # it stopped on the way, it did not finish the motion
    assert robot.violations() == []


def test_exception_in_the_block_stops_the_robot(robot_and_driver):
    robot, driver = robot_and_driver
    with pytest.raises(KeyError), driver:
        driver.move_to([-0.9, -1.9, -0.4], wait=False)
        time.sleep(0.2)
        raise KeyError("user code failed")
    assert _settled(robot)
    assert robot.violations() == []


def test_streamed_targets_blend(robot_and_driver):
    robot, driver = robot_and_driver
    with driver:
        for k in range(100):                         # a target that moves every cycle
            driver.stream([0.6 * np.sin(k / 100), 0.0, 0.0])
            time.sleep(0.005)
        driver.move_to([0.0, 0.0, 0.0])
    speeds = np.array([v for _, _, v in robot.commands])[:, 0]
    assert np.all(np.abs(np.diff(speeds)) <= 4.0 * 0.005 + 1e-9)   # continuous: no stop between targets
    assert robot.violations() == []


def test_follow_a_timed_path(robot_and_driver):
    robot, driver = robot_and_driver
    times = np.linspace(0, 1.0, 11)
    path = Path(np.stack([0.5 * np.sin(np.pi * times), 0.2 * times, 0.4 * times], axis=1), times)
    with driver:
        end = driver.follow(path)
    np.testing.assert_allclose(end, path.configurations[-1], atol=0.01)
    assert robot.violations() == []


def test_step_is_the_execution_protocol(robot_and_driver):
    robot, driver = robot_and_driver
    with driver:
        driver.reset(np.zeros(3))
        q = driver.configuration()
        t0 = time.monotonic()
        for _ in range(10):
            q = driver.step(np.array([0.5, 0.0, 0.0]), 0.05, None)
        elapsed = time.monotonic() - t0
        assert elapsed >= 0.5 - 1e-3                             # real time: each step lasts at least its dt
        measured = driver.measured()
        assert measured.velocities[0] > 0 and measured.time <= time.monotonic()
        # it moved along the commanded velocity, never faster (bounds that hold however loaded the machine is)
        assert 0 < q[0] <= 0.5 * (time.monotonic() - t0) + 1e-3
        assert np.all(np.abs(q[1:]) < 1e-3)
        driver.stop()
    assert robot.violations() == []


@pytest.mark.parametrize(("target", "error"), [([np.nan, 0, 0], NonFiniteCommand), ([0, 0, 1.6], LimitViolation),
                                               ([0, 2.5, 0], LimitViolation)])
def test_bad_targets_are_refused_and_never_sent(robot_and_driver, target, error):
    robot, driver = robot_and_driver
    with driver:
        driver.move_to([0.3, 0.3, 0.3], wait=False)
        time.sleep(0.1)
        with pytest.raises(error):
            driver.stream(target)
        with pytest.raises(error):                  # the stream stays faulted: no further motion
            driver.move_to([0, 0, 0])
        driver.stop()
    assert _settled(robot)
    assert robot.violations() == []


def test_velocity_spike_in_a_stream_is_refused(robot_and_driver):
    robot, driver = robot_and_driver
    with driver:
        for k in range(20):
            driver.stream([0.01 * k, 0, 0], [0.2, 0, 0])
            time.sleep(0.005)
        with pytest.raises(LimitViolation, match="joint a"):
            driver.stream([0.2, 0, 0], [5.0, 0, 0])
    assert robot.violations() == []


def test_a_jump_in_a_stream_is_refused(robot_and_driver):
    robot, driver = robot_and_driver
    with driver:
        for k in range(20):
            driver.stream([0.004 * k, 0, 0])           # 0.004 rad per 5 ms cycle: under the step limit (0.006)
            time.sleep(0.005)
        with pytest.raises(StepTooLarge, match="joint a") as info:
            driver.stream([0.5, 0, 0])
        assert info.value.limit < 0.1
        with pytest.raises(StepTooLarge):              # faulted: no further motion until reconnecting
            driver.stream([0.08, 0, 0])
        driver.stop()
    assert _settled(robot) and robot.positions[0] < 0.2
    assert robot.violations() == []


@pytest.mark.parametrize(("fault", "error"), [
    (lambda r: setattr(r, "publishing", False), StaleState),
    (lambda r: setattr(r, "enabled", False), RobotDisabled),
    (lambda r: setattr(r, "estop", True), EmergencyStop),
    (lambda r: setattr(r, "names", ("a", "b", "x")), JointMismatch),
    (lambda r: setattr(r, "stamp_offset", -10.0), StateError),
    (lambda r: setattr(r, "position_offset", np.array([0.0, 0.5, 0.0])), StateError),     # an encoder jump
])
def test_faults_mid_motion_stop_the_robot(robot_and_driver, fault, error):
    robot, driver = robot_and_driver
    with driver:
        driver.move_to([0.9, 1.9, 1.4], wait=False)
        time.sleep(0.25)
        fault(robot)
        with pytest.raises(error):
            driver.move_to([0.9, 1.9, 1.4])
        driver.stop()                                # waits until the braking reference is at rest
        smoother = driver.session.smoother
        assert smoother.braking and smoother.at_rest
        assert smoother.brake_reason == f"fault: {error.__name__}" or issubclass(type(driver.session.error), error)
    assert robot.violations() == []


def test_arrival_needs_a_state_measured_after_the_last_command(robot_and_driver):
    """A robot that goes quiet where it stands has not arrived anywhere: the newest state is still younger than the
    watchdog, and within tolerance of the target, but it was measured before the command (the ROS 1 peer-death
    test in CI returned 'arrived' this way when the arm had barely left its start)."""
    robot, driver = robot_and_driver
    with driver:
        here = driver.state()
        robot.publishing = False
        with pytest.raises(StaleState, match="old"):
            driver.move_to(here)
        driver.stop()
    assert robot.violations() == []


def test_connect_enables_a_disabled_robot(robot_and_driver):
    robot, driver = robot_and_driver
    robot.enabled = False
    with driver:
        assert robot.enabled
        driver.move_to([0.1, 0.1, 0.1])
    assert robot.violations() == []


def test_not_connected_is_a_clear_error(robot_and_driver):
    _, driver = robot_and_driver
    with pytest.raises(DriverError, match="not connected"):
        driver.state()


def test_check_reports_state_limits_and_rates(robot_and_driver):
    _, driver = robot_and_driver
    with driver:
        time.sleep(0.3)
        report = driver.check()
    assert report["joints"] == ["a", "b", "c"] and report["enabled"]
    # never above the command rate (a late cycle is not made up by a burst); how close to 200 Hz it comes depends
    # on the machine's load, so that is not asserted
    assert 0 < report["measured_command_rate"] <= 200.0 * 1.05
    assert report["sources"] == ["made up for tests"]


def test_no_socket_is_opened(robot_and_driver, monkeypatch):
    """ruckig can send waypoints to a cloud service (``intermediate_positions``); the stack must never open a
    connection of its own (this robot is in memory: any connection at all is a leak)."""
    import socket

    opened = []
    real_connect = socket.socket.connect

    def record(self, address):
        opened.append(address)
        return real_connect(self, address)

    monkeypatch.setattr(socket.socket, "connect", record)
    monkeypatch.setattr(socket.socket, "connect_ex", lambda self, address: opened.append(address) or 0)
    robot, driver = robot_and_driver
    with driver:
        driver.move_to([0.3, -0.3, 0.3])
        times = np.linspace(0, 0.5, 6)
        driver.follow(Path(np.stack([0.3 - 0.2 * times, -0.3 + 0.2 * times, 0.3 + 0 * times], axis=1), times))
    assert opened == []
    assert robot.violations() == []


def test_the_memory_driver_passes_the_conformance_kit(robot_and_driver):
    from pliant.testing import check_driver

    robot, driver = robot_and_driver
    assert "stream" in check_driver(driver)
    assert robot.violations() == []


def test_the_measurement_stays_current_after_a_status_fault(robot_and_driver):
    """After an e-stop the states are still valid: stop() returns where the arm came to rest, not where it was."""
    robot, driver = robot_and_driver
    with driver:
        driver.move_to([0.9, 1.9, 1.4], wait=False)
        time.sleep(0.3)
        robot.estop = True                      # the emulated arm holds where it is, still publishing
        time.sleep(0.1)
        rest = driver.stop()
        np.testing.assert_allclose(driver.session.measured_log[-1][1], robot.positions, atol=1e-6)
        np.testing.assert_allclose(rest, robot.positions, atol=1e-3)


def test_reset_to_a_start_on_a_limit_drives_inside_the_margin(robot_and_driver):
    robot, driver = robot_and_driver
    with driver:
        driver.reset(np.array([1.0, 0.0, 0.0]))           # on joint a's limit: held 0.05 inside it
        np.testing.assert_allclose(driver.state(), [0.95, 0.0, 0.0], atol=0.01)
        with pytest.raises(LimitViolation, match="joint a"):
            driver.reset(np.array([1.2, 0.0, 0.0]))       # beyond the limit by more than the margin
    assert robot.violations() == []
