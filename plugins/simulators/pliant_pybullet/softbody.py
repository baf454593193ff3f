"""Soft bodies in pybullet: tetrahedral meshes of boxes, and their deformation as volume change.

Thesis 3.3.4 validates the voxel cost of deformation against Bullet's soft bodies: the deformable
cube is a tetrahedral mesh, and "deformation is assessed by computing the current volume of each
tetrahedron (m^3) and comparing the total against an undeformed reference".  We report the sum of
absolute per-tetrahedron volume changes, which (unlike the change of the total) does not let
compression in one place cancel expansion in another.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

# five tetrahedra per hexahedral cell (corners numbered as in the VTK hexahedron)
_CELL_TETS = ((0, 1, 3, 4), (1, 2, 3, 6), (1, 4, 5, 6), (3, 4, 6, 7), (1, 3, 4, 6))


def box_tetrahedra(size, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``(k, 3)`` and tetrahedra ``(t, 4)`` filling a box of ``size`` (m) centred at the origin.

    ``cells`` hexahedra per axis, five tetrahedra each (``5 cells^3`` in all).
    """
    size = np.broadcast_to(np.asarray(size, dtype=np.float64), (3,))
    axes = [np.linspace(-size[i] / 2, size[i] / 2, cells + 1) for i in range(3)]
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)

    def index(i, j, k):
        return (i * (cells + 1) + j) * (cells + 1) + k

    tets = []
    for i in range(cells):
        for j in range(cells):
            for k in range(cells):
                corners = (index(i, j, k), index(i + 1, j, k), index(i + 1, j + 1, k), index(i, j + 1, k),
                           index(i, j, k + 1), index(i + 1, j, k + 1), index(i + 1, j + 1, k + 1),
                           index(i, j + 1, k + 1))
                tets.extend([corners[a] for a in t] for t in _CELL_TETS)
    return nodes, np.array(tets, dtype=np.int64)


def tetrahedron_volumes(nodes: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Unsigned volumes ``(t,)`` (m^3) of tetrahedra ``(t, 4)`` over ``nodes`` ``(k, 3)``."""
    a, b, c, d = (nodes[tets[:, i]] for i in range(4))
    return np.abs(np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))) / 6.0


def write_vtk(nodes: np.ndarray, tets: np.ndarray, path: Path) -> Path:
    """Write an ASCII VTK unstructured grid of tetrahedra (the format pybullet's ``loadSoftBody`` reads)."""
    lines = ["# vtk DataFile Version 2.0", "pliant tetrahedral mesh", "ASCII", "DATASET UNSTRUCTURED_GRID",
             f"POINTS {len(nodes)} double", *(f"{x:.17g} {y:.17g} {z:.17g}" for x, y, z in nodes.tolist()),
             f"CELLS {len(tets)} {5 * len(tets)}", *("4 " + " ".join(map(str, t)) for t in tets),
             f"CELL_TYPES {len(tets)}", *("10" for _ in tets)]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


class SoftBox:
    """A soft box loaded into a pybullet client (deformable world), with its deformation measure.

    ``stiffness`` is the Neo-Hookean (mu, lambda) pair in Pa-like units of Bullet's solver.
    """

    def __init__(self, client, size, cells: int, position, mass: float = 1.0, stiffness=(180.0, 600.0),
                 friction: float = 0.5) -> None:
        self.client = client
        self.nodes0, self.tets = box_tetrahedra(size, cells)
        self.rest = tetrahedron_volumes(self.nodes0, self.tets)
        # the mesh file must outlive the body: pybullet reads it again when it first steps the soft body
        self._directory = tempfile.TemporaryDirectory()
        path = write_vtk(self.nodes0, self.tets, Path(self._directory.name) / "box.vtk")
        self.body = client.loadSoftBody(str(path), basePosition=list(position), mass=mass, useNeoHookean=1,
                                        NeoHookeanMu=stiffness[0], NeoHookeanLambda=stiffness[1],
                                        NeoHookeanDamping=0.01, collisionMargin=0.002, useSelfCollision=0,
                                        frictionCoeff=friction)

    def nodes(self) -> np.ndarray:
        """Current node positions ``(k, 3)`` (valid once the world has been stepped)."""
        _, verts = self.client.getMeshData(self.body, flags=self.client.MESH_DATA_SIMULATION_MESH)
        return np.asarray(verts, dtype=np.float64)

    def deformation(self) -> float:
        """Sum of absolute volume changes of the tetrahedra (m^3), thesis 3.3.4."""
        return float(np.sum(np.abs(tetrahedron_volumes(self.nodes(), self.tets) - self.rest)))
