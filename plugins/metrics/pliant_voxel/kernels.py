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


@numba.njit(cache=True, nogil=True)
def _axis(p, lower, resolution, size):
    """Continuous voxel coordinate of ``p`` on one axis: (lower index, upper index, fraction, varies)."""
    c = (p - lower) / resolution - 0.5
    live = (c >= 0.0) and (c <= size - 1.0) and size > 1
    c = min(max(c, 0.0), size - 1.0)
    lo = min(int(np.floor(c)), max(size - 2, 0))
    return lo, min(lo + 1, size - 1), c - lo, live


@numba.njit(cache=True, nogil=True)
def trilinear_with_gradient(field_, lower, resolution, points, value, gradient):
    """Trilinear interpolation of ``field_`` ``(nx, ny, nz)`` (voxel-centred samples) at world ``points``
    ``(n, m, 3)``: fills ``value`` ``(n, m)`` and its exact gradient ``gradient`` ``(n, m, 3)`` (per metre).

    The same arithmetic as :func:`pliant.voxelgrid._trilinear` and ``_trilinear_gradient`` (clamping to
    the grid; a clamped axis has zero derivative), fused into one pass without temporaries.
    """
    nx, ny, nz = field_.shape
    n, m = points.shape[0], points.shape[1]
    for a in range(n):
        for i in range(m):
            x0, x1, fx, lx = _axis(points[a, i, 0], lower[0], resolution, nx)
            y0, y1, fy, ly = _axis(points[a, i, 1], lower[1], resolution, ny)
            z0, z1, fz, lz = _axis(points[a, i, 2], lower[2], resolution, nz)
            c000, c001 = field_[x0, y0, z0], field_[x0, y0, z1]
            c010, c011 = field_[x0, y1, z0], field_[x0, y1, z1]
            c100, c101 = field_[x1, y0, z0], field_[x1, y0, z1]
            c110, c111 = field_[x1, y1, z0], field_[x1, y1, z1]
            c00 = c000 * (1.0 - fz) + c001 * fz
            c01 = c010 * (1.0 - fz) + c011 * fz
            c10 = c100 * (1.0 - fz) + c101 * fz
            c11 = c110 * (1.0 - fz) + c111 * fz
            c0 = c00 * (1.0 - fy) + c01 * fy
            c1 = c10 * (1.0 - fy) + c11 * fy
            value[a, i] = c0 * (1.0 - fx) + c1 * fx
            gx = c1 - c0
            gy = (c01 - c00) * (1.0 - fx) + (c11 - c10) * fx
            d0 = (c001 - c000) * (1.0 - fy) + (c011 - c010) * fy
            d1 = (c101 - c100) * (1.0 - fy) + (c111 - c110) * fy
            gz = d0 * (1.0 - fx) + d1 * fx
            gradient[a, i, 0] = gx / resolution if lx else 0.0
            gradient[a, i, 1] = gy / resolution if ly else 0.0
            gradient[a, i, 2] = gz / resolution if lz else 0.0
