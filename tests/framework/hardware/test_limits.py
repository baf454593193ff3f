"""Limits files: every field checked, errors name the field; scaling and selection."""

from __future__ import annotations

import numpy as np
import pytest
from pliant.errors import ConfigError, JointMismatch
from pliant.hardware.limits import load_limits


def test_loads_the_file(limits):
    assert limits.names == ("a", "b", "c")
    assert limits.command_rate == 200.0 and limits.period == pytest.approx(0.005)
    np.testing.assert_allclose(limits.command_lower, [-0.95, -1.95, -0.45])
    np.testing.assert_allclose(limits.max_step, 1.2 * np.array([1.0, 2.0, 0.5]) / 200.0)


@pytest.mark.parametrize(("old", "new", "field"), [
    ('velocity = 2.0', 'velocity = -2.0', "joints[1].velocity"),
    ('upper = 1.5', 'upper = -0.45', "c.upper"),
    ('sources = ["made up for tests"]', 'sources = []', "sources"),
    ('command_rate = 200.0', 'command_rate = "fast"', "command_rate"),
    ('name = "c"', 'name = "a"', "joints"),
    ('jerk = 20.0', 'jerk = 20.0\nspeed = 3', "joints[2].speed"),
])
def test_bad_fields_are_named(tmp_path, limits_file, old, new, field):
    path = tmp_path / "bad.toml"
    path.write_text(limits_file.read_text().replace(old, new))
    with pytest.raises(ConfigError) as info:
        load_limits(path)
    assert field in str(info.value) and str(path) in str(info.value)


def test_scaling_slows_the_same_motion(limits):
    slow = limits.scaled(0.5)
    np.testing.assert_allclose(slow.velocity, limits.velocity * 0.5)
    np.testing.assert_allclose(slow.acceleration, limits.acceleration * 0.25)
    np.testing.assert_allclose(slow.jerk, limits.jerk * 0.125)
    with pytest.raises(ConfigError, match="speed_scale"):
        limits.scaled(1.5)


def test_select_reorders_and_names_a_missing_joint(limits):
    picked = limits.select(("c", "a"))
    assert picked.names == ("c", "a")
    np.testing.assert_allclose(picked.upper, [1.5, 1.0])
    with pytest.raises(JointMismatch, match="joint z"):
        limits.select(("a", "z"))
