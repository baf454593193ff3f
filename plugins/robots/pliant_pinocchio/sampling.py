"""Surface points of coal collision geometries, at a given spacing (for voxel lookups, thesis 3.2.1)."""

from __future__ import annotations

import numpy as np


def _dedupe(points: np.ndarray, spacing: float) -> np.ndarray:
    """Keep one point per ``spacing`` lattice cell (the first), so density is uniform."""
    if len(points) == 0:
        return points
    keys = np.floor(points / spacing).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return points[np.sort(first)]


def _triangles(tris: np.ndarray, spacing: float) -> np.ndarray:
    """Points on triangles ``(t, 3, 3)``: each subdivided until its edges are shorter than ``spacing / 2``."""
    out = [tris.reshape(-1, 3)]
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    longest = np.max(np.stack([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                               np.linalg.norm(a - c, axis=1)]), axis=0)
    splits = np.ceil(2 * longest / spacing).astype(np.int64)
    for k in np.unique(splits[splits > 1]):
        sel = splits == k
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = i + j <= k
        u, v = (i[keep] / k)[None, :, None], (j[keep] / k)[None, :, None]
        pts = a[sel, None] + u * (b[sel] - a[sel])[:, None] + v * (c[sel] - a[sel])[:, None]
        out.append(pts.reshape(-1, 3))
    return np.concatenate(out)


def _sphere(radius: float, spacing: float) -> np.ndarray:
    """About one point per ``spacing**2`` of a sphere's area (a Fibonacci lattice), centred at the origin."""
    n = max(8, int(np.ceil(4 * np.pi * radius * radius / spacing ** 2)))
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = np.pi * (1 + 5 ** 0.5) * i
    return radius * np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])


def surface_points(geometry, spacing: float) -> np.ndarray:
    """Points ``(k, 3)`` on the surface of a coal geometry in its own frame (m), about ``spacing`` apart.

    Boxes (faces on a lattice of at most ``spacing``), spheres (Fibonacci lattice, one point per
    ``spacing**2`` of area), cylinders and capsules (rings ``spacing`` apart, caps filled), and
    triangle meshes (BVH models: triangles subdivided to edges below ``spacing / 2``, then one point
    kept per ``spacing / 2`` cell) are sampled exactly on their surface; any other type returns
    points on its local bounding box's surface.
    """
    kind = type(geometry).__name__
    if kind == "Box":
        h = np.asarray(geometry.halfSide, dtype=np.float64)
        axes = [np.linspace(-h[i], h[i], max(2, int(np.ceil(2 * h[i] / spacing)) + 1)) for i in range(3)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        on_face = np.any(np.isclose(np.abs(grid), h), axis=1)
        return grid[on_face]
    if kind == "Sphere":
        return _sphere(float(geometry.radius), spacing)
    if kind in ("Cylinder", "Capsule"):
        r, half = float(geometry.radius), float(geometry.halfLength)
        ring = max(6, int(np.ceil(2 * np.pi * r / spacing)))
        angles = 2 * np.pi * np.arange(ring) / ring
        zs = np.linspace(-half, half, max(2, int(np.ceil(2 * half / spacing)) + 1))
        side = np.column_stack([np.tile(r * np.cos(angles), len(zs)), np.tile(r * np.sin(angles), len(zs)),
                                np.repeat(zs, ring)])
        if kind == "Capsule":       # hemispherical ends
            ball = _sphere(r, spacing)
            ball[:, 2] += np.where(ball[:, 2] >= 0, half, -half)
            return np.concatenate([side, ball])
        caps = []
        for radius in np.linspace(0, r, max(2, int(np.ceil(r / spacing)) + 1))[:-1]:
            m = max(1, int(np.ceil(2 * np.pi * radius / spacing)))
            a = 2 * np.pi * np.arange(m) / m
            for z in (-half, half):
                caps.append(np.column_stack([radius * np.cos(a), radius * np.sin(a), np.full(m, z)]))
        return np.concatenate([side, *caps])
    if hasattr(geometry, "vertices") and hasattr(geometry, "num_tris"):
        vertices = np.asarray(geometry.vertices(), dtype=np.float64).reshape(-1, 3)
        if geometry.num_tris == 0:
            return vertices
        idx = np.array([[t[0], t[1], t[2]] for t in (geometry.tri_indices(i) for i in range(geometry.num_tris))],
                       dtype=np.int64)
        return _dedupe(_triangles(vertices[idx], spacing), spacing / 2)
    geometry.computeLocalAABB()
    lo, hi = np.asarray(geometry.aabb_local.min_), np.asarray(geometry.aabb_local.max_)
    axes = [np.linspace(lo[i], hi[i], max(2, int(np.ceil((hi[i] - lo[i]) / spacing)) + 1)) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return grid[np.any(np.isclose(grid, lo) | np.isclose(grid, hi), axis=1)]
