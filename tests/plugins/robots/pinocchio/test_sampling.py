"""Surface sampling of coal geometries: points lie on the surface and cover it at the given spacing."""

from __future__ import annotations

import coal
import numpy as np
import pytest
from pliant_pinocchio.sampling import surface_points
from scipy.spatial import cKDTree

SPACING = 0.02


def _cube_mesh(half: float):
    corners = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(len(faces), len(corners))
    mesh.addVertices(corners)
    mesh.addTriangles(np.array(faces, dtype=np.int64))
    mesh.endModel()
    return mesh


def _uniform_on_box(rng, half, n):
    p = rng.uniform(-half, half, (n, 3))
    axis = rng.integers(0, 3, n)
    p[np.arange(n), axis] = np.where(rng.random(n) < 0.5, -half[axis], half[axis])
    return p


def _on_sphere(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _cylinder_surface(rng, r, half, n):
    a = rng.uniform(0, 2 * np.pi, n)
    side = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(-half, half, n)])
    rad = r * np.sqrt(rng.random(n))
    cap = np.column_stack([rad * np.cos(a), rad * np.sin(a), np.where(rng.random(n) < 0.5, -half, half)])
    return np.concatenate([side, cap])


def _box_gap(points, half):
    """Distance of each point to the surface of the box ``[-half, half]``."""
    inside = np.all(np.abs(points) <= half + 1e-12, axis=1)
    return np.where(inside, np.min(half - np.abs(points), axis=1), np.inf)


@pytest.mark.parametrize("kind", ["box", "sphere", "cylinder", "capsule", "mesh"])
def test_points_lie_on_the_surface_and_cover_it(kind):
    rng = np.random.default_rng(0)
    if kind == "box":
        half = np.array([0.05, 0.1, 0.15])
        pts = surface_points(coal.Box(*(2 * half)), SPACING)
        assert np.allclose(_box_gap(pts, half), 0.0)
        truth = _uniform_on_box(rng, half, 4000)
    elif kind == "mesh":
        half = np.full(3, 0.1)
        pts = surface_points(_cube_mesh(0.1), SPACING)
        assert np.allclose(_box_gap(pts, half), 0.0)
        truth = _uniform_on_box(rng, half, 4000)
    elif kind == "sphere":
        pts = surface_points(coal.Sphere(0.1), SPACING)
        assert np.allclose(np.linalg.norm(pts, axis=1), 0.1)
        truth = 0.1 * _on_sphere(rng, 4000)
    elif kind == "cylinder":
        r, half = 0.05, 0.1
        pts = surface_points(coal.Cylinder(r, 2 * half), SPACING)
        radial = np.linalg.norm(pts[:, :2], axis=1)
        assert np.all(np.isclose(radial, r) | np.isclose(np.abs(pts[:, 2]), half))
        assert np.all((radial <= r + 1e-12) & (np.abs(pts[:, 2]) <= half + 1e-12))
        truth = _cylinder_surface(rng, r, half, 2000)
    else:
        r, half = 0.05, 0.1
        pts = surface_points(coal.Capsule(r, 2 * half), SPACING)
        axis = np.column_stack([np.zeros((len(pts), 2)), np.clip(pts[:, 2], -half, half)])
        assert np.allclose(np.linalg.norm(pts - axis, axis=1), r)       # capsule = points at r from the segment
        truth = None
    if truth is not None:
        gap, _ = cKDTree(pts).query(truth)
        assert gap.max() <= SPACING
