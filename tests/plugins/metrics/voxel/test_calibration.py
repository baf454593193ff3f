"""Calibration of planner cost to measured deformation (thesis 3.3.2) on synthetic data."""

import numpy as np
import pytest
from pliant.errors import DimensionError
from pliant_voxel.calibration import fit_calibration


def test_exact_scale_is_recovered_with_zero_error():
    rng = np.random.default_rng(0)
    planned = [rng.uniform(0, 5, 30), rng.uniform(0, 5, 40)]
    measured = [33.9 * p for p in planned]
    cal = fit_calibration(planned, measured)
    assert cal.scale == pytest.approx(33.9)
    assert cal.least_squares_scale == pytest.approx(33.9) and cal.total_scale == pytest.approx(33.9)
    assert np.allclose(cal.path_errors, 0.0)
    assert np.allclose(cal.apply([1.0, 2.0]), [33.9, 67.8])


def test_noisy_measurements_give_the_thesis_style_errors():
    planned = [np.array([1.0, 2.0, 0.0]), np.array([2.0, 2.0])]
    measured = [np.array([2.0, 4.4, 0.5]), np.array([3.6, 4.4])]
    cal = fit_calibration(planned, measured)
    # ratios over points with planned > 0: 2.0, 2.2, 1.8, 2.2 -> mean 2.05
    assert cal.scale == pytest.approx(2.05)
    assert cal.path_errors[0] == pytest.approx(abs(2.05 * 3 - 6.9) / 6.9)
    assert cal.path_errors[1] == pytest.approx(abs(2.05 * 4 - 8.0) / 8.0)
    assert cal.mean_error == pytest.approx(cal.path_errors.mean())
    # the ratio of totals makes the mean calibrated path cost equal the mean measured one
    assert cal.total_scale == pytest.approx((6.9 + 8.0) / 7.0)
    assert np.mean([cal.total_scale * p.sum() for p in planned]) == pytest.approx(np.mean([6.9, 8.0]))


def test_bad_input_names_the_path():
    with pytest.raises(DimensionError, match=r"path\[1\]"):
        fit_calibration([np.ones(3), np.ones(3)], [np.ones(3), np.ones(2)])
    with pytest.raises(DimensionError):
        fit_calibration([np.zeros(3)], [np.ones(3)])


def test_a_power_law_of_path_totals_is_recovered():
    rng = np.random.default_rng(1)
    planned = [rng.uniform(0, 5, n) for n in (10, 20, 40, 80)]
    measured = [np.full(len(p), 2e-3 * p.sum() ** 0.5 / len(p)) for p in planned]   # sub-linear in the total
    cal = fit_calibration(planned, measured)
    assert cal.power_exponent == pytest.approx(0.5) and cal.power_factor == pytest.approx(2e-3)
    totals = np.array([p.sum() for p in planned])
    assert np.allclose(cal.apply_path(totals), [m.sum() for m in measured])
    # a single scale cannot fit it: the ratio of totals leaves an error on some path
    assert max(abs(cal.total_scale * t - m.sum()) / m.sum() for t, m in zip(totals, measured)) > 0.2


def test_without_two_distinct_totals_there_is_no_power_law():
    cal = fit_calibration([np.ones(3)], [2 * np.ones(3)])
    assert np.isnan(cal.power_exponent)
    assert cal.apply_path(3.0) == pytest.approx(cal.total_scale * 3.0)
