"""The ROS 2 drivers end to end against the ROS 2 peer (an emulated ros2_control arm in a child process, on a ROS
domain of its own, discovery limited to this machine): streaming to the forward controller, the trajectory
controller, faults (stale states, wrong joint names, joint states that jump, a controller that stops consuming, a
crashed node), refusals
before anything is sent, ``pliant driver iiwa-ros2 --check`` and ``pliant robot ros2-graph``.

No wall-clock assertions: every wait has a generous deadline and every check is on what the peer received."""

from __future__ import annotations

import time

import numpy as np
import pytest
from pliant import registry
from pliant.errors import (
    ConfigError,
    ConnectionLost,
    JointMismatch,
    LimitViolation,
    NonFiniteCommand,
    StaleState,
    StateError,
)
from ros2_helpers import assert_within_limits, at_rest, commands, start_motion, wait_until

pytestmark = pytest.mark.realtime

LBR = tuple(f"lbr_A{i}" for i in range(1, 8))
MODEL = tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8))


def test_the_drivers_are_registered_with_the_lbr_stack_defaults():
    assert {"ros2-control", "iiwa-ros2"} <= set(registry.available("driver"))
    iiwa = registry.create("driver", "iiwa-ros2")
    assert iiwa.joint_names() == MODEL and iiwa.options.joints == LBR
    assert iiwa.topics == {"command": "/lbr/forward_position_controller/commands",
                           "trajectory": "/lbr/joint_trajectory_controller/joint_trajectory",
                           "state": "/lbr/joint_states"}
    assert iiwa.limits.command_rate == 100.0 and iiwa.limits.names == MODEL
    assert iiwa.options.state_qos == "best_effort" and iiwa.options.command_qos == "reliable"
    with pytest.raises(ConfigError, match="joints"):
        registry.create("driver", "ros2-control").joint_names()
    generic = registry.create("driver", "ros2-control", joints=["a", "b"], namespace="arm", forward_controller="fwd")
    assert generic.topics["command"] == "/arm/fwd/commands" and generic.topics["state"] == "/arm/joint_states"
    with pytest.raises(ConfigError, match="limits"):
        _ = generic.limits


def test_the_child_environment_isolates_ros2(tmp_path):
    from pliant_ros2.environment import ros2_prefix

    if ros2_prefix() is None:
        pytest.skip("ROS 2 is not installed: make install puts its wheels under .venv/ros2")
    from pliant_ros2.environment import ros2_environment

    env = ros2_environment(42, log_dir=tmp_path, base={"PYTHONPATH": "/x", "_ROS_WHEELS_BOOTSTRAP_COMPLETE": "1",
                                                        "ROS_LOCALHOST_ONLY": "0"})
    assert env["ROS_DOMAIN_ID"] == "42" and env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert env["RMW_IMPLEMENTATION"] == "rmw_fastrtps_cpp" and env["ROS_LOG_DIR"] == str(tmp_path)
    assert env["PYTHONPATH"].split(":")[0].endswith("site-packages") and env["PYTHONPATH"].endswith("/x")
    assert "ROS_LOCALHOST_ONLY" not in env and env["_ROS_WHEELS_BOOTSTRAP_COMPLETE"] == "1"
    assert any(p.endswith(".libs") for p in env["LD_LIBRARY_PATH"].split(":"))


def test_the_driver_passes_the_conformance_kit_against_the_peer(make_peer, make_driver):
    from pliant.testing.conformance import check_driver

    peer = make_peer(wait=False)
    assert "non-finite" in check_driver(make_driver(peer), "iiwa-ros2")


def test_move_to_streams_to_the_forward_controller_within_the_limits(make_peer, make_driver):
    """move_to arrives, every command the controller received is within the limits; an out-of-limit target is
    refused before anything of it is sent (and the stream then refuses motion until reconnected)."""
    peer = make_peer(wait=False)
    driver = make_driver(peer)
    with driver:
        q0 = driver.state()
        np.testing.assert_allclose(q0, [0.0, 0.3, 0.0, -1.2, 0.0, 0.6, 0.0], atol=1e-6)
        target = q0 + np.array([0.3, -0.2, 0.25, 0.3, -0.3, 0.2, 0.4])
        reached = driver.move_to(target)
        np.testing.assert_allclose(reached, target, atol=driver.options.reach_tolerance)
        report = driver.check()
        assert report["enabled"] and "1 subscriber" in report["detail"]
        with pytest.raises(LimitViolation, match="lbr_iiwa_joint_1"):
            driver.move_to(np.array([3.5, 0, 0, 0, 0, 0, 0.0]))     # A1 beyond +-170 deg
        with pytest.raises(LimitViolation):
            driver.move_to(q0)
    count = assert_within_limits(peer, driver.limits)
    assert count > 50                                              # a stream, not one jump
    assert all(r.get("source") != "trajectory" for r in commands(peer))
    np.testing.assert_allclose(at_rest(peer), target, atol=driver.options.reach_tolerance)


def test_the_trajectory_controller_mode_and_a_whole_trajectory(make_peer, make_driver):
    """mode = "trajectory": the stream's commands go to the joint_trajectory_controller; a NaN target is refused
    before anything is sent.  send_trajectory: one whole trajectory, checked against the limits first."""
    peer = make_peer(wait=False)
    driver = make_driver(peer, mode="trajectory")
    with driver:
        q0 = driver.state()
        target = q0 + 0.25
        np.testing.assert_allclose(driver.move_to(target), target, atol=driver.options.reach_tolerance)
        with pytest.raises(NonFiniteCommand):
            driver.move_to(np.full(7, np.nan))
    received = commands(peer)
    assert received and all(r.get("source") == "trajectory" for r in received)
    assert_within_limits(peer, driver.limits)
    # a whole trajectory in one message, checked first: too fast is refused, a feasible one is executed
    driver.open()
    try:
        assert wait_until(lambda: driver.latest_state() is not None)
        start = np.array(driver.latest_state().positions)
        with pytest.raises(LimitViolation, match="rad/s"):
            driver.send_trajectory([0.1], [start + 1.0])
        with pytest.raises(LimitViolation, match="rad/s\\^2"):          # slow enough, but too sudden
            driver.send_trajectory([0.5], [start + 0.5])
        path = np.array([start - 0.1, start - 0.2])
        times = driver.path_times(path)
        driver.trajectory_points(times, path)                          # the times it chose keep every limit
        with pytest.raises(LimitViolation):
            driver.trajectory_points(times * 0.9, path)                # and they are the shortest that do
        np.testing.assert_allclose(driver.send_path(path), times)
        assert wait_until(lambda: np.max(np.abs(driver.latest_state().positions - path[-1])) < 0.01)
    finally:
        driver.shutdown()
    whole = [r for r in peer.records() if r["kind"] == "trajectory" and len(r["points"]) == 2]
    assert len(whole) == 1 and whole[0]["names"] == list(LBR)
    np.testing.assert_allclose([t for t, _, _ in whole[0]["points"]], times, atol=1e-6)
    assert all(np.all(np.isfinite(r["positions"])) for r in commands(peer))


@pytest.mark.parametrize("fault, error, match", [("stale", StaleState, "watchdog"),
                                                  ("names-wrong", JointMismatch, "lack"),
                                                  ("jump", StateError, "the joint states jump"),
                                                  ("deactivate", ConnectionLost, "nothing subscribes")])
def test_a_fault_stops_the_arm_with_a_clear_error(make_peer, make_driver, fault, error, match):
    """Stale states (the watchdog at the limits file's 0.1 s... here 0.3 s), joint states naming other joints, joint
    states that jump (0.5 rad in one 10 ms period: beyond what the velocity limits allow), and a forward controller that
    stops consuming: the stream brakes within the limits and the caller gets the error."""
    peer = make_peer(wait=False)
    driver = make_driver(peer, state_timeout=0.3 if fault == "stale" else 0.5)
    since = time.monotonic()
    with driver:
        q0 = driver.state()
        target = q0 + np.array([0.6, -0.5, 0.6, 0.6, -0.6, 0.6, 0.6])
        start_motion(driver, target)
        peer.fault(fault)
        with pytest.raises(error, match=match):
            driver.move_to(target)
        driver.stop()
    rest = at_rest(peer)
    assert np.max(np.abs(rest - target)) > 0.05                  # stopped on the way, not at the target
    assert_within_limits(peer, driver.limits, since)


def test_no_controller_and_a_crashed_node_are_lost_connections(make_peer, make_driver):
    """A controller that is not there: one line naming its topic.  The driver's own ROS 2 node dying mid-session:
    ConnectionLost naming it."""
    peer = make_peer(wait=False)
    missing = make_driver(peer, forward_controller="no_such_controller", connect_timeout=1.0)
    with pytest.raises(ConnectionLost, match="nothing subscribes to /lbr/no_such_controller/commands"):
        missing.connect()
    driver = make_driver(peer)
    with driver:
        driver._process.kill()
        with pytest.raises(ConnectionLost, match="node's process exited"):
            driver.move_to(driver.state() + 0.2)


def test_check_and_graph_commands(make_peer, capsys):
    from pliant.cli import main

    peer = make_peer()
    settings = ["--set", f"domain_id={peer.domain_id}", "--set", "localhost_only=true", "--set", "state_timeout=0.5",
                "--set", "connect_timeout=20"]
    assert main(["driver", "iiwa-ros2", "--check", *settings]) == 0
    out = capsys.readouterr().out
    assert "iiwa-ros2: enabled" in out and "/lbr/forward_position_controller/commands: 1 subscriber" in out
    assert "lbr_iiwa_joint_7" in out and "ok: the robot answers" in out
    assert main(["robot", "ros2-graph", "iiwa-ros2", "--duration", "0.3", *settings]) == 0
    out = capsys.readouterr().out
    assert "std_msgs/msg/Float64MultiArray" in out and "sensor_msgs/msg/JointState" in out
    assert "trajectory_msgs/msg/JointTrajectory" in out and "naming lbr_A1, lbr_A2" in out
    assert "forward_position_controller" in out and "joint_trajectory_controller" in out
