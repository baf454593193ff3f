"""ruckig smoothing: limits respected, targets blend, stops planned before position limits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import SmoothingError
from pliant.hardware.smoothing import OnlineSmoother


def _run(smoother, cycles):
    out = [smoother.update() for _ in range(cycles)]
    return np.array([o[0] for o in out]), np.array([o[1] for o in out]), np.array([o[2] for o in out])


def _within(limits, p, v, a):
    tol = 1e-6
    assert np.all(p >= limits.command_lower - tol) and np.all(p <= limits.command_upper + tol)
    assert np.all(np.abs(v) <= limits.velocity + tol)
    assert np.all(np.abs(a) <= limits.acceleration + tol)


def test_reaches_the_target_within_limits(limits):
    s = OnlineSmoother(limits)
    s.reset(np.zeros(3))
    s.set_target([0.5, -1.0, 1.0])
    p, v, a = _run(s, 2000)
    _within(limits, p, v, a)
    np.testing.assert_allclose(p[-1], [0.5, -1.0, 1.0])
    assert s.finished and s.at_rest


def test_a_new_target_mid_motion_blends_without_stopping(limits):
    s = OnlineSmoother(limits)
    s.reset(np.zeros(3))
    s.set_target([0.9, 0, 0])
    _, v1, _ = _run(s, 100)
    assert v1[-1, 0] > 0.5
    s.set_target([-0.9, 0, 0])
    p2, v2, _ = _run(s, 1000)
    speeds = np.concatenate([v1[:, 0], v2[:, 0]])
    # the velocity changes continuously (bounded by the acceleration limit per cycle): no jump to zero
    assert np.all(np.abs(np.diff(speeds)) <= limits.acceleration[0] * limits.period + 1e-9)
    np.testing.assert_allclose(p2[-1, 0], -0.9)


@settings(max_examples=40)
@given(st.floats(0.2, 1.0), st.floats(0.0, 0.95))
def test_a_velocity_target_near_a_limit_stops_before_it(limits, speed, start):
    s = OnlineSmoother(limits)
    s.reset(np.array([start, 0, 0]))
    s.set_target([0.95, 0, 0], [speed, 0, 0])          # arrive at the edge with speed: would pass it
    p, v, a = _run(s, 600)
    _within(limits, p, v, a)
    assert s.braking and s.brake_reason == "position limit"


def test_an_overshooting_trajectory_brakes_instead(limits):
    s = OnlineSmoother(limits)
    s.reset(np.array([-0.9, 0, 0]))
    s.set_target([0.9, 0, 0])
    _run(s, 150)                                        # moving fast toward +0.95
    s.set_target([0.94, 0, 0])                         # close target: time-optimal would overshoot
    p, v, a = _run(s, 600)
    _within(limits, p, v, a)


def test_ruckig_errors_become_smoothing_errors(limits):
    s = OnlineSmoother(limits)
    s.reset(np.zeros(3))
    s.set_target([np.nan, 0, 0])
    with pytest.raises(SmoothingError, match="ruckig"):
        s.update()


def test_brake_decelerates_within_limits(limits):
    s = OnlineSmoother(limits)
    s.reset(np.zeros(3))
    s.set_target([0.9, 1.9, 1.4])
    _run(s, 60)
    s.brake()
    p, v, a = _run(s, 300)
    _within(limits, p, v, a)
    assert s.at_rest
    assert np.all(np.abs(np.diff(v, axis=0)) <= limits.acceleration * limits.period + 1e-9)


def test_a_one_off_ruckig_failure_on_a_valid_target_is_retried_once(limits):
    """ruckig 0.19 fails on some valid moves from rest ("error in step 1"); the same motion to a target 1e-9 rad
    away plans.  A second failure is real and raises."""
    import ruckig

    s = OnlineSmoother(limits)
    s.reset(np.zeros(3))
    s.set_target([0.3, 0.2, 0.1])
    real = s._otg
    calls = []

    class FailsOnce:
        def update(self, inp, out):
            calls.append(list(inp.target_position))
            if len(calls) == 1:
                raise ruckig.RuckigError("[ruckig] error in step 1, dof: 0 input: ...")
            return real.update(inp, out)

    s._otg = FailsOnce()
    p, _, _ = _run(s, 400)
    assert len(calls) > 2 and calls[1][0] == pytest.approx(0.3 + 1e-9, abs=1e-12)
    np.testing.assert_allclose(p[-1], [0.3, 0.2, 0.1], atol=1e-8)

    class AlwaysFails:
        def update(self, inp, out):
            raise ruckig.RuckigError("[ruckig] error in step 1")

    s.set_target([0.0, 0.0, 0.0])
    s._otg = AlwaysFails()
    with pytest.raises(SmoothingError):
        s.update()
