"""A body's points in runs for a broad phase (``point_runs``) and in an order that keeps near points together
(``spatial_order``): invariants checked by brute force on random clouds, and the run counts of a box's surface."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.api import point_runs, spatial_order


@settings(max_examples=40)
@given(st.integers(0, 2**32 - 1), st.integers(1, 200), st.floats(0.01, 0.3), st.integers(1, 40))
def test_runs_cover_the_points_in_order_within_their_radius_and_count(seed, k, radius, most):
    points = np.random.default_rng(seed).uniform(-0.3, 0.3, (k, 3))
    starts, centres, extents, radii = point_runs(points, radius, most)
    assert starts[0] == 0 and starts[-1] == k and np.all(np.diff(starts) >= 1) and np.all(np.diff(starts) <= most)
    for s in range(len(starts) - 1):
        run = points[starts[s]:starts[s + 1]]
        lo, hi = run.min(axis=0), run.max(axis=0)
        np.testing.assert_allclose(centres[s], 0.5 * (lo + hi), atol=1e-15)
        np.testing.assert_allclose(extents[s], 0.5 * (hi - lo), atol=1e-15)
        assert radii[s] == np.max(np.linalg.norm(run - centres[s], axis=1))
        assert len(run) == 1 or 0.5 * np.linalg.norm(hi - lo) <= radius       # a run is cut where it grows too wide
        if starts[s + 1] < k and len(run) < most:                            # ... and only there
            grown = points[starts[s]:starts[s + 1] + 1]
            assert 0.5 * np.linalg.norm(grown.max(axis=0) - grown.min(axis=0)) > radius


@settings(max_examples=30)
@given(st.integers(0, 2**32 - 1), st.integers(0, 300), st.floats(0.005, 0.2))
def test_the_spatial_order_is_a_permutation_that_keeps_each_cell_together(seed, k, radius):
    points = np.random.default_rng(seed).uniform(-0.3, 0.3, (k, 3))
    order = spatial_order(points, radius)
    assert order.dtype == np.int64 and np.array_equal(np.sort(order), np.arange(k))
    if k == 0:
        return
    cells = np.floor((points - points.min(axis=0)) / (2 * radius / np.sqrt(3))).astype(int)[order]
    keys = [tuple(c) for c in cells]
    assert keys == sorted(keys)                                  # cell after cell, so a cell's points are together
    for key in set(keys):                                        # and within a cell, in the points' own order
        inside = order[[i for i, c in enumerate(keys) if c == key]]
        assert np.all(np.diff(inside) > 0)


def test_a_box_surface_in_lattice_order_makes_short_runs_and_in_the_spatial_order_long_ones():
    """A 20 x 20 x 60 lattice box's surface points in lattice order jump from one end of a column to the other;
    grouped by cells they make runs close to the limit."""
    h = 0.01
    grid = np.stack(np.meshgrid(*(np.arange(n) for n in (20, 20, 60)), indexing="ij"), axis=-1).reshape(-1, 3)
    surface = grid[(grid == 0).any(axis=1) | (grid == [19, 19, 59]).any(axis=1)] * h
    lattice = len(point_runs(surface, 3 * h, 32)[0]) - 1
    spatial = len(point_runs(surface[spatial_order(surface, 3 * h)], 3 * h, 32)[0]) - 1
    assert len(surface) / lattice < 4 and len(surface) / spatial > 10, (len(surface), lattice, spatial)


@settings(max_examples=20)
@given(st.integers(0, 2**32 - 1), st.integers(1, 200), st.floats(0.01, 0.3), st.integers(1, 40))
def test_spatial_runs_are_the_runs_of_the_points_in_their_spatial_order(seed, k, radius, most):
    from pliant.api import spatial_runs

    points = np.random.default_rng(seed).uniform(-0.3, 0.3, (k, 3))
    order, *runs = spatial_runs(points, radius, most)
    assert np.array_equal(order, spatial_order(points, radius))
    for ours, expected in zip(runs, point_runs(points[order], radius, most), strict=True):
        assert np.array_equal(ours, expected)
