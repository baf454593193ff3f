"""Footprints and batched collision checks of TS-RRT (poster ICHR 2010, IN_COLLISION) against brute force."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant_tsrrt.geometry import BOX, CIRCLE, CollisionChecker, Footprints, box_corners, extents, pair_overlap


def _inside(points, pose, kind, half):
    """Brute force: which world points lie in a footprint."""
    d = points - pose[:2]
    c, s = np.cos(pose[2]), np.sin(pose[2])
    local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], -1)
    if kind == CIRCLE:
        return np.linalg.norm(local, axis=1) <= half[0]
    return np.all(np.abs(local) <= half, axis=1)


def _brute_overlap(pa, ka, ha, pb, kb, hb, n=120):
    """Sample footprint a densely; any sample inside b means overlap (a lower bound, exact up to the grid)."""
    r = np.hypot(*ha) if ka == BOX else ha[0]
    u = np.linspace(-r, r, n)
    grid = np.stack(np.meshgrid(u, u), -1).reshape(-1, 2) + pa[:2]
    grid = grid[_inside(grid, pa, ka, ha)]
    return bool(_inside(grid, pb, kb, hb).any())


def test_box_corners_of_a_turned_box():
    corners = box_corners(np.array([1.0, 2.0, np.pi / 2]), np.array([0.2, 0.1]))
    expected = np.array([[1.1, 1.8], [1.1, 2.2], [0.9, 2.2], [0.9, 1.8]])
    assert np.allclose(corners, expected)


def test_extents_of_a_box_at_45_degrees_and_a_circle():
    fp = Footprints([BOX, CIRCLE], [[0.1, 0.1], [0.05, 0.05]])
    lo, hi = extents(np.array([[0.5, 0.5, np.pi / 4], [0.2, 0.3, 1.0]]), fp)
    assert np.allclose(hi[0] - lo[0], 2 * 0.1 * np.sqrt(2))
    assert np.allclose(lo[1], [0.15, 0.25]) and np.allclose(hi[1], [0.25, 0.35])


@pytest.mark.parametrize("kinds", [(BOX, BOX), (BOX, CIRCLE), (CIRCLE, BOX), (CIRCLE, CIRCLE)])
def test_pair_overlap_agrees_with_brute_force(kinds):
    rng = np.random.default_rng(7)
    ka, kb = kinds
    disagreements = 0
    for _ in range(150):
        ha = rng.uniform(0.02, 0.12, 2) if ka == BOX else np.full(2, rng.uniform(0.02, 0.1))
        hb = rng.uniform(0.02, 0.12, 2) if kb == BOX else np.full(2, rng.uniform(0.02, 0.1))
        pa = np.array([0.0, 0.0, rng.uniform(-np.pi, np.pi)])
        pb = np.array([*rng.uniform(-0.25, 0.25, 2), rng.uniform(-np.pi, np.pi)])
        fast = pair_overlap(pa[None, None], Footprints([ka], [ha]), pb[None, None], Footprints([kb], [hb]))[0, 0]
        slow = _brute_overlap(pa, ka, ha, pb, kb, hb)
        if fast != slow:
            # the grid can miss a sliver of overlap; never the other way round by more than a grid cell
            assert fast and not slow
            disagreements += 1
    assert disagreements <= 3


@settings(max_examples=60, deadline=None)
@given(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-3.1, 3.1), st.floats(-3.1, 3.1),
       st.floats(0.02, 0.1), st.floats(0.02, 0.1))
def test_overlap_is_symmetric_and_moves_with_the_pair(x, y, ta, tb, hx, hy):
    fa = Footprints([BOX], [[hx, hy]])
    fb = Footprints([BOX], [[hy, 0.05]])
    pa = np.array([[[0.0, 0.0, ta]]])
    pb = np.array([[[x, y, tb]]])
    ab = pair_overlap(pa, fa, pb, fb)[0, 0]
    assert ab == pair_overlap(pb, fb, pa, fa)[0, 0]
    shift = np.array([0.7, -0.2, 0.0])
    assert ab == pair_overlap(pa + shift, fa, pb + shift, fb)[0, 0]


def test_checker_sees_overlaps_obstacles_and_the_table_edge():
    fp = Footprints([BOX, CIRCLE], [[0.1, 0.05], [0.05, 0.05]])
    obs = Footprints([BOX], [[0.05, 0.05]])
    checker = CollisionChecker(fp, obs, np.array([[0.8, 0.4, 0.0]]), (0.0, 0.0, 1.0, 0.8), margin=0.0)
    free = np.array([[0.3, 0.4, 0.0], [0.5, 0.4, 0.0]])
    touching = np.array([[0.3, 0.4, 0.0], [0.42, 0.4, 0.0]])
    on_obstacle = np.array([[0.3, 0.4, 0.0], [0.72, 0.4, 0.0]])
    off_table = np.array([[0.05, 0.4, 0.0], [0.5, 0.4, 0.0]])
    assert checker.in_collision(np.stack([free, touching, on_obstacle, off_table])).tolist() == [
        False, True, True, True]
    # the margin inflates every footprint: 0.05 m apart is a collision with a 0.03 m margin
    apart = np.array([[0.3, 0.4, 0.0], [0.5, 0.4, 0.0]])
    from dataclasses import replace

    assert not checker.in_collision(apart)[0]
    assert replace(checker, margin=0.03).in_collision(apart)[0]
