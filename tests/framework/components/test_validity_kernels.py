"""The collision checker's compiled kernels (pliant.components.validity_kernels) against the batched numpy
formulation they replaced, kept here as the reference: the same verdict and the same clearance, bit for bit, on
points inside, on and near voxel faces, outside the grid, for several material classes, in 3-D and planar scenes.
And the clearance is a true lower bound: no forbidden cube's point is nearer than it (brute force).  That test
found the one change: a point on a face of its own forbidden cube (free by touching) had the clearance of its
neighbours, up to half a voxel, instead of 0 (the reference has the fix too: ``own``)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import Pipeline
from pliant.components.validity import FACE_SLACK
from pliant.interfaces import PlanningProblem
from pliant.scene import Scene


def _scene(planar: bool) -> Scene:
    z = (-0.05, 0.05) if planar else (0.0, 0.6)
    return Scene.from_dict({
        "name": "kernel-test", "planar": planar, "start": [0.05, 0.05, 0.05] if not planar else [0.05, 0.05, 0.0],
        "goal": [0.5, 0.5, 0.3] if not planar else [0.5, 0.5, 0.0],
        "bounds": {"lower": [0.0, 0.0, z[0]], "upper": [0.6, 0.6, z[1]], "resolution": 0.1},
        "objects": [
            {"name": "rigid", "cells": [[2, 3], [1, 4], [0, 6 if not planar else 1]], "deformability": 0.0,
             "sensitivity": 1.0},
            {"name": "soft", "cells": [[4, 5], [3, 5], [0, 6 if not planar else 1]], "deformability": 0.5,
             "sensitivity": 1.0},
            {"name": "forbidden", "cells": [[0, 1], [4, 6], [0, 6 if not planar else 1]], "deformability": 0.5,
             "sensitivity": float("nan")}],
        # two parts of different materials: two classes of points (a rigid part may not enter the rigid object)
        # two parts of different materials, one body point each (on the lattice of the scene's resolution): two
        # classes (the rigid one may not enter "rigid")
        "robot": {"kind": "rigid", "space": "se2" if planar else "r3", "sensitivity": 1.0,
                  "parts": [{"shape": "box", "size": [0.02, 0.02, 0.02], "deformability": 0.0},
                            {"shape": "box", "size": [0.02, 0.02, 0.02], "position": [0.1, 0.0, 0.0],
                             "deformability": 0.5}]},
    })


@pytest.fixture(scope="module", params=[False, True], ids=["3d", "planar"])
def checker(request):
    context = Pipeline(_scene(request.param), planner="straight").build()
    checker = PlanningProblem.from_context(context).checker
    assert len(set(checker.classes.tolist())) == 2
    return checker


# --- the numpy reference (the checker's formulation before the kernels) ---------------------------------------


def _flat(checker, padded_idx):
    padded = checker._padded_shape
    i = np.clip(padded_idx, 0, padded - 1)
    return (i[..., 0] * padded[1] + i[..., 1]) * padded[2] + i[..., 2]


def _lookup(checker, table, idx, classes):
    return table[classes, _flat(checker, idx + 1)]


def reference_points_free(checker, points, tolerance=0.0):
    u = points - checker._lower
    u *= 1.0 / checker.resolution
    u += 1.0
    padded_idx = u.astype(np.int64)
    classes = np.broadcast_to(checker.classes, points.shape[:-1])
    bad = checker._forbidden_padded[classes, _flat(checker, padded_idx)]
    if not bad.any():
        return ~bad
    slack = min(max(FACE_SLACK, tolerance / checker.resolution), 0.5)
    frac = u - np.floor(u)
    onface = bad & np.any((frac < slack) | (frac > 1.0 - slack), axis=-1)
    if onface.any():
        sel = np.nonzero(onface)
        us, cs = u[sel], classes[sel]
        lo = np.floor(us - slack).astype(np.int64)
        hi = np.floor(us + slack).astype(np.int64)
        still = np.ones(len(us), dtype=bool)
        for pick in itertools.product((0, 1), repeat=3):
            cand = np.stack([hi[:, k] if pick[k] else lo[:, k] for k in range(3)], axis=-1)
            still &= checker._forbidden_padded[cs, _flat(checker, cand)]
        bad[sel] = still
    return ~bad


def reference_clearance(checker, points):
    h = checker.resolution
    u = (points - checker._lower) / h
    idx = np.floor(u).astype(np.int64)
    frac = (u - idx) * h
    classes = np.broadcast_to(checker.classes, points.shape[:-1])
    moving = checker._moving_axes
    best = h + np.min(np.where(moving, np.minimum(frac, h - frac), np.inf), axis=-1)
    offset = np.linalg.norm(np.where(moving, frac - 0.5 * h, 0.0), axis=-1)
    far = checker._far_clearance(checker._grids)
    best = np.maximum(best, _lookup(checker, far, idx, classes) - offset)
    near = _lookup(checker, checker._near_padded, idx, classes)
    sel = np.nonzero(near)
    below, above = frac[sel], h - frac[sel]
    nidx, ncls = idx[sel], classes[sel]
    local = best[sel]
    for off in checker._offsets:
        hit = _lookup(checker, checker._forbidden_padded, nidx + off, ncls)
        gap2 = np.zeros(len(local))
        for k in range(3):
            if off[k] < 0:
                gap2 = gap2 + below[:, k] ** 2
            elif off[k] > 0:
                gap2 = gap2 + above[:, k] ** 2
        local = np.where(hit, np.minimum(local, np.sqrt(gap2)), local)
    best[sel] = local
    own = _lookup(checker, checker._forbidden_padded, idx - 1 + 1, classes)     # the point's own voxel
    return np.where(own, 0.0, best)


def _points(checker, rng, n):
    """``(n, 2, 3)`` points: uniform over the grid and a voxel beyond, on voxel faces and edges, a hair either side
    of them, and far outside; planar scenes keep z in the layer."""
    h, lower = checker.resolution, checker._lower
    upper = lower + h * checker._shape
    pts = rng.uniform(lower - h, upper + h, (n, 2, 3))
    faces = lower + h * rng.integers(-1, checker._shape + 2, (n, 2, 3))
    pick = rng.random((n, 2, 3))
    pts = np.where(pick < 0.3, faces, pts)
    pts = np.where((pick >= 0.3) & (pick < 0.45), faces + rng.choice([-1, 1], (n, 2, 3)) * 10.0 ** rng.integers(
        -12, -3, (n, 2, 3)), pts)
    pts[rng.random(n) < 0.02] += 5.0
    if not checker._moving_axes[2]:
        pts[..., 2] = rng.uniform(lower[2], upper[2], (n, 2))
    return pts


def test_the_kernels_give_the_references_verdicts_and_clearances_bit_for_bit(checker):
    rng = np.random.default_rng(7)
    pts = _points(checker, rng, 20_000)
    for tolerance in (0.0, 0.004, 0.2):
        free = checker._points_free(pts, tolerance)
        assert free.shape == (20_000, 2)
        assert np.array_equal(free, reference_points_free(checker, pts.copy(), tolerance))
    assert 0 < np.count_nonzero(~checker._points_free(pts)) < pts.shape[0] * 2      # both verdicts occur
    clear = checker._clearance(pts)
    assert np.array_equal(clear, reference_clearance(checker, pts))
    # the checker's other shapes: one configuration's points (m, 3) and a batch of batches
    assert np.array_equal(checker._points_free(pts[0]), reference_points_free(checker, pts[0].copy()))
    assert np.array_equal(checker._clearance(pts[:6].reshape(2, 3, 2, 3)),
                          reference_clearance(checker, pts[:6]).reshape(2, 3, 2))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-0.15, 0.75, allow_nan=False)] * 3), min_size=2, max_size=2))
def test_any_points_agree_with_the_reference(checker, coords):
    pts = np.array(coords, dtype=np.float64)[None]
    if not checker._moving_axes[2]:
        pts[..., 2] = 0.0
    assert np.array_equal(checker._points_free(pts), reference_points_free(checker, pts.copy()))
    assert np.array_equal(checker._clearance(pts), reference_clearance(checker, pts))


def test_the_clearance_is_a_lower_bound_of_the_distance_to_every_forbidden_cube(checker):
    """Brute force: every forbidden cube (the grid's and one voxel of outside around it), the exact distance from
    a point to the box (moving axes only), against the kernel's clearance of free points."""
    rng = np.random.default_rng(3)
    h = checker.resolution
    pts = _points(checker, rng, 1500)
    free = checker._points_free(pts)
    clear = checker._clearance(pts)
    grids = checker._grids                                  # (classes, padded...) forbidden, outside included
    moving = checker._moving_axes
    for c in range(grids.shape[0]):
        cubes = np.argwhere(grids[c]) - 1                    # voxel indices of the forbidden cubes
        lo = checker._lower + h * cubes
        hi = lo + h
        mine = checker.classes == c
        p = pts[:, mine].reshape(-1, 3)
        ok = free[:, mine].reshape(-1)
        bound = clear[:, mine].reshape(-1)
        for j in np.nonzero(ok)[0][:400]:
            gap = np.maximum(np.maximum(lo - p[j], p[j] - hi), 0.0)
            gap = np.where(moving, gap, 0.0)
            inside_layer = np.all(moving | ((lo <= p[j]) & (p[j] <= hi)), axis=1)
            d = np.linalg.norm(gap[inside_layer], axis=1)
            assert bound[j] <= d.min() + 1e-12
