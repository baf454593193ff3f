"""The poster reproduction's measures of the poster's claims (orthonormal orientations, centred arrangement), by
hand on known arrangements; and its declaration (run end to end in tests/e2e/test_reproductions.py)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pliant.experiments.reproduce import reproductions
from pliant_tsrrt.geometry import BOX, CIRCLE, Footprints
from pliant_tsrrt.reproduce import axis_deviation, centre_offset


def test_axis_deviation_is_zero_at_multiples_of_a_quarter_turn_and_ignores_circles():
    poses = np.array([[0.1, 0.2, 0.0], [0.5, 0.5, np.pi / 2], [0.3, 0.3, -np.pi], [0.7, 0.2, 0.6]])
    circular = np.array([False, False, False, True])
    assert axis_deviation(poses, circular) == pytest.approx(0.0, abs=1e-12)


def test_axis_deviation_is_the_largest_angle_to_the_nearest_axis():
    poses = np.array([[0, 0, np.radians(10)], [0, 0, np.radians(80)], [0, 0, np.radians(-100)]])
    # 10 deg off x; 80 deg is 10 off y; -100 is 10 off -y
    assert np.degrees(axis_deviation(poses, np.zeros(3, bool))) == pytest.approx(10.0)
    poses[1, 2] = np.radians(45 + 90)
    assert np.degrees(axis_deviation(poses, np.zeros(3, bool))) == pytest.approx(45.0)


@given(st.floats(-20.0, 20.0), st.integers(-8, 8))
def test_axis_deviation_is_invariant_to_quarter_turns_and_at_most_45_degrees(yaw, turns):
    a = axis_deviation(np.array([[0.0, 0.0, yaw]]), np.array([False]))
    b = axis_deviation(np.array([[0.0, 0.0, yaw + turns * np.pi / 2]]), np.array([False]))
    assert 0.0 <= a <= np.pi / 4 + 1e-12
    assert a == pytest.approx(b, abs=1e-9)


def test_centre_offset_measures_the_bounding_box_of_the_circumscribed_circles():
    fp = Footprints(np.array([CIRCLE, BOX]), np.array([[0.05, 0.05], [0.03, 0.04]]))   # radii 0.05 and 0.05
    table = (0.0, 0.0, 1.0, 0.8)
    centred = np.array([[0.4, 0.4, 0.0], [0.6, 0.4, 1.0]])
    assert centre_offset(centred, fp, table) == pytest.approx(0.0, abs=1e-12)
    shifted = centred + np.array([0.3, -0.4, 0.0])
    assert centre_offset(shifted, fp, table) == pytest.approx(0.5)


def test_the_poster_is_an_available_reproduction_with_a_ci_mode():
    poster = reproductions()["poster"]
    assert poster.plugin == "pliant_tsrrt" and {"ci", "quick", "full"} <= set(poster.modes)
