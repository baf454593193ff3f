"""A free-flying rigid body as a set of material points (thesis 3.2.1).

The moving object is represented by the centres of the voxels it occupies at the scene resolution
(the environment is voxelised, the robot is not, to avoid re-voxelising rotated bodies).  Each point
carries the deformability and sensitivity of the part it belongs to.  Point Jacobians are analytic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import (
    PlanningError,
    RealVectorSpace,
    RobotModel,
    RobotSpec,
    Scene,
    SE2Space,
    SE3Space,
    Space,
    check_batch,
    option,
    quat_to_matrix,
    rotation_z,
)


@dataclass(frozen=True)
class RigidBodyOptions:
    """Options of :class:`RigidBody`."""

    resolution: float | None = option(None, "spacing of body points in metres (default: the scene resolution)",
                                      minimum=1e-6)
    translation_weight: float = option(1.0, "weight of translation in the distance metric (se2/se3)", minimum=1e-9)
    rotation_weight: float = option(1.0, "weight of rotation (rad) in the distance metric (se2/se3)", minimum=1e-9)


def sample_body_points(spec: RobotSpec, resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """Body points ``(m, 3)`` in the robot frame and their materials ``(m, 2)``.

    Points lie on the lattice ``resolution * Z^3`` (the robot frame origin is a voxel centre); a
    lattice point belongs to the body if any part contains it; where parts overlap, the later part's
    material wins.
    """
    points, materials = [], []
    for rp in spec.parts:
        lo, hi = rp.part.bounds()
        axes = [np.arange(np.ceil(lo[i] / resolution - 1e-9), np.floor(hi[i] / resolution + 1e-9) + 1) * resolution
                for i in range(3)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        inside = grid[rp.part.contains(grid)]
        points.append(inside)
        materials.append(np.tile([rp.material.deformability, rp.material.sensitivity], (len(inside), 1)))
    pts = np.concatenate(points)
    mats = np.concatenate(materials)
    keys = np.round(pts / resolution).astype(np.int64)
    # keep the last occurrence of each lattice point (later parts override earlier ones)
    _, last = np.unique(keys[::-1], axis=0, return_index=True)
    keep = np.sort(len(keys) - 1 - last)
    return pts[keep], mats[keep]


class RigidBody(RobotModel):
    """A free-flying rigid body from the scene's ``[robot]`` parts.

    Spaces: ``r3`` (translation ``(x, y, z)``), ``se2`` (``(x, y, theta)``, rotation about z) or
    ``se3`` (``(x, y, z, qx, qy, qz, qw)``), bounded by the scene's workspace.  Tangent motions for
    SE(3) are ``(v, w)`` in the world frame, so a point ``p`` moves by ``v + w x (p - c)``.
    """

    Options = RigidBodyOptions

    def bind(self, context) -> None:
        super().bind(context)
        scene: Scene = self.require("scene")
        spec = scene.robot
        if spec.kind != "rigid":
            raise PlanningError("the rigid robot needs a scene whose [robot] kind is 'rigid'",
                                source=scene.source, field="robot.kind", value=spec.kind)
        self.spec = spec
        res = self.options.resolution or scene.resolution
        self._points, self._materials = sample_body_points(spec, res)
        if len(self._points) == 0:
            raise PlanningError("the robot's parts contain no point at this resolution", source=scene.source,
                                field="robot.parts", value=res)
        self._space = self._make_space(scene)
        self._spacing = res
        self._surface = None
        self._open = None

    def _make_space(self, scene: Scene) -> Space:
        o = self.options
        if self.spec.space == "r3":
            return RealVectorSpace(scene.lower, scene.upper, self.spec.weights)
        if self.spec.space == "se2":
            return SE2Space(scene.lower[:2], scene.upper[:2], o.translation_weight, o.rotation_weight)
        return SE3Space(scene.lower, scene.upper, o.translation_weight, o.rotation_weight)

    @property
    def space(self) -> Space:
        return self._space

    @property
    def local_points(self) -> np.ndarray:
        """Body points ``(m, 3)`` in the robot frame (metres)."""
        return self._points

    def point_materials(self) -> np.ndarray:
        return self._materials

    def rotations(self, q: np.ndarray) -> np.ndarray:
        """Rotation matrices ``(n, 3, 3)`` of configurations ``(n, d)``."""
        if self.spec.space == "r3":
            return np.broadcast_to(np.eye(3), (len(q), 3, 3))
        if self.spec.space == "se2":
            return rotation_z(q[:, 2])
        return quat_to_matrix(q[:, 3:7])

    def positions(self, q: np.ndarray) -> np.ndarray:
        """Reference-point positions ``(n, 3)`` of configurations ``(n, d)``."""
        if self.spec.space == "se2":
            return np.column_stack([q[:, :2], np.zeros(len(q))])
        return q[:, :3]

    def rigid_placement(self, q):
        q, _ = check_batch(q, self._space)
        return self.rotations(q), self.positions(q), self._points

    def _open_faces(self) -> np.ndarray:
        """``(m, 6)``: for every body point, which lattice neighbours (-x, +x, -y, +y, -z, +z) are not in the body."""
        if self._open is None:
            keys = np.round(self._points / self._spacing).astype(np.int64)
            present = set(map(tuple, keys))
            steps = [(-1, 0, 0), (1, 0, 0), (0, -1, 0), (0, 1, 0), (0, 0, -1), (0, 0, 1)]
            self._open = np.array([[(k[0] + a, k[1] + b, k[2] + c) not in present for a, b, c in steps]
                                   for k in map(tuple, keys)], dtype=bool).reshape(-1, 6)
        return self._open

    def surface_indices(self):
        """Points with at least one of their six lattice neighbours outside the body."""
        if self._surface is None:
            self._surface = np.nonzero(self._open_faces().any(axis=1))[0].astype(np.int64)
        return self._surface

    def surface_faces(self):
        """For each surface point, the lattice directions (body frame) with no body point next to it."""
        return self._open_faces()[self.surface_indices()]

    def _local(self, indices):
        return self._points if indices is None else self._points[indices]

    def body_points(self, q, indices=None):
        q, _ = check_batch(q, self._space)
        # one BLAS product for the whole batch: (n, 3, 3) x (m, 3) -> (n, 3, m)
        world = np.tensordot(self.rotations(q), self._local(indices), axes=([2], [1])).transpose(0, 2, 1)
        return world + self.positions(q)[:, None, :]

    def point_jacobians(self, q, indices=None):
        q, _ = check_batch(q, self._space)
        local = self._local(indices)
        n, m = len(q), len(local)
        jac = np.zeros((n, m, 3, self._space.tangent_dim))
        if self.spec.space == "r3":
            jac[..., 0, 0] = jac[..., 1, 1] = jac[..., 2, 2] = 1.0
            return jac
        rel = np.tensordot(self.rotations(q), local, axes=([2], [1])).transpose(0, 2, 1)  # p - c
        if self.spec.space == "se2":
            jac[..., 0, 0] = jac[..., 1, 1] = 1.0
            jac[..., 0, 2] = -rel[..., 1]
            jac[..., 1, 2] = rel[..., 0]
            return jac
        jac[..., 0, 0] = jac[..., 1, 1] = jac[..., 2, 2] = 1.0
        # d/dw (w x r) = -[r]_x
        jac[..., 0, 4], jac[..., 0, 5] = rel[..., 2], -rel[..., 1]
        jac[..., 1, 3], jac[..., 1, 5] = -rel[..., 2], rel[..., 0]
        jac[..., 2, 3], jac[..., 2, 4] = rel[..., 1], -rel[..., 0]
        return jac
