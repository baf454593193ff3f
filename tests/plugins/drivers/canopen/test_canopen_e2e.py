"""End to end: the core's command stream (ruckig, safety layer, watchdogs) drives the emulated CiA 402 arm over the
virtual CAN bus.  Every test ends by checking every target position the drives received against the limits."""

from __future__ import annotations

import time

import numpy as np
import pytest
from pliant.errors import ConnectionLost, DriveFault, RobotDisabled
from pliant_canopen.cia402 import DriveState

Q = np.array([0.3, -0.25, 0.2, -0.4, 0.15, 0.3, -0.2])


def assert_targets_within_limits(peer, limits):
    """Every target the drives received: inside [lower + margin, upper - margin], no step per SYNC larger than
    the step limit (plus one count of rounding), no velocity offset beyond the velocity limit."""
    _, joints, positions = peer.targets_in_radians()
    assert len(positions) > 0
    slack = 1e-6 + 1.0 / np.array([j.counts_per_radian for j in peer.joint_map.joints])
    lower = limits.command_lower[joints] - slack[joints]
    upper = limits.command_upper[joints] + slack[joints]
    bad = np.flatnonzero((positions < lower) | (positions > upper))
    assert bad.size == 0, f"targets outside the limits: joints {joints[bad][:5]}, values {positions[bad][:5]}"
    for j in range(limits.dof):
        steps = np.abs(np.diff(positions[joints == j]))
        assert steps.size == 0 or steps.max() <= limits.max_step[j] + 2 * slack[j], \
            f"joint {limits.names[j]}: a step of {steps.max():.5f} rad > {limits.max_step[j]:.5f}"
    factors = np.array([j.velocity_factor for j in peer.joint_map.joints])
    records = list(peer.targets)
    index = {n: i for i, n in enumerate(peer.joint_map.nodes)}
    for _, node, _, units in records:
        i = index[node]
        assert abs(units) / factors[i] <= limits.velocity[i] * (1 + 1e-6) + 1.0 / factors[i]


def _start_motion(driver, target):
    driver.move_to(target, wait=False)
    time.sleep(0.3)
    assert np.any(np.abs(driver.measured().velocities) > 0.05)      # it is moving


def test_move_to_reaches_the_target_within_the_limits(make_peer, make_driver):
    peer = make_peer()
    driver = make_driver()
    with driver:
        assert driver.robot_status().enabled
        reached = driver.move_to(Q)
        np.testing.assert_allclose(reached, Q, atol=driver.options.reach_tolerance)
        np.testing.assert_allclose(peer.positions(), Q, atol=driver.options.reach_tolerance)
        back = driver.move_to(np.zeros(7))
        np.testing.assert_allclose(back, 0.0, atol=driver.options.reach_tolerance)
        log = list(driver.session.log)
    assert_targets_within_limits(peer, driver.limits)
    # each command of the stream went out as one RPDO set + SYNC: the peer saw as many targets per joint as writes
    per_joint = sum(1 for t in peer.targets if t[1] == 1)
    assert per_joint >= len(log)
    assert all(d.state == DriveState.READY for d in peer.drives.values())     # disabled on leaving


def test_a_drive_fault_mid_motion_stops_the_arm_with_a_clear_error(make_peer, make_driver):
    peer = make_peer()
    driver = make_driver()
    with driver:
        _start_motion(driver, Q)
        peer.fault(4, code=0x2310)
        with pytest.raises(DriveFault) as info:
            driver.move_to(Q)
        assert "node 4 (lbr_iiwa_joint_4)" in str(info.value) and "0x2310" in str(info.value)
        stopped = driver.stop()
        assert max(abs(d.velocity) / d.joint.counts_per_radian for d in peer.drives.values()) < 1e-3   # rad/s
        with pytest.raises(DriveFault):                   # motion stays refused until reconnecting
            driver.move_to(np.zeros(7))
    assert peer.drive(4).state == DriveState.FAULT
    assert not np.allclose(stopped, Q, atol=0.01)         # it stopped on the way
    assert_targets_within_limits(peer, driver.limits)


def test_heartbeat_loss_mid_motion_stops_the_arm_with_a_clear_error(make_peer, make_driver):
    peer = make_peer()
    # 0.3 s: the drives' own consumer of the master's heartbeat gets the same deadline, and at 0.1 s a loaded machine
    # (2 test workers) let every drive fault on a late master heartbeat before node 6's loss was seen
    driver = make_driver(heartbeat_timeout=0.3)
    with driver:
        _start_motion(driver, Q)
        peer.drop_heartbeat(6)
        with pytest.raises(ConnectionLost) as info:
            driver.move_to(Q)
        assert "node 6 (lbr_iiwa_joint_6): heartbeat lost" in str(info.value)
        driver.stop()
    # The driver cannot reach node 6, so it leaves it enabled; once the master's heartbeat stops on shutdown, the
    # drive's own heartbeat consumer (0x1016, the same 0.3 s) faults it with EMCY 0x8130, a race with this line.
    # Either way it was never disabled by the driver, and it came to rest.
    drive = peer.drive(6)
    assert drive.state in (DriveState.OPERATION_ENABLED, DriveState.FAULT)
    if drive.state == DriveState.FAULT:
        assert drive.emcy_sent[-1] == 0x8130                       # master heartbeat lost, not another fault
    assert abs(drive.velocity) < 1.0                               # counts/s
    assert_targets_within_limits(peer, driver.limits)


def test_a_frame_of_the_wrong_length_mid_motion_stops_the_arm_with_a_clear_error(make_peer, make_driver):
    peer = make_peer()
    driver = make_driver()
    with driver:
        _start_motion(driver, Q)
        peer.short_frame(2, tpdo=2, size=3)
        with pytest.raises(ConnectionLost) as info:
            driver.move_to(Q)
        assert "node 2 (lbr_iiwa_joint_2): TPDO2 (COB-ID 0x282) carried 3 bytes, its mapping has 5" in str(info.value)
        driver.stop()
    velocities = [abs(d.velocity) for d in peer.drives.values()]
    assert max(velocities) < 1.0
    assert_targets_within_limits(peer, driver.limits)


def test_a_drive_that_does_not_enable_refuses_the_connection_and_nothing_moves(make_peer, make_driver):
    peer = make_peer()
    peer.refuse_enable(5)
    driver = make_driver(enable_timeout=0.2)
    with pytest.raises(RobotDisabled, match=r"node 5 \(lbr_iiwa_joint_5\).*Ready to switch on"):
        with driver:
            driver.move_to(Q)                               # never reached
    assert np.allclose(peer.positions(), 0.0)
    assert {t[2] for t in peer.targets if t[1] == 5} == {0}  # only the hold position was ever sent
    assert all(d.state != DriveState.OPERATION_ENABLED for d in peer.drives.values())   # disabled again


def test_a_streamed_target_blends_and_the_speed_scale_holds(make_peer, make_driver):
    peer = make_peer()
    driver = make_driver(speed_scale=0.5)
    with driver:
        for k in range(1, 51):                       # a target moving at 0.1 x the velocity limits
            driver.stream(Q * 0.02 * k)
            time.sleep(0.01)
        reached = driver.move_to(Q)
        np.testing.assert_allclose(reached, Q, atol=driver.options.reach_tolerance)
    # driver.limits are the scaled ones (half the velocity, a quarter of the acceleration): the check below holds
    # every target to them
    assert driver.limits.velocity[0] == pytest.approx(0.5 * np.radians(98))
    assert_targets_within_limits(peer, driver.limits)


def test_the_driver_fits_the_iiwa_robot_model_of_a_pipeline(make_driver):
    from pliant import load_scene, registry
    from pliant.interfaces import Context

    ctx = Context(scene=load_scene("iiwa-shelf"))
    ctx.robot = registry.create("robot", "pinocchio", ctx)
    driver = make_driver()
    driver.bind(ctx)                      # same joints, same order as the URDF robot plans
    assert driver.joint_names() == tuple(ctx.robot.urdf_description().joint_names)


@pytest.mark.slow
def test_a_pipeline_executes_on_the_can_arm_by_one_setting(make_peer, channel, tmp_path):
    from pliant import Pipeline

    peer = make_peer()
    pipeline = Pipeline(scene="iiwa-shelf", name="iiwa-canopen", output=tmp_path / "out",
                        planner={"name": "waypoints", "waypoints": [[0.4, 0.45, 0.0, -1.1, 0.0, 0.75, 0.0]]},
                        controller={"name": "contact", "gain": 4.0, "tolerance": 0.05},
                        execution={"period": 0.05, "time_limit": 30.0,
                                   "world": {"name": "canopen", "channel": channel,
                                             "state_timeout": 0.5}})      # the fixture's: a loaded CI machine
    record = pipeline.run(write=False)
    assert record.execution.success and record.execution.world == "canopen"
    # the arm decelerates within its (conservative) limits after the last command; the record ends at rest
    np.testing.assert_allclose(peer.positions(), record.execution.configurations[-1], atol=0.005)
    assert_targets_within_limits(peer, peer.limits)
