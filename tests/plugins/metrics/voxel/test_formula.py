"""Thesis eq. 3.1 by hand."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pliant_voxel.formula import compress_table, cost_tables, deformation_cost


def test_hard_robot_on_soft_environment_costs_the_environment_sensitivity():
    # D_A = 0: only the soft environment voxel contributes: 0/(0+0.5)*1 + 0.5/0.5*0.3 = 0.3
    assert deformation_cost(0.0, 1.0, 0.5, 0.3) == pytest.approx(0.3)


def test_soft_robot_on_hard_environment_costs_the_robot_sensitivity():
    assert deformation_cost(0.4, 0.7, 0.0, 5.0) == pytest.approx(0.7)


def test_equal_deformability_averages_the_sensitivities():
    assert deformation_cost(0.5, 0.2, 0.5, 0.6) == pytest.approx(0.4)


def test_unequal_deformability_weights_the_softer_more():
    # 0.25/(0.25+0.75)*1 + 0.75/1.0*2 = 0.25 + 1.5
    assert deformation_cost(0.25, 1.0, 0.75, 2.0) == pytest.approx(1.75)


def test_rigid_on_rigid_is_nan():
    assert math.isnan(deformation_cost(0.0, 1.0, 0.0, 1.0))


def test_nan_sensitivity_is_forbidden():
    assert math.isnan(deformation_cost(0.5, 1.0, 0.5, np.nan))


@given(st.floats(0, 1), st.floats(0, 10), st.floats(0, 1), st.floats(0, 10))
def test_cost_lies_between_the_sensitivities(da, sa, db, sb):
    c = deformation_cost(da, sa, db, sb)
    if da + db == 0:
        assert math.isnan(c)
    else:
        assert min(sa, sb) - 1e-9 <= c <= max(sa, sb) + 1e-9


def test_tables_free_space_is_zero_and_outside_is_nan():
    occ = np.array([[[True, False]]])
    classes, table = cost_tables(np.array([[0.0, 1.0], [0.5, 0.5], [0.0, 1.0]]), np.array([[[0.5, 1.0]]]),
                                 np.array([[[0.3, 0.0]]]), occ)
    assert classes.tolist() == [0, 1, 0]
    assert table.shape == (2, 3)
    assert table[0, 0] == pytest.approx(0.3) and table[0, 1] == 0.0 and math.isnan(table[0, 2])
    assert table[1, 0] == pytest.approx(0.4)


def test_subnormal_deformability_keeps_the_cost_between_the_sensitivities():
    assert deformation_cost(5e-324, 0.75, 0.0, 0.0) == pytest.approx(0.75)


@given(st.integers(1, 3), st.integers(1, 40), st.integers(0, 2**32 - 1))
def test_compress_table_reproduces_every_column(classes, columns, seed):
    """``lut[:, materials]`` is the table again, NaN where it was NaN, with as many ids as distinct columns."""
    rng = np.random.default_rng(seed)
    distinct = rng.choice([0.0, 0.25, 1.0, np.nan], size=(classes, 4))
    table = distinct[:, rng.integers(0, 4, size=columns)]
    materials, lut = compress_table(table)
    assert materials.dtype == np.uint8 and materials.shape == (columns,)
    np.testing.assert_array_equal(lut[:, materials], table)          # NaN == NaN for assert_array_equal
    assert lut.shape[1] == len({tuple(np.nan_to_num(c, nan=-1.0)) for c in table.T})


def test_compress_table_widens_the_ids_beyond_256_materials():
    table = np.arange(300.0)[None]
    materials, lut = compress_table(table)
    assert materials.dtype == np.uint16
    np.testing.assert_array_equal(lut[:, materials], table)
