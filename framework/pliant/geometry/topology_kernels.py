"""numba kernel of the puncture check (:mod:`pliant.geometry.topology`): the voxels body points occupy or sweep,
in one compiled pass instead of one array operation per piece offset.

It follows :meth:`PunctureChecker.occupied`'s definition with the same floating-point operations, so the set of
voxels is the one of the batched numpy formulation it replaced (tests/framework/geometry/test_topology_kernels.py
keeps that formulation as the reference); the order and the repetitions of the returned indices are not part of
the result (the checker takes the unique voxels per object).
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, inline="always")
def _padded(x, upper):
    """Voxel coordinate ``x`` (voxels from the grid's lower corner) as a padded-grid index in ``[0, upper]``."""
    return int(min(max(math.floor(x + 1.0), 0.0), upper))


@numba.njit(cache=True, nogil=True, inline="always")
def _pieces(coords, c, i):
    """How many pieces the segment of point ``i`` from configuration ``c`` to ``c + 1`` is cut into: ``ceil`` of
    its largest per-axis displacement in voxels, at least 1."""
    d0 = abs(coords[c + 1, i, 0] - coords[c, i, 0])
    d1 = abs(coords[c + 1, i, 1] - coords[c, i, 1])
    d2 = abs(coords[c + 1, i, 2] - coords[c, i, 2])
    return max(1, math.ceil(max(d0, max(d1, d2))))


@numba.njit(cache=True, nogil=True)
def swept_cells(coords, shape, arc_margin):
    """Flat padded-grid indices of the voxels body points ``coords`` ``(n, m, 3)`` (in voxels from the grid's lower
    corner) occupy (``n == 1``: the voxel holding each point) or sweep between consecutive configurations: each
    segment is cut into ``ceil`` of its largest per-axis displacement pieces, and each piece takes every voxel its
    bounding box, grown by ``arc_margin`` voxels, overlaps.  ``shape``: the grid's shape (unpadded)."""
    n, m = coords.shape[0], coords.shape[1]
    u0, u1, u2 = shape[0] + 1.0, shape[1] + 1.0, shape[2] + 1.0
    py, pz = shape[1] + 2, shape[2] + 2
    if n == 1:
        out = np.empty(m, dtype=np.int64)
        for i in range(m):
            out[i] = (_padded(coords[0, i, 0], u0) * py + _padded(coords[0, i, 1], u1)) * pz \
                + _padded(coords[0, i, 2], u2)
        return out
    # first pass: the number of voxels, to allocate once
    total = 0
    for c in range(n - 1):
        for i in range(m):
            total += _pieces(coords, c, i) * 27
    out = np.empty(total, dtype=np.int64)
    w = 0
    first = np.empty(3, dtype=np.int64)
    last = np.empty(3, dtype=np.int64)
    upper = np.array([u0, u1, u2])
    for c in range(n - 1):
        for i in range(m):
            count = _pieces(coords, c, i)
            nf = float(count)
            for k in range(count):
                for a in range(3):
                    delta = coords[c + 1, i, a] - coords[c, i, a]
                    p0 = coords[c, i, a] + (k / nf) * delta
                    p1 = coords[c, i, a] + ((k + 1) / nf) * delta
                    first[a] = _padded(min(p0, p1) - arc_margin, upper[a])
                    last[a] = _padded(max(p0, p1) + arc_margin, upper[a])
                for x in range(first[0], last[0] + 1):
                    for y in range(first[1], last[1] + 1):
                        for z in range(first[2], last[2] + 1):
                            if w == len(out):           # wider pieces than 3 voxels per axis (a large margin)
                                grown = np.empty(2 * len(out) + 27, dtype=np.int64)
                                grown[:w] = out[:w]
                                out = grown
                            out[w] = (x * py + y) * pz + z
                            w += 1
    return out[:w]
