"""Runs of a body's points for a broad phase: consecutive points grouped under a bounding box and a radius, so a
kernel can skip a whole run that cannot touch anything (the kinematic simulator's contacts, the reachable-volume
metric's clearance queries)."""

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
