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
def rigid_state_costs(rotations, positions, local, centre, half, lower, inv_res, shape, classes, materials, lut,
                      out):
    """:func:`state_costs` for a rigid body, transforming the local points on the fly.

    ``local`` ``(3, m)``: the body points' coordinates (m), one row per axis.  ``rotations``
    ``(n, 3, 3)`` and ``positions`` ``(n, 3)`` place the body; world point = ``R @ p + t``.  Fusing the
    transform avoids an ``(n, m, 3)`` temporary.  The cost table comes compressed
    (:func:`pliant_voxel.formula.compress_table`): ``materials`` ``(N + 1,)`` the material id of every
    flat voxel (the last: outside the grid) and ``lut[c, k]`` the cost of class ``c`` on material ``k`` —
    a byte or two per voxel instead of eight per class, so the lookups stay in cache.  ``centre`` and
    ``half`` (m): the local points' bounding box.  A configuration whose rotated box lies inside the grid
    takes the branch-free path (:func:`_inside_costs`); the others check every point.
    """
    n, m = positions.shape[0], local.shape[1]
    nx, ny, nz = shape[0], shape[1], shape[2]
    outside = materials.shape[0] - 1
    scaled = np.empty((3, 3))
    flat = np.empty(m, dtype=np.int64)
    grid = (nx, ny, nz)
    for a in range(n):
        r = rotations[a]
        inside = True
        for k in range(3):
            mid = (r[k, 0] * centre[0] + r[k, 1] * centre[1] + r[k, 2] * centre[2]
                   + positions[a, k] - lower[k]) * inv_res
            extent = (abs(r[k, 0]) * half[0] + abs(r[k, 1]) * half[1] + abs(r[k, 2]) * half[2]) * inv_res
            inside = inside and mid - extent >= 1e-6 and mid + extent <= grid[k] - 1e-6
        if inside:
            for i in range(3):
                for j in range(3):
                    scaled[i, j] = r[i, j] * inv_res
            out[a] = _inside_costs(scaled, (positions[a, 0] - lower[0]) * inv_res,
                                   (positions[a, 1] - lower[1]) * inv_res, (positions[a, 2] - lower[2]) * inv_res,
                                   local, ny, nz, classes, materials, lut, flat)
            continue
        mx, my, mz = positions[a, 0] - lower[0], positions[a, 1] - lower[1], positions[a, 2] - lower[2]
        total = 0.0
        for i in range(m):
            px, py, pz = local[0, i], local[1, i], local[2, i]
            ix = int(np.floor((r[0, 0] * px + r[0, 1] * py + r[0, 2] * pz + mx) * inv_res))
            iy = int(np.floor((r[1, 0] * px + r[1, 1] * py + r[1, 2] * pz + my) * inv_res))
            iz = int(np.floor((r[2, 0] * px + r[2, 1] * py + r[2, 2] * pz + mz) * inv_res))
            if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
                total += lut[classes[i], materials[(ix * ny + iy) * nz + iz]]
            else:
                total += lut[classes[i], materials[outside]]
        out[a] = total


@numba.njit(cache=True, nogil=True, fastmath=True)
def _inside_costs(r, tx, ty, tz, local, ny, nz, classes, materials, lut, flat):
    """Summed cost of the ``local`` ``(3, m)`` points placed by ``r`` (rotation over the resolution) and ``t``
    (voxels), all of them inside the grid.  Two passes: the flat voxel indices first (no bounds checks,
    truncation toward zero is the floor as every coordinate is positive: a loop the compiler vectorises),
    then the lookups; ``flat`` ``(m,)`` is scratch."""
    lx, ly, lz = local[0], local[1], local[2]
    for i in range(lx.shape[0]):
        ix = np.int64(r[0, 0] * lx[i] + r[0, 1] * ly[i] + r[0, 2] * lz[i] + tx)
        iy = np.int64(r[1, 0] * lx[i] + r[1, 1] * ly[i] + r[1, 2] * lz[i] + ty)
        iz = np.int64(r[2, 0] * lx[i] + r[2, 1] * ly[i] + r[2, 2] * lz[i] + tz)
        flat[i] = (ix * ny + iy) * nz + iz
    total = 0.0
    for i in range(lx.shape[0]):
        total += lut[classes[i], materials[flat[i]]]
    return total


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

    The same arithmetic as :func:`pliant.geometry.voxelgrid._trilinear` and ``_trilinear_gradient`` (clamping to
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


@numba.njit(cache=True, nogil=True)
def rigid_state_breakdown(rotations, positions, local, centre, half, lower, inv_res, shape, classes, codes, lut,
                          object_of_code, out):
    """Per-object cost of rigid-body configurations: ``out[a, o]`` += the cost of every point of configuration
    ``a`` inside object ``o`` (``out`` ``(n, k)``, zeroed by the caller); a row is NaN when any point's cost is
    not finite (outside the grid, a rigid collision, a forbidden object), as :meth:`VoxelDeformationCost.breakdown`
    defines it.  The cost table comes compressed together with the voxels' objects: ``codes`` ``(N + 1,)`` one
    small integer per flat voxel (the last: outside), ``lut[c, k]`` the cost of class ``c`` on code ``k`` and
    ``object_of_code[k]`` its object (-1: free space and outside), so that the per-point lookups read a byte a
    voxel instead of sixteen (:func:`pliant_voxel.formula.compress_table`).  The body points are placed on the
    fly, world = ``R @ p + t``, as in :func:`rigid_state_costs`; ``centre`` and ``half`` (m): the local points'
    bounding box.  Each configuration takes two passes: every point's voxel first (a loop the compiler
    vectorises), then the lookups, without bounds checks when the rotated box lies inside the grid.  Every point
    lands in the voxel the per-point formula gives and the costs are summed in the points' order, so the result is
    the uncompressed, one-pass kernel's bit for bit (tested)."""
    n, m = positions.shape[0], local.shape[1]
    nx, ny, nz = shape[0], shape[1], shape[2]
    grid = (nx, ny, nz)
    outside = codes.shape[0] - 1
    ix, iy, iz = np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64)
    lx, ly, lz = local[0], local[1], local[2]
    for a in range(n):
        r = rotations[a]
        mx, my, mz = positions[a, 0] - lower[0], positions[a, 1] - lower[1], positions[a, 2] - lower[2]
        inside = True
        for k in range(3):
            mid = (r[k, 0] * centre[0] + r[k, 1] * centre[1] + r[k, 2] * centre[2] + positions[a, k] - lower[k]) \
                * inv_res
            extent = (abs(r[k, 0]) * half[0] + abs(r[k, 1]) * half[1] + abs(r[k, 2]) * half[2]) * inv_res
            inside = inside and mid - extent >= 1e-6 and mid + extent <= grid[k] - 1e-6
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = (r[0, 0], r[0, 1], r[0, 2], r[1, 0], r[1, 1], r[1, 2],
                                                       r[2, 0], r[2, 1], r[2, 2])
        if inside:              # every coordinate is positive: truncation toward zero is the floor
            for i in range(m):
                ix[i] = np.int64((r00 * lx[i] + r01 * ly[i] + r02 * lz[i] + mx) * inv_res)
                iy[i] = np.int64((r10 * lx[i] + r11 * ly[i] + r12 * lz[i] + my) * inv_res)
                iz[i] = np.int64((r20 * lx[i] + r21 * ly[i] + r22 * lz[i] + mz) * inv_res)
        else:
            for i in range(m):
                ix[i] = int(np.floor((r00 * lx[i] + r01 * ly[i] + r02 * lz[i] + mx) * inv_res))
                iy[i] = int(np.floor((r10 * lx[i] + r11 * ly[i] + r12 * lz[i] + my) * inv_res))
                iz[i] = int(np.floor((r20 * lx[i] + r21 * ly[i] + r22 * lz[i] + mz) * inv_res))
        bad = False
        for i in range(m):
            if inside or (0 <= ix[i] < nx and 0 <= iy[i] < ny and 0 <= iz[i] < nz):
                k = codes[(ix[i] * ny + iy[i]) * nz + iz[i]]
            else:
                k = codes[outside]
            cost = lut[classes[i], k]
            if not np.isfinite(cost):
                bad = True
                break
            o = object_of_code[k]
            if o >= 0:
                out[a, o] += cost
        if bad:
            for o in range(out.shape[1]):
                out[a, o] = np.nan
