"""Runs of a body's points for a broad phase: consecutive points grouped under a bounding box and a radius, so a
kernel can skip a whole run that cannot touch anything (the kinematic simulator's contacts, the reachable-volume
metric's clearance queries); and an order of the points that makes the runs long."""

from __future__ import annotations

import numpy as np


def point_runs(local: np.ndarray, max_radius: float, max_points: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Runs of consecutive points of ``local`` ``(k, 3)`` (body frame, m), each as long as its bounding box's
    half-diagonal stays within ``max_radius`` (m), of at most ``max_points`` points.  Returns ``starts`` ``(s + 1,)``
    (int64: the first point of each run, then ``k``), the boxes' ``centres`` and half ``extents`` ``(s, 3)`` (m) and
    ``radii`` ``(s,)`` (m: the farthest point of each run from its centre).  The points keep their order, so a kernel
    that walks the runs meets the points in the order it would without them."""
    local = np.asarray(local, dtype=np.float64).reshape(-1, 3)
    starts, centres, extents, radii = [], [], [], []
    i, k = 0, len(local)
    while i < k:
        lo, hi, j = local[i].copy(), local[i].copy(), i + 1
        while j < k and j - i < max_points:
            lo2, hi2 = np.minimum(lo, local[j]), np.maximum(hi, local[j])
            if 0.5 * np.linalg.norm(hi2 - lo2) > max_radius:
                break
            lo, hi, j = lo2, hi2, j + 1
        centre = 0.5 * (lo + hi)
        starts.append(i)
        centres.append(centre)
        extents.append(0.5 * (hi - lo))
        radii.append(float(np.max(np.linalg.norm(local[i:j] - centre, axis=1))))
        i = j
    return (np.array(starts + [k], dtype=np.int64), np.ascontiguousarray(np.array(centres).reshape(-1, 3)),
            np.ascontiguousarray(np.array(extents).reshape(-1, 3)), np.array(radii, dtype=np.float64))


def spatial_order(points: np.ndarray, radius: float) -> np.ndarray:
    """A permutation ``(k,)`` (int64) of ``points`` ``(k, 3)`` (m) that keeps near points together: by cubic cells
    whose half-diagonal is ``radius`` (m), cell after cell in lexicographic order, and within a cell in the points'
    own order -- so that runs of consecutive points (:func:`point_runs` with that radius) are long.  A body's points
    in lattice order jump about the body (a box's surface: from one end of a column to the other), which leaves runs
    of two or three points; a kernel that walks the points in this order and needs results in their own order maps
    them back through the permutation."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) == 0:
        return np.zeros(0, dtype=np.int64)
    cell = 2.0 * radius / np.sqrt(3.0)
    key = np.floor((points - points.min(axis=0)) / cell).astype(np.int64)
    return np.lexsort((np.arange(len(points)), key[:, 2], key[:, 1], key[:, 0])).astype(np.int64)


def spatial_runs(points: np.ndarray, max_radius: float, max_points: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`point_runs` of ``points`` ``(k, 3)`` taken in their :func:`spatial_order` (cells of half-diagonal
    ``max_radius``): ``order`` ``(k,)`` (a kernel walks ``points[order]``; ``order[j]`` is the walked point's place in
    ``points``), then the runs' ``starts``, ``centres``, ``extents`` and ``radii`` over the walked points."""
    order = spatial_order(points, max_radius)
    return (order, *point_runs(np.asarray(points, dtype=np.float64).reshape(-1, 3)[order], max_radius, max_points))
