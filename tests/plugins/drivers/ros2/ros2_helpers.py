"""Helpers of the ROS 2 driver tests."""

from __future__ import annotations

import time

import numpy as np


def wait_until(condition, timeout: float = 10.0, period: float = 0.01) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(period)
    return True


def commands(peer, since: float = 0.0) -> list[dict]:
    return [r for r in peer.records() if r["kind"] == "command" and r["t"] >= since]


def assert_within_limits(peer, limits, since: float = 0.0) -> int:
    """Every command the peer received since ``since`` respects ``limits``; returns how many there were."""
    from pliant_ros2.testing.record import command_violations

    received = commands(peer, since)
    violations = command_violations(received, limits)
    assert not violations, f"{len(violations)} commands broke a limit: {violations[:5]}"
    assert received, "the peer received no command"
    return len(received)


def start_motion(driver, target, timeout: float = 10.0) -> None:
    """``move_to(target)`` without waiting, then wait until the measured arm moves."""
    driver.move_to(target, wait=False)
    assert wait_until(lambda: np.max(np.abs(driver.measured().velocities)) > 0.05, timeout), "the arm does not move"


def at_rest(peer, settle: float = 0.5, speed: float = 1e-3) -> np.ndarray:
    """After ``settle`` s the peer's arm stands still; returns its positions."""
    time.sleep(settle)
    states = [r for r in peer.records() if r["kind"] == "state"][-5:]
    assert states, "the peer recorded no state"
    fastest = max(float(np.max(np.abs(r["velocities"]))) for r in states)
    assert fastest < speed, f"the arm still moves at {fastest:.4f} rad/s"
    return np.array(states[-1]["positions"])
