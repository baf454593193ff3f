"""The task cost terms of TS-RRT (poster ICHR 2010: orthogonality, circumscribed area, distance from the edge; table
setting) by hand on simple arrangements."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant_tsrrt.cost import TaskCost
from pliant_tsrrt.geometry import BOX, CIRCLE, Footprints

TABLE = (0.0, 0.0, 1.0, 0.8)


def test_orthogonality_is_zero_on_the_axes_and_one_at_45_degrees():
    cost = TaskCost(Footprints([BOX, CIRCLE], [[0.1, 0.05], [0.05, 0.05]]), TABLE)
    s = np.array([[[0.3, 0.4, 0.0], [0.7, 0.4, 0.7]], [[0.3, 0.4, np.pi / 2], [0.7, 0.4, 0.0]],
                  [[0.3, 0.4, np.pi / 4], [0.7, 0.4, 0.0]]])
    assert np.allclose(cost.terms(s)[:, 0], [0.0, 0.0, 1.0])        # the circle's yaw never counts


def test_circumscribed_area_of_two_boxes():
    cost = TaskCost(Footprints([BOX, BOX], [[0.1, 0.05], [0.05, 0.05]]), TABLE)
    s = np.array([[0.3, 0.4, 0.0], [0.6, 0.5, 0.0]])
    # x from 0.2 to 0.65, y from 0.35 to 0.55: 0.45 x 0.2 over the table's 0.8 m^2
    assert np.isclose(cost.terms(s)[0, 1], 0.45 * 0.2 / 0.8)


def test_edge_term_by_hand():
    cost = TaskCost(Footprints([CIRCLE], [[0.05, 0.05]]), TABLE)
    # d = min(x - r, 1 - x - r, y - r, 0.8 - y - r); d_ref = 0.4
    s = np.array([[[0.5, 0.4, 0.0]], [[0.2, 0.4, 0.0]], [[0.05, 0.4, 0.0]]])
    assert np.allclose(cost.terms(s)[:, 2], [1 - 0.35 / 0.4, 1 - 0.15 / 0.4, 1.0])


def test_setting_term_by_hand():
    fp = Footprints([CIRCLE, BOX], [[0.1, 0.1], [0.09, 0.015]])
    relations = np.array([[0, -1, 0.3, 0.25], [1, 0, -0.15, 0.0]])
    cost = TaskCost(fp, TABLE, (0.0, 0.0, 0.0, 1.0), relations, setting_scale=0.1)
    s = np.array([[0.3, 0.25, 0.0], [0.1, 0.3, 0.0]])
    # plate on its target; fork at (-0.2, +0.05) from the plate instead of (-0.15, 0): 0.05^2 + 0.05^2 over 0.1^2
    assert np.isclose(cost.cost(s)[0], (0.05 ** 2 + 0.05 ** 2) / 0.01)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.2, 0.8), st.floats(0.2, 0.6), st.floats(-3.0, 3.0))
def test_gradient_of_orthogonality_is_2_sin_4_theta(x, y, theta):
    cost = TaskCost(Footprints([BOX], [[0.1, 0.05]]), TABLE, weights=(1.0, 0.0, 0.0, 0.0))
    g = cost.gradient(np.array([[[x, y, theta]]]))[0, 0]
    assert np.allclose(g, [0.0, 0.0, 2 * np.sin(4 * theta)], atol=1e-5)
