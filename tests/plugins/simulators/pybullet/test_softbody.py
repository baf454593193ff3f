"""Soft bodies: the tetrahedral mesh, volume conserved at rest, volume change under load."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from pliant.errors import ConfigError
from pliant_pybullet.softbody import SoftBox, box_tetrahedra, box_ticks, tetrahedron_volumes


def test_box_mesh_fills_the_box():
    nodes, tets = box_tetrahedra((0.2, 0.4, 0.1), 3)
    assert len(tets) == 5 * 27
    assert tetrahedron_volumes(nodes, tets).sum() == pytest.approx(0.2 * 0.4 * 0.1)
    assert np.all(tetrahedron_volumes(nodes, tets) > 0)


def test_box_mesh_is_conforming_and_consistently_oriented():
    nodes, tets = box_tetrahedra(0.2, (5, 4, 4))
    assert len(tets) == 400                                    # the thesis's count
    a, b, c, d = (nodes[tets[:, i]] for i in range(4))
    assert np.all(np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) > 0)
    faces = Counter(tuple(sorted(t[list(f)])) for t in tets for f in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)))
    # every face is shared by two tetrahedra except the box's surface: 2 triangles per boundary quad
    boundary = 2 * 2 * (5 * 4 + 5 * 4 + 4 * 4)
    assert Counter(faces.values()) == {1: boundary, 2: (4 * len(tets) - boundary) // 2}


def test_node_planes_snap_to_a_core():
    ticks = box_ticks(0.2, (5, 4, 4), snap=(np.full(3, -0.04), np.full(3, 0.02)))
    for t in ticks:
        assert np.any(np.isclose(t, -0.04)) and np.any(np.isclose(t, 0.02))
        assert t[0] == -0.1 and t[-1] == 0.1 and np.all(np.diff(t) > 0)
    assert [len(t) - 1 for t in ticks] == [5, 4, 4]
    with pytest.raises(ConfigError, match="cells"):
        box_ticks(0.2, 0)
    with pytest.raises(ConfigError, match="size"):
        box_ticks(-0.2, 3)


def _world():
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    client = BulletClient(connection_mode=pybullet.DIRECT)
    client.resetSimulation(client.RESET_USE_DEFORMABLE_WORLD)
    client.setGravity(0, 0, 0)
    client.setTimeStep(1 / 240)
    return client


def test_volume_is_conserved_at_rest_and_changes_under_load():
    free = _world()
    cube = SoftBox(free, 0.2, 3, [0, 0, 0.5])
    for _ in range(60):
        free.stepSimulation()
    at_rest = cube.deformation()
    assert np.allclose(cube.nodes().mean(axis=0), [0, 0, 0.5], atol=1e-6)
    free.disconnect()

    pressed = _world()
    shape = pressed.createCollisionShape(pressed.GEOM_BOX, halfExtents=[0.5, 0.025, 0.5])
    pressed.createMultiBody(0, shape, basePosition=[0, 0.15, 0.5])
    cube = SoftBox(pressed, 0.2, 3, [0, 0.06, 0.5])           # overlapping the wall by 0.035 m
    for _ in range(60):
        pressed.stepSimulation()
    loaded = cube.deformation()
    assert pressed.getContactPoints()
    pressed.disconnect()
    assert at_rest < 1e-3 * 0.2 ** 3 and loaded > 10 * max(at_rest, 1e-12)
