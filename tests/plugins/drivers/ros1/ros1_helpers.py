"""Helpers of the ROS 1 driver tests (waiting, targets, checking a peer's record against the limits)."""

from __future__ import annotations

import shutil
import time

import numpy as np
import pytest

try:
    import rospy  # noqa: F401
except ImportError:
    HAVE_ROSPY = False
else:
    HAVE_ROSPY = True
HAVE_ROSMASTER = shutil.which("rosmaster") is not None


def need_ros() -> None:
    """Skip the calling test when ROS 1 is not installed."""
    if not HAVE_ROSPY:
        pytest.skip("ROS 1 is not installed: no rospy (Debian: python3-rospy)")
    if not HAVE_ROSMASTER:
        pytest.skip("ROS 1 is not installed: no rosmaster (Debian: ros-core)")


def unique_fault_topic() -> str:
    """A fault topic of one peer only (every peer of a master would otherwise hear every switch)."""
    unique_fault_topic.count = getattr(unique_fault_topic, "count", 0) + 1
    return f"/pliant_peer/test_{unique_fault_topic.count}/fault"


def wait_until(condition, timeout: float = 5.0, period: float = 0.01) -> bool:
    """Poll ``condition()`` until it holds or ``timeout`` s have passed."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(period)
    return True


def reachable_target(q, limits, rng, low: float = 0.25, high: float = 0.45) -> np.ndarray:
    """A target ``low``..``high`` rad from ``q`` per joint (seeded ``rng``), toward the farther position limit."""
    room_up = limits.command_upper - 0.05 - q
    room_down = q - (limits.command_lower + 0.05)
    sign = np.where(room_up >= room_down, 1.0, -1.0)
    step = rng.uniform(low, high, size=len(q))
    return q + sign * np.minimum(step, np.maximum(room_up, room_down))


def commands_since(peer, since: float) -> list[dict]:
    """The peer's command and state records from monotonic time ``since`` on (clocks agree across processes)."""
    return [r for r in peer.records() if r["t"] >= since]


def assert_within_limits(records: list[dict], limits, tolerance: float = 1e-6) -> int:
    """Every command in ``records`` respects ``limits``; returns how many commands there were."""
    from pliant_ros1.testing.record import command_violations

    violations = command_violations(records, limits, tolerance=tolerance)
    assert not violations, f"{len(violations)} commands broke a limit: {violations[:5]}"
    count = sum(1 for r in records if r["kind"] == "command")
    assert count > 0, "the peer received no command"
    return count


def assert_at_rest(peer, settle: float = 0.4, speed: float = 1e-3) -> np.ndarray:
    """After ``settle`` s the peer's arm stands still (its recorded velocities); returns its positions."""
    time.sleep(settle)
    states = [r for r in peer.records() if r["kind"] == "state"][-5:]
    assert states, "the peer recorded no state"
    fastest = max(float(np.max(np.abs(r["velocities"]))) for r in states)
    assert fastest < speed, f"the arm still moves at {fastest:.4f} rad/s"
    return np.array(states[-1]["positions"])


def start_motion(driver, target, timeout: float = 2.0) -> None:
    """``move_to(target)`` without waiting, then wait until the measured arm moves (faster than 0.05 rad/s)."""
    driver.move_to(target, wait=False)
    if not wait_until(lambda: np.max(np.abs(driver.measured().velocities)) > 0.05, timeout=timeout):
        session = driver.session
        measured = driver.measured()
        last = np.round(session.log[-1][1], 3).tolist() if session.log else None
        q, v = np.round(measured.positions, 3).tolist(), np.round(measured.velocities, 3).tolist()
        raise AssertionError(f"the arm does not move toward {np.round(target, 3).tolist()}: measured {q} at {v} "
                             f"rad/s; {len(session.log)} commands written, the last {last}; {session.overruns} late "
                             "cycles")
