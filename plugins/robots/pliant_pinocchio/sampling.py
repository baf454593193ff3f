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
    """Points on triangles ``(m, 3, 3)``: each subdivided until its edges are shorter than ``spacing / 2``."""
    out = [tris.reshape(-1, 3)]
    for a, b, c in tris:
        longest = max(np.linalg.norm(b - a), np.linalg.norm(c - b), np.linalg.norm(a - c))
        k = int(np.ceil(2 * longest / spacing))
        if k <= 1:
            continue
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = i + j <= k
        u, v = i[keep] / k, j[keep] / k
        out.append(a + np.outer(u, b - a) + np.outer(v, c - a))
    return np.concatenate(out)


def surface_points(geometry, spacing: float) -> np.ndarray:
    """Points ``(k, 3)`` on the surface of a coal geometry in its own frame, about ``spacing`` apart.

    Boxes, spheres, cylinders, capsules and triangle meshes (BVH models) are supported; any other
    type returns its axis-aligned bounding box's surface.
    """
    kind = type(geometry).__name__
    if kind == "Box":
        h = np.asarray(geometry.halfSide, dtype=np.float64)
        axes = [np.linspace(-h[i], h[i], max(2, int(np.ceil(2 * h[i] / spacing)) + 1)) for i in range(3)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        on_face = np.any(np.isclose(np.abs(grid), h), axis=1)
        return grid[on_face]
    if kind == "Sphere":
        r = float(geometry.radius)
        n = max(8, int(np.ceil(4 * np.pi * r * r / spacing ** 2)))
        i = np.arange(n) + 0.5
        phi = np.arccos(1 - 2 * i / n)
        theta = np.pi * (1 + 5 ** 0.5) * i
        return r * np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])
    if kind in ("Cylinder", "Capsule"):
        r, half = float(geometry.radius), float(geometry.halfLength)
        ring = max(6, int(np.ceil(2 * np.pi * r / spacing)))
        angles = 2 * np.pi * np.arange(ring) / ring
        zs = np.linspace(-half, half, max(2, int(np.ceil(2 * half / spacing)) + 1))
        side = np.column_stack([np.tile(r * np.cos(angles), len(zs)), np.tile(r * np.sin(angles), len(zs)),
                                np.repeat(zs, ring)])
        caps = []
        for radius in np.linspace(0, r, max(2, int(np.ceil(r / spacing)) + 1))[:-1]:
            m = max(1, int(np.ceil(2 * np.pi * radius / spacing)))
            a = 2 * np.pi * np.arange(m) / m
            for z in (-half, half):
                caps.append(np.column_stack([radius * np.cos(a), radius * np.sin(a), np.full(m, z)]))
        return np.concatenate([side, *caps])
    if hasattr(geometry, "vertices") and hasattr(geometry, "num_tris"):
        vertices = np.asarray(geometry.vertices(), dtype=np.float64)
        idx = np.array([[t[0], t[1], t[2]] for t in (geometry.tri_indices(i) for i in range(geometry.num_tris))],
                       dtype=np.int64)
        return _dedupe(_triangles(vertices[idx], spacing), spacing / 2)
    geometry.computeLocalAABB()
    lo, hi = np.asarray(geometry.aabb_local.min_), np.asarray(geometry.aabb_local.max_)
    axes = [np.linspace(lo[i], hi[i], max(2, int(np.ceil((hi[i] - lo[i]) / spacing)) + 1)) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return grid[np.any(np.isclose(grid, lo) | np.isclose(grid, hi), axis=1)]
