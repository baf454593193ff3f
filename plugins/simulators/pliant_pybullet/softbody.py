"""Soft bodies in pybullet: tetrahedral meshes of boxes, and their deformation as volume change.

Thesis 3.3.4 validates the voxel cost of deformation against Bullet's soft bodies: the deformable
cube is a tetrahedral mesh, and "deformation is assessed by computing the current volume of each
tetrahedron (m^3) and comparing the total against an undeformed reference".  We report the sum of
absolute per-tetrahedron volume changes, which (unlike the change of the total) does not let
compression in one place cancel expansion in another.

The meshes (conforming: five tetrahedra per hexahedral cell) come from :mod:`pliant.geometry.tetmesh` in the core, which
deformability probing (thesis app. A) uses too.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from pliant.api import DimensionError, box_tetrahedra, box_ticks, tetrahedron_volumes, write_vtk

__all__ = ["SoftBox", "box_tetrahedra", "box_ticks", "tetrahedron_volumes", "write_vtk"]


class SoftBox:
    """A soft box loaded into a pybullet client (deformable world), with its deformation measure.

    ``size`` (m) and ``cells`` define the mesh (:func:`box_tetrahedra`), or ``mesh = (nodes (k, 3),
    tets (t, 4))`` gives one directly, in the body's frame; ``position`` (m) and ``orientation``
    (qx, qy, qz, qw) place that frame in the world.  ``mass`` in kg; ``stiffness`` is the Neo-Hookean
    (mu, lambda) pair in Pa; ``damping`` Bullet's Neo-Hookean damping (s).  Thesis 3.3.4.
    """

    def __init__(self, client, size=0.2, cells=4, position=(0.0, 0.0, 0.0), mass: float = 1.0,
                 stiffness=(180.0, 600.0), friction: float = 0.5, *, mesh=None, orientation=(0.0, 0.0, 0.0, 1.0),
                 damping: float = 0.01, margin: float = 0.002) -> None:
        self.client = client
        if mesh is None:
            self.nodes0, self.tets = box_tetrahedra(size, cells)
        else:
            self.nodes0 = np.asarray(mesh[0], dtype=np.float64)
            self.tets = np.asarray(mesh[1], dtype=np.int64)
            if self.nodes0.ndim != 2 or self.nodes0.shape[1] != 3 or self.tets.ndim != 2 or self.tets.shape[1] != 4:
                raise DimensionError("a mesh is nodes (k, 3) and tetrahedra (t, 4)", field="mesh",
                                     value=(self.nodes0.shape, self.tets.shape))
        self.rest = tetrahedron_volumes(self.nodes0, self.tets)
        # the mesh file must outlive the body: pybullet reads it again when it first steps the soft body
        self._directory = tempfile.TemporaryDirectory()
        path = write_vtk(self.nodes0, self.tets, Path(self._directory.name) / "box.vtk")
        self.body = client.loadSoftBody(str(path), basePosition=list(position), baseOrientation=list(orientation),
                                        mass=mass, useNeoHookean=1, NeoHookeanMu=stiffness[0],
                                        NeoHookeanLambda=stiffness[1], NeoHookeanDamping=damping,
                                        collisionMargin=margin, useSelfCollision=0, frictionCoeff=friction)

    def nodes(self) -> np.ndarray:
        """Current node positions ``(k, 3)`` (m, world frame; valid once the world has been stepped)."""
        _, verts = self.client.getMeshData(self.body, flags=self.client.MESH_DATA_SIMULATION_MESH)
        return np.asarray(verts, dtype=np.float64)

    def volume_changes(self, nodes: np.ndarray | None = None) -> np.ndarray:
        """Absolute volume change ``(t,)`` (m^3) of each tetrahedron against the rest mesh, thesis 3.3.4."""
        return np.abs(tetrahedron_volumes(self.nodes() if nodes is None else nodes, self.tets) - self.rest)

    def deformation(self, nodes: np.ndarray | None = None) -> float:
        """Sum of absolute volume changes of the tetrahedra (m^3), thesis 3.3.4."""
        return float(np.sum(self.volume_changes(nodes)))
