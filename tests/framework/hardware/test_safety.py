"""The safety layer refuses what breaks a limit and names the joint, value and limit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pliant.errors import (
    DriveFault,
    EmergencyStop,
    JointMismatch,
    LimitViolation,
    NonFiniteCommand,
    RobotDisabled,
    StaleState,
    StateError,
    StepTooLarge,
)
from pliant.hardware.safety import SafetyLayer, state_jump
from pliant.hardware.state import JointState, RobotStatus


def test_commands_inside_the_limits_pass(limits):
    layer = SafetyLayer(limits)
    layer.begin(np.zeros(3))
    layer.check_command([0.004, 0.0, -0.002], [0.5, 0.0, -0.4], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(layer.last_positions, [0.004, 0.0, -0.002])


@pytest.mark.parametrize(("positions", "velocities", "error", "joint"), [
    ([np.nan, 0, 0], [0, 0, 0], NonFiniteCommand, "a"),
    ([0, 0, 0], [0, np.inf, 0], NonFiniteCommand, "b"),
    ([0, 0, -0.46], [0, 0, 0], LimitViolation, "c"),     # inside the hard limit, outside the margin
    ([0, 0, 0], [0, 0, 0.6], LimitViolation, "c"),
    ([0.007, 0, 0], [0, 0, 0], StepTooLarge, "a"),       # max step a = 1.2 * 1.0 / 200 = 0.006
])
def test_a_bad_command_is_refused_naming_the_joint(limits, positions, velocities, error, joint):
    layer = SafetyLayer(limits)
    layer.begin(np.zeros(3))
    with pytest.raises(error) as info:
        layer.check_command(positions, velocities)
    assert info.value.joint == joint and f"joint {joint}" in str(info.value)
    np.testing.assert_array_equal(layer.last_positions, np.zeros(3))   # a refused command is not remembered


def test_acceleration_limit(limits):
    layer = SafetyLayer(limits)
    with pytest.raises(LimitViolation, match="acceleration") as info:
        layer.check_command([0, 0, 0], [0, 0, 0], [0, 8.5, 0])
    assert info.value.limit == [-8.0, 8.0]


@given(st.lists(st.floats(-3, 3), min_size=3, max_size=3))
def test_targets_are_checked_against_the_commanded_range(limits, values):
    layer = SafetyLayer(limits)
    values = np.array(values)
    inside = np.all((values >= limits.command_lower) & (values <= limits.command_upper))
    if inside:
        position, velocity = layer.check_target(values)
        np.testing.assert_array_equal(position, values)
        assert not velocity.any()
    else:
        with pytest.raises(LimitViolation):
            layer.check_target(values)


def _state(names, positions, stamp, received, sequence=1, velocities=None):
    return JointState(tuple(names), np.asarray(positions, dtype=float), velocities, stamp, received, sequence)


def test_states_are_mapped_by_name(limits):
    layer = SafetyLayer(limits)
    names = ["head", "c", "x", "a", "b"]
    positions, velocities = layer.read_state(_state(names, [9, 0.3, 8, 0.1, 0.2], 1.0, 10.0), 10.0)
    np.testing.assert_allclose(positions, [0.1, 0.2, 0.3])
    positions, velocities = layer.read_state(_state(names, [9, 0.4, 8, 0.1, 0.2], 1.1, 10.1, 2), 10.1)
    np.testing.assert_allclose(velocities, [0, 0, 1.0])     # estimated from the stamps when not reported


@pytest.mark.parametrize(("names", "match"), [(["a", "b"], "joint c"), (["a", "b", "c", "a"], "twice")])
def test_missing_or_repeated_joints(limits, names, match):
    with pytest.raises(JointMismatch, match=match):
        SafetyLayer(limits).read_state(_state(names, np.zeros(len(names)), 1.0, 1.0), 1.0)


def test_stamps_backwards_or_repeated_with_new_values(limits):
    layer = SafetyLayer(limits)
    layer.read_state(_state("abc", [0, 0, 0], 2.0, 1.0, 1), 1.0)
    layer.read_state(_state("abc", [0, 0, 0], 2.0, 1.001, 2), 1.001)     # an exact repeat is ignored
    with pytest.raises(StateError, match="same time stamp"):
        layer.read_state(_state("abc", [0.1, 0, 0], 2.0, 1.002, 3), 1.002)
    with pytest.raises(StateError, match="backwards"):
        layer.read_state(_state("abc", [0, 0, 0], 1.5, 1.003, 4), 1.003)


def test_a_jump_is_a_move_beyond_what_the_velocity_limits_allow_between_two_stamps():
    """Twice the velocity limit over the stamps' interval (at least 50 ms: stamps jitter) plus 0.02 rad."""
    velocity = np.array([1.0, 2.0])
    assert state_jump([0, 0], [0.119, -0.219], 0.01, velocity) is None              # 2 x 0.05 s x v + 0.02
    assert state_jump([0, 0], [0.379, 0.0], 0.18, velocity) is None                 # 2 x 0.18 s x 1 + 0.02
    assert state_jump([0, 0], [0.381, 0.0], 0.18, velocity) == (0, pytest.approx(0.38))
    assert state_jump([0, 0], [0.0, -0.5], 0.01, velocity) == (1, pytest.approx(0.22))
    assert state_jump([0, 0], [np.nan, 0.0], 0.01, velocity) is not None


def test_joint_states_that_jump_are_refused_naming_the_joint(limits):
    layer = SafetyLayer(limits)                                  # velocity limits a 1, b 2, c 0.5 rad/s
    layer.read_state(_state("abc", [0, 0, 0], 1.0, 5.0, 1), 5.0)
    layer.read_state(_state("abc", [0.1, 0.2, 0.05], 1.01, 5.01, 2), 5.01)   # within 2 x 0.05 s x v + 0.02
    layer.read_state(_state("abc", [0.6, 0.2, 0.05], 1.25, 5.25, 3), 5.25)   # 0.5 rad in 0.24 s: 0.5 <= 0.5
    with pytest.raises(StateError, match=r"jump: moved \+0.13 rad in 0.01 s") as caught:
        layer.read_state(_state("abc", [0.6, 0.2, 0.18], 1.26, 5.26, 4), 5.26)  # c: 0.13 > 2 x 0.05 x 0.5 + 0.02
    assert caught.value.joint == "c"


def test_watchdog_and_flood(limits):
    layer = SafetyLayer(limits)
    layer.read_state(_state("abc", [0, 0, 0], 1.0, 5.0), 5.0)
    with pytest.raises(StaleState, match="watchdog"):
        layer.read_state(_state("abc", [0, 0, 0], 1.0, 5.0), 5.2)
    flood = SafetyLayer(limits)
    with pytest.raises(StateError, match="flood"):
        for k in range(1, 6000):
            t = k * 1e-4                               # 10 kHz, limit 5 kHz
            flood.read_state(_state("abc", [0, 0, 0], t, t, k), t)


@pytest.mark.parametrize(("status", "error"), [(RobotStatus(enabled=False), RobotDisabled),
                                               (RobotStatus(estop=True), EmergencyStop),
                                               (RobotStatus(fault="overcurrent"), DriveFault)])
def test_status(status, error):
    with pytest.raises(error):
        SafetyLayer.check_status(status)
    SafetyLayer.check_status(RobotStatus())
