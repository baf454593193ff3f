"""numba kernels of the collision checker (:mod:`pliant.components.validity`): per body point, whether it is free
and a lower bound of its clearance, fused in one pass over the points (no temporaries, no per-offset array calls).

Both follow the checker's definitions exactly (same floating-point operations in the same order, so the results
are bit-identical to the batched numpy formulation they replaced, which tests/framework/components/
test_validity_kernels.py keeps as the reference; the one change is the touching point's clearance below, which that
formulation overstated):

- a point is **free** when the padded voxel it lies in is not forbidden to its material class, or when it lies
  within ``slack`` (voxel units) of a face of that voxel and one of the voxels that many slack-widened floors
  reach is allowed;
- its **clearance** (m) is 0 when the voxel it lies in is itself forbidden (a point on the face of such a cube is
  free by touching it), else the distance to the nearest forbidden cube among the 26 (or, planar, 8) around its
  voxel, when the voxel is marked near one, else at least the distance to the edge of that 3 x 3 x 3 block or the
  far-field bound of the voxel's centre less the point's offset from it, whichever is larger.

Grids are padded by one voxel of "outside" (forbidden) on every side and flattened per class: ``(c, N)``.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, inline="always")
def _flat(i0, i1, i2, p0, p1, p2):
    """Flat index of padded voxel ``(i0, i1, i2)`` clamped to the padded grid ``(p0, p1, p2)``."""
    i0 = min(max(i0, 0), p0 - 1)
    i1 = min(max(i1, 0), p1 - 1)
    i2 = min(max(i2, 0), p2 - 1)
    return (i0 * p1 + i1) * p2 + i2


@numba.njit(cache=True, nogil=True)
def points_free(points, classes, lower, inv_res, padded, forbidden, slack, out):
    """Fill ``out`` ``(n, m)`` bool: body point ``points[a, i]`` ``(n, m, 3)`` of material class ``classes[i]`` is
    free (module docstring).  ``inv_res``: 1 / the voxel edge (1/m); ``padded``: the padded grid's shape;
    ``forbidden`` ``(c, N)``: the padded forbidden cubes per class; ``slack``: the face slack (voxel units)."""
    n, m = points.shape[0], points.shape[1]
    p0, p1, p2 = padded[0], padded[1], padded[2]
    u = np.empty(3)
    for a in range(n):
        for i in range(m):
            c = classes[i]
            for k in range(3):
                u[k] = (points[a, i, k] - lower[k]) * inv_res + 1.0
            # truncation, as numpy's astype: floor wherever the point is inside the padded grid
            if not forbidden[c, _flat(int(u[0]), int(u[1]), int(u[2]), p0, p1, p2)]:
                out[a, i] = True
                continue
            onface = False
            for k in range(3):
                f = u[k] - math.floor(u[k])
                if f < slack or f > 1.0 - slack:
                    onface = True
            if not onface:
                out[a, i] = False
                continue
            l0, l1, l2 = math.floor(u[0] - slack), math.floor(u[1] - slack), math.floor(u[2] - slack)
            h0, h1, h2 = math.floor(u[0] + slack), math.floor(u[1] + slack), math.floor(u[2] + slack)
            still = True
            for pick in range(8):
                j0 = h0 if pick & 4 else l0
                j1 = h1 if pick & 2 else l1
                j2 = h2 if pick & 1 else l2
                if not forbidden[c, _flat(j0, j1, j2, p0, p1, p2)]:
                    still = False
                    break
            out[a, i] = not still


@numba.njit(cache=True, nogil=True)
def clearances(points, classes, lower, res, padded, forbidden, near, far, moving, offsets, out):
    """Fill ``out`` ``(n, m)`` with a lower bound (m) of each body point's distance to the nearest cube its class
    may not enter (module docstring).  ``res``: the voxel edge (m); ``near`` ``(c, N)``: voxels with a forbidden
    cube among their neighbours along the moving axes; ``far`` ``(c, N)``: the far-field bound of each voxel's
    centre (m); ``moving`` ``(3,)`` bool: the axes the points move along; ``offsets`` ``(o, 3)``: the neighbours
    to search (moving axes only)."""
    n, m = points.shape[0], points.shape[1]
    p0, p1, p2 = padded[0], padded[1], padded[2]
    frac = np.empty(3)
    idx = np.empty(3, dtype=np.int64)
    for a in range(n):
        for i in range(m):
            c = classes[i]
            inner = np.inf
            off2 = 0.0
            for k in range(3):
                u = (points[a, i, k] - lower[k]) / res
                idx[k] = math.floor(u)
                frac[k] = (u - idx[k]) * res
                if moving[k]:
                    inner = min(inner, min(frac[k], res - frac[k]))
                    d = frac[k] - 0.5 * res
                    off2 += d * d
            v = _flat(idx[0] + 1, idx[1] + 1, idx[2] + 1, p0, p1, p2)
            if forbidden[c, v]:
                # on a face of its own forbidden cube (free only by touching it): no clearance
                out[a, i] = 0.0
                continue
            best = res + inner
            best = max(best, far[c, v] - math.sqrt(off2))
            if near[c, v]:
                local = best
                for o in range(offsets.shape[0]):
                    if not forbidden[c, _flat(idx[0] + offsets[o, 0] + 1, idx[1] + offsets[o, 1] + 1,
                                              idx[2] + offsets[o, 2] + 1, p0, p1, p2)]:
                        continue
                    gap2 = 0.0
                    for k in range(3):
                        if offsets[o, k] < 0:
                            gap2 = gap2 + frac[k] ** 2
                        elif offsets[o, k] > 0:
                            gap2 = gap2 + (res - frac[k]) ** 2
                    local = min(local, math.sqrt(gap2))
                best = local
            out[a, i] = best
