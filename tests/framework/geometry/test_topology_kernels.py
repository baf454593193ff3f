"""The puncture check's compiled sweep (pliant.geometry.topology_kernels) against the batched numpy formulation it
replaced, kept here as the reference: the same voxels for one configuration and for paths, with and without an arc
margin, for points inside and outside the grid, on voxel faces and a hair off them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.geometry.topology import PunctureChecker
from pliant.geometry.voxelgrid import VoxelGrid

RES = 0.1
SHAPE = (7, 6, 5)


def _checker(arc_margin: float) -> PunctureChecker:
    mask = np.zeros(SHAPE, dtype=bool)
    mask[1:6, 1:5, 1:4] = True
    mask[2:5, 2:4, 2:3] = False                       # a shell: something to watch
    object_id = np.where(mask, 0, -1).astype(np.int32)
    grid = VoxelGrid(np.array([0.1, -0.2, 0.0]), RES, np.where(mask, 0.5, 1.0), np.where(mask, 1.0, 0.0),
                     object_id, ["shell"])
    return PunctureChecker(grid, lambda q: np.atleast_2d(q)[:, None, :], arc_margin=arc_margin)


def reference_swept_cells(checker: PunctureChecker, pts: np.ndarray) -> np.ndarray:
    """The formulation before the kernel (one array operation per piece offset)."""
    shape = checker._shape
    _, py, pz = shape + 2

    def padded_index(c, axis):
        ci = np.floor(c + 1.0)
        np.maximum(ci, 0.0, out=ci)
        np.minimum(ci, shape[axis] + 1.0, out=ci)
        return ci.astype(np.int64)

    def flat(index):
        return ((index[0] * py + index[1]) * pz + index[2]).ravel()

    coords = (pts - checker.grid.lower) / checker.grid.resolution
    if len(coords) == 1:
        return flat([padded_index(coords[..., a], a) for a in range(3)])
    start, end = coords[:-1].reshape(-1, 3), coords[1:].reshape(-1, 3)
    delta = end - start
    counts = np.maximum(1, np.ceil(np.max(np.abs(delta), axis=1)).astype(np.int64))
    owner = np.repeat(np.arange(len(start)), counts)
    k = np.arange(len(owner)) - np.repeat(np.cumsum(counts) - counts, counts)
    n = counts[owner].astype(np.float64)
    p0 = start[owner] + (k / n)[:, None] * delta[owner]
    p1 = start[owner] + ((k + 1) / n)[:, None] * delta[owner]
    lo = np.minimum(p0, p1) - checker.arc_margin
    hi = np.maximum(p0, p1) + checker.arc_margin
    first = [padded_index(lo[..., a], a).ravel() for a in range(3)]
    last = [padded_index(hi[..., a], a).ravel() for a in range(3)]
    span = [last[a] - first[a] for a in range(3)]
    cells = [flat(first)]
    for dx in range(int(span[0].max()) + 1):
        for dy in range(int(span[1].max()) + 1):
            for dz in range(int(span[2].max()) + 1):
                if dx == dy == dz == 0:
                    continue
                keep = (dx <= span[0]) & (dy <= span[1]) & (dz <= span[2])
                if keep.any():
                    cells.append(flat([first[0][keep] + dx, first[1][keep] + dy, first[2][keep] + dz]))
    return np.concatenate(cells)


def _paths(rng, count, length, points):
    """Random walks of ``points`` body points (steps up to two voxels), a third of the coordinates snapped to voxel
    faces or a hair off them, some leaving the grid."""
    lower = np.array([0.1, -0.2, 0.0])
    upper = lower + RES * np.array(SHAPE)
    out = []
    for _ in range(count):
        p = rng.uniform(lower - 2 * RES, upper + 2 * RES, (1, points, 3))
        steps = rng.uniform(-2 * RES, 2 * RES, (length - 1, points, 3))
        path = np.concatenate([p, p + np.cumsum(steps, axis=0)])
        snap = rng.random(path.shape) < 0.3
        faces = lower + RES * np.round((path - lower) / RES)
        path = np.where(snap, faces + rng.choice([0.0, 1e-12, -1e-12], path.shape), path)
        out.append(path)
    return out


@pytest.mark.parametrize("arc_margin", [0.0, 0.2, 0.49])
def test_the_kernel_sweeps_the_references_voxels(arc_margin):
    checker = _checker(arc_margin)
    rng = np.random.default_rng(11)
    for length in (1, 2, 5):
        for path in _paths(rng, 60, length, 3):
            got = checker._swept_cells(path)
            want = reference_swept_cells(checker, path)
            assert np.array_equal(np.unique(got), np.unique(want))
            if length == 1:
                assert np.array_equal(got, want)             # one configuration: one voxel per point, in order


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-0.5, 1.0, allow_nan=False)] * 3), min_size=1, max_size=4),
       st.sampled_from([0.0, 0.25]))
def test_any_path_sweeps_the_references_voxels(points, arc_margin):
    checker = _checker(arc_margin)
    path = np.array(points, dtype=np.float64)[:, None, :]
    assert np.array_equal(np.unique(checker._swept_cells(path)), np.unique(reference_swept_cells(checker, path)))

