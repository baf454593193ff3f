"""End to end: pliant's command stream (ruckig, safety layer, watchdogs) drives each robot's peer over ROS 1 on
loopback, and every fault of the ROS side -- wrong joint names, stale states, a dead peer, stamps out of order or
repeated, a flood, the robot disabled or e-stopped -- reaches the caller as a DriverError subclass while the arm
is stopped.  Every test ends by checking every command the peer received against the limits file."""

from __future__ import annotations

import time

import numpy as np
import pytest
from pliant.errors import (
    EmergencyStop,
    JointMismatch,
    RobotDisabled,
    StaleState,
    StateError,
)
from pliant.hardware.limits import load_limits
from pliant.results import Path
from pliant_ros1.robots import limits_file
from ros1_helpers import (
    assert_at_rest,
    assert_within_limits,
    commands_since,
    reachable_target,
    start_motion,
    unique_fault_topic,
    wait_until,
)

pytestmark = pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning")

DRIVERS = {"pr2": "pr2-ros", "baxter": "baxter-ros", "iiwa": "iiwa-ros"}


@pytest.fixture(scope="module")
def baxter_peer(ros_session, tmp_path_factory):
    """One Baxter peer (right arm, kinematic simulator) shared by the tests whose faults can be switched off; its
    ``home`` is where its arm started (each test starts there, so that the arm never wanders into the scene)."""
    from pliant_ros1.testing.process import PeerProcess

    if not ros_session.alive():
        ros_session.start()
    directory = tmp_path_factory.mktemp("baxter_peer")
    peer = PeerProcess("baxter", ros_session.uri, record=directory / "record.jsonl", log=directory / "peer.log",
                       fault_topic=unique_fault_topic())
    try:
        peer.start()
        assert wait_until(lambda: any(r["kind"] == "state" for r in peer.records()))
        peer.home = np.array(next(r for r in peer.records() if r["kind"] == "state")["positions"])
        yield peer
    finally:
        peer.stop()


def _home(peer, rng) -> np.ndarray:
    """The shared peer's home, moved by up to 2 mrad per joint (seeded).

    A brake that begins exactly a / j seconds into a jerk-limited start ends exactly 2 a^3 / j^2 from where the
    motion began (0.08 rad for Baxter's shoulder), and ruckig 0.19 fails ("error in step 1") for some positions
    when asked to move exactly that far from rest: never aim exactly back at the same home."""
    return peer.home + rng.uniform(-2e-3, 2e-3, len(peer.home))


def test_baxter_moves_follows_and_streams_within_its_limits(baxter_peer, make_driver):
    baxter_peer.fault("clear")
    rng = np.random.default_rng(11)
    since = time.monotonic()
    driver = make_driver("baxter-ros")
    with driver:                                            # enables the (disabled) robot
        q0 = driver.move_to(_home(baxter_peer, rng))
        target = reachable_target(q0, driver.limits, rng)
        np.testing.assert_allclose(driver.move_to(target), target, atol=driver.options.reach_tolerance)
        arm = np.array([r for r in baxter_peer.records() if r["kind"] == "state"][-1]["positions"])
        np.testing.assert_allclose(arm, target, atol=driver.options.reach_tolerance)
        # a timed path back through a midpoint
        path = Path(np.array([target, 0.5 * (target + q0) + 0.05, q0]), times=np.array([0.0, 1.0, 2.0]))
        np.testing.assert_allclose(driver.follow(path), q0, atol=driver.options.reach_tolerance)
        # a streamed target changing every cycle (a slow wave on every joint, toward the side with room)
        lim = driver.limits
        side = np.where(lim.command_upper - q0 >= q0 - lim.command_lower, 1.0, -1.0) * rng.uniform(0.5, 1.0, 7)
        start = time.monotonic()
        while (t := time.monotonic() - start) < 1.0:
            driver.stream(q0 + side * 0.1 * (1.0 - np.cos(np.pi * t)))
            time.sleep(lim.period)
        driver.stop()
        rate = driver.check()["measured_command_rate"]
    assert_at_rest(baxter_peer)
    records = commands_since(baxter_peer, since)
    count = assert_within_limits(records, driver.limits)
    commands = [r for r in records if r["kind"] == "command"]
    assert all(r["accepted"] and r["names"] == list(driver.joint_names()) for r in commands[-50:])
    duration = commands[-1]["t"] - commands[0]["t"]
    assert 90 < rate < 110 and count / duration > 80        # 100 Hz at the driver, and as received by the robot


@pytest.mark.parametrize(("robot", "side"), [("pr2", "right"), ("iiwa", "right")])
def test_pr2_and_iiwa_move_within_their_limits(robot, side, make_peer, make_driver):
    peer = make_peer(robot, side, "--physics-rate", "250")
    rng = np.random.default_rng(5)
    since = time.monotonic()
    driver = make_driver(DRIVERS[robot])
    with driver:
        q0 = driver.state()
        target = reachable_target(q0, driver.limits, rng)
        np.testing.assert_allclose(driver.move_to(target), target, atol=driver.options.reach_tolerance)
        np.testing.assert_allclose(driver.move_to(q0), q0, atol=driver.options.reach_tolerance)
    records = commands_since(peer, since)
    assert_within_limits(records, driver.limits, tolerance=1e-6)   # the iiwa's commands are float32
    commands = [r for r in records if r["kind"] == "command"]
    if robot == "pr2":        # one trajectory point per command, with its velocities
        assert all(r["velocities"] is not None for r in commands)
        assert max(np.max(np.abs(r["velocities"])) for r in commands) > 0.1


FAULTS = [("names-wrong", JointMismatch, "lack"), ("names-duplicate", JointMismatch, "twice"),
          ("stale", StaleState, "old"), ("stamps-backwards", StateError, "backwards"),
          ("stamps-repeat", StateError, "same time stamp"), ("flood", StateError, "flood"),
          ("disable", RobotDisabled, "disabled"), ("estop", EmergencyStop, "emergency stop")]


@pytest.mark.parametrize(("fault", "error", "words"), FAULTS, ids=[f[0] for f in FAULTS])
def test_a_fault_mid_motion_stops_the_arm_with_a_clear_error(fault, error, words, baxter_peer, make_driver):
    baxter_peer.fault("clear")
    rng = np.random.default_rng(100 + [f[0] for f in FAULTS].index(fault))
    since = time.monotonic()
    # the watchdog test: 0.3 s, short enough to stop the arm on the way, long enough that the thread stalls of a
    # loaded machine do not fire it at connection (the limits files' own 0.1 s did, in CI)
    # the flood test: 300 states/s (three times Baxter's 100 Hz), not the limits file's 1,000: on a loaded machine
    # neither the peer's 10 kHz publisher nor rospy's reader reaches 1,000 messages a second every time
    settings = {"stale": {"state_timeout": 0.3}, "flood": {"max_state_rate": 300.0}}.get(fault, {})
    driver = make_driver("baxter-ros", **settings)
    with driver:
        q0 = driver.move_to(_home(baxter_peer, rng))
        target = reachable_target(q0, driver.limits, rng, 0.4, 0.6)
        start_motion(driver, target)
        baxter_peer.fault(fault)
        with pytest.raises(error, match=words) as info:
            driver.move_to(target)
        assert "\n" not in str(info.value)
        stopped = driver.stop()                          # a stop is always allowed
        with pytest.raises(error):                       # motion stays refused until reconnecting
            driver.move_to(q0)
    rest = assert_at_rest(baxter_peer)
    assert np.max(np.abs(rest - target)) > 0.02          # it stopped on the way
    records = commands_since(baxter_peer, since)
    if fault in ("disable", "estop"):                    # the robot holds where it was (the stream's last
        np.testing.assert_allclose(rest, stopped, atol=0.05)  # measurement is up to a cycle older)
    else:                                                # the arm followed the braking commands to their end
        last = [r for r in records if r["kind"] == "command"][-1]
        np.testing.assert_allclose(rest, last["positions"], atol=1e-3)
    assert_within_limits(records, driver.limits)
    baxter_peer.fault("clear")


def test_a_shuffled_joint_order_is_mapped_by_name(baxter_peer, make_driver):
    """Baxter names its joints in every message: a different order is not a fault, the core maps by name."""
    baxter_peer.fault("clear")
    baxter_peer.fault("names-shuffle")
    since = time.monotonic()
    driver = make_driver("baxter-ros")
    try:
        with driver:
            assert wait_until(lambda: driver.latest_state().names[:2] != ("head_nod", "head_pan")
                              or driver.latest_state().names[-1] != "torso_t0")
            q0 = driver.move_to(_home(baxter_peer, np.random.default_rng(2)))
            target = reachable_target(q0, driver.limits, np.random.default_rng(2))
            np.testing.assert_allclose(driver.move_to(target), target, atol=driver.options.reach_tolerance)
        arm = assert_at_rest(baxter_peer)
        np.testing.assert_allclose(arm, target, atol=driver.options.reach_tolerance)
        assert_within_limits(commands_since(baxter_peer, since), driver.limits)
    finally:
        baxter_peer.fault("clear")


@pytest.mark.parametrize(("robot", "fault", "error"), [("pr2", "names-wrong", JointMismatch),
                                                       ("iiwa", "stamps-backwards", StateError),
                                                       ("iiwa", "stale", StaleState)])
def test_pr2_and_iiwa_faults_stop_the_arm_too(robot, fault, error, make_peer, make_driver):
    peer = make_peer(robot, "right", "--simulator", "none")
    since = time.monotonic()
    driver = make_driver(DRIVERS[robot], **({"state_timeout": 0.3} if fault == "stale" else {}))
    with driver:
        q0 = driver.state()
        target = reachable_target(q0, driver.limits, np.random.default_rng(4), 0.4, 0.6)
        start_motion(driver, target)
        peer.fault(fault)
        with pytest.raises(error):
            driver.move_to(target)
        driver.stop()
    rest = assert_at_rest(peer)
    assert np.max(np.abs(rest - target)) > 0.02
    assert_within_limits(commands_since(peer, since), driver.limits)


def test_a_pipeline_executes_on_the_iiwa_peer_by_one_setting(make_peer, master, tmp_path):
    """The execution world ``iiwa-ros``: the contact controller runs closed-loop on the peer's measured states.

    The controller's gain is gentler than in the simulator-only pipelines: the iiwa's limits file allows only
    2 rad/s^2 and 10 rad/s^3, so a fast velocity command would coast well past the goal while braking."""
    from pliant import Pipeline

    peer = make_peer("iiwa", "right", "--start", "0.0,0.3,0.0,-1.2,0.0,0.6,0.0")     # the iiwa-shelf start
    since = time.monotonic()
    pipeline = Pipeline(scene="iiwa-shelf", name="iiwa-ros-drive", output=tmp_path / "out",
                        planner={"name": "waypoints", "waypoints": [[0.4, 0.45, 0.0, -1.1, 0.0, 0.75, 0.0]]},
                        simulator={"name": "kinematic", "noise": "none", "joint_velocity_limits": [1.0] * 7},
                        controller={"name": "contact", "gain": 1.5, "tolerance": 0.05},
                        execution={"period": 0.05, "time_limit": 30.0,
                                   "world": {"name": "iiwa-ros", "master_uri": master.uri, "state_timeout": 0.25}})
    result = pipeline.run(write=False)
    assert result.execution.success and result.execution.world == "iiwa-ros"
    goal = np.array([0.8, 0.6, 0.0, -1.0, 0.0, 0.9, 0.0])
    np.testing.assert_allclose(result.execution.configurations[-1], goal, atol=0.15)
    rest = assert_at_rest(peer)
    np.testing.assert_allclose(rest, result.execution.configurations[-1], atol=0.005)
    assert_within_limits(commands_since(peer, since), load_limits(limits_file("iiwa")), tolerance=1e-6)


def test_the_pr2_run_stop_stops_the_arm_and_reset_motors_brings_it_back(make_peer, make_driver):
    """The PR2's run-stop (/power_board/state) and halted motors (/pr2_ethercat/motors_halted) are read: a run-stop
    mid-motion stops the stream; resetting is refused while it is pressed; after its release the motors stay halted
    (RobotDisabled) until --enable calls reset_motors, and the arm moves again.

    The two topics come over separate connections, so the driver may see the motors halt before the power board
    reports the run-stop (so on a real PR2): the stream then stops with RobotDisabled ("motors halted"), and the
    status names the run-stop once the power board's message is in."""
    peer = make_peer("pr2", "right", "--physics-rate", "250")
    rng = np.random.default_rng(7)
    driver = make_driver("pr2-ros")
    with driver:
        assert wait_until(lambda: driver.robot_status().detail == "ready", 5.0), driver.robot_status()
        q0 = driver.state()
        target = reachable_target(q0, driver.limits, rng, 0.4, 0.6)
        start_motion(driver, target)
        peer.fault("estop")
        with pytest.raises((EmergencyStop, RobotDisabled), match=r"run-stop pressed|motors halted"):
            driver.move_to(target)
        assert wait_until(lambda: driver.robot_status().estop, 5.0), driver.robot_status()
        assert "run-stop pressed" in driver.robot_status().detail
    with pytest.raises(EmergencyStop, match="run-stop pressed"):
        driver.check(enable=True)                       # the driver does not reset while the run-stop is pressed
    peer.fault("clear")                                 # released: the motors stay halted
    with pytest.raises(RobotDisabled, match="motors halted"):
        driver.check()
    report = driver.check(enable=True)                  # reset_motors
    assert report["enabled"] and report["detail"] == "ready"
    with driver:
        back = driver.move_to(q0)
    np.testing.assert_allclose(back, q0, atol=driver.options.reach_tolerance)
    events = [r["event"] for r in peer.records() if r["kind"] == "event"]
    assert any(e.startswith("enabled (reset_motors)") for e in events)


def test_a_simulated_pr2_without_a_power_board_runs_with_robot_state_off(make_peer, make_driver):
    make_peer("pr2", "left", "--simulator", "none")
    driver = make_driver("pr2-ros", side="left", robot_state=False)
    report = driver.check()
    assert report["enabled"] and "not read" in report["detail"]
