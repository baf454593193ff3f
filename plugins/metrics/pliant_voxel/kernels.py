"""numba kernels of the voxel cost: fused point lookup and summation (no temporaries)."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def point_costs(points, lower, inv_res, shape, classes, table, out):
    """Fill ``out`` ``(n, m)`` with the cost of each body point ``points`` ``(n, m, 3)``.

    ``table[c, v]`` is the cost of class ``c`` in flat voxel ``v``; points outside the grid take the
    last column (NaN).
    """
    n, m = points.shape[0], points.shape[1]
    nx, ny, nz = shape[0], shape[1], shape[2]
    outside = table.shape[1] - 1
    for a in range(n):
        for i in range(m):
            ix = int(np.floor((points[a, i, 0] - lower[0]) * inv_res))
            iy = int(np.floor((points[a, i, 1] - lower[1]) * inv_res))
            iz = int(np.floor((points[a, i, 2] - lower[2]) * inv_res))
            if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
                v = (ix * ny + iy) * nz + iz
            else:
                v = outside
            out[a, i] = table[classes[i], v]


@numba.njit(cache=True, nogil=True)
def state_costs(points, lower, inv_res, shape, classes, table, out):
    """Fill ``out`` ``(n,)`` with the summed cost of each configuration's points (NaN propagates)."""
    n, m = points.shape[0], points.shape[1]
    nx, ny, nz = shape[0], shape[1], shape[2]
    outside = table.shape[1] - 1
    for a in range(n):
        total = 0.0
        for i in range(m):
            ix = int(np.floor((points[a, i, 0] - lower[0]) * inv_res))
            iy = int(np.floor((points[a, i, 1] - lower[1]) * inv_res))
            iz = int(np.floor((points[a, i, 2] - lower[2]) * inv_res))
            if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
                total += table[classes[i], (ix * ny + iy) * nz + iz]
            else:
                total += table[classes[i], outside]
        out[a] = total


@numba.njit(cache=True, nogil=True)
def rigid_state_costs(rotations, positions, local, lower, inv_res, shape, classes, table, out):
    """:func:`state_costs` for a rigid body, transforming ``local`` points ``(m, 3)`` on the fly.

    ``rotations`` ``(n, 3, 3)`` and ``positions`` ``(n, 3)`` place the body; world point =
    ``R @ p + t``.  Fusing the transform avoids an ``(n, m, 3)`` temporary.
    """
    n, m = positions.shape[0], local.shape[0]
    nx, ny, nz = shape[0], shape[1], shape[2]
    outside = table.shape[1] - 1
    for a in range(n):
        r = rotations[a]
        tx, ty, tz = positions[a, 0] - lower[0], positions[a, 1] - lower[1], positions[a, 2] - lower[2]
        total = 0.0
        for i in range(m):
            px, py, pz = local[i, 0], local[i, 1], local[i, 2]
            ix = int(np.floor((r[0, 0] * px + r[0, 1] * py + r[0, 2] * pz + tx) * inv_res))
            iy = int(np.floor((r[1, 0] * px + r[1, 1] * py + r[1, 2] * pz + ty) * inv_res))
            iz = int(np.floor((r[2, 0] * px + r[2, 1] * py + r[2, 2] * pz + tz) * inv_res))
            if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
                total += table[classes[i], (ix * ny + iy) * nz + iz]
            else:
                total += table[classes[i], outside]
        out[a] = total
