"""The cost component ``voxel``: cost of deformation of a robot over the voxelised scene.

Implements thesis ch. 3: per robot point overlapping an object, eq. 3.1 (see :mod:`.formula`);
free space contributes nothing; the state cost is the sum over the robot's points.  NaN marks an
infeasible state: a rigid point in a rigid voxel (implicit collision), a forbidden object (NaN
sensitivity), or any point outside the grid.  The gradient is eq. 3.2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import FREE_VOXEL as FREE
from pliant.api import CostModel, DimensionError, VoxelGrid, check_batch, option

from pliant_voxel.formula import code_dtype, compress_table, cost_tables
from pliant_voxel.kernels import (
    point_costs,
    rigid_state_breakdown,
    rigid_state_costs,
    state_costs,
    trilinear_with_gradient,
)


@dataclass(frozen=True)
class VoxelCostOptions:
    """Options of :class:`VoxelDeformationCost`."""

    padding: float = option(0.0, "dilate every object by this distance (m) before costing (thesis 3.3.3)",
                            minimum=0.0)


class VoxelDeformationCost(CostModel):
    """Cost of deformation (thesis eq. 3.1) summed over the robot's points; gradient by eq. 3.2.

    ``cost(q)`` ``(n, d) -> (n,)``, dimensionless (sensitivity units per overlapping voxel).
    ``breakdown(q)`` gives one column per scene object (the learning chapter's features).
    ``gradient(q)`` ``(n, t)`` is the exact gradient of the smooth surrogate
    ``S(q) = sum_i C_i * max(0, -sdf(x_i(q)))`` with each point's cost ``C_i`` held fixed: the
    workspace gradient ``-grad sdf`` of every penetrating point, scaled by its cost and mapped through
    the point Jacobians, ``J^T [C_1 grad x_1, ...]`` (eq. 3.2).
    """

    Options = VoxelCostOptions
    has_gradient = True

    def bind(self, context) -> None:
        super().bind(context)
        scene = self.require("scene")
        self.robot = self.require("robot")
        self.grid = VoxelGrid.from_scene(scene, self.options.padding)
        self.classes, self.table = cost_tables(self.robot.point_materials(), self.grid.deformability,
                                               self.grid.sensitivity, self.grid.occupied)
        self._lower = np.ascontiguousarray(self.grid.lower, dtype=np.float64)
        self._inv_res = 1.0 / self.grid.resolution
        self._shape = np.asarray(self.grid.shape, dtype=np.int64)
        self._materials, self._lut = compress_table(self.table)     # the rigid kernel's cache-friendly form
        self._layout_of = (None,)
        self._object_of_voxel = np.append(self.grid.object_id.reshape(-1), FREE).astype(np.int64)
        self._breakdown_tables = None

    # --- evaluation ---------------------------------------------------------------------------

    def _batch(self, q) -> np.ndarray:
        q, _ = check_batch(q, self.robot.space)
        return q

    def cost(self, q):
        q = self._batch(q)
        out = np.empty(len(q))
        placement = self.robot.rigid_placement(q)
        if placement is not None:
            rot, pos, local = placement
            columns, centre, half = self._local_layout(local)
            rigid_state_costs(np.ascontiguousarray(rot), np.ascontiguousarray(pos), columns, centre, half, self._lower,
                              self._inv_res, self._shape, self.classes, self._materials, self._lut, out)
        else:
            state_costs(self.robot.body_points(q), self._lower, self._inv_res, self._shape, self.classes,
                        self.table, out)
        return out

    def _local_layout(self, local: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rigid body's local points ``(m, 3)`` as rows per axis ``(3, m)``, and their bounding box's
        centre and half extents (m); cached for the robot's point array."""
        if self._layout_of[0] is not local:
            lo, hi = (local.min(axis=0), local.max(axis=0)) if len(local) else (np.zeros(3), np.zeros(3))
            self._layout_of = (local, np.ascontiguousarray(local.T), (lo + hi) / 2, (hi - lo) / 2)
        return self._layout_of[1:]

    def _points_and_costs(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Body points ``(n, m, 3)`` of configurations ``(n, d)`` and each point's cost ``(n, m)``."""
        pts = self.robot.body_points(self._batch(q))
        costs = np.empty(pts.shape[:2])
        point_costs(pts, self._lower, self._inv_res, self._shape, self.classes, self.table, costs)
        return pts, costs

    def point_costs(self, q) -> np.ndarray:
        """Cost of every robot point ``(n, m)`` (0 in free space, NaN where infeasible)."""
        return self._points_and_costs(q)[1]

    def breakdown(self, q):
        q = self._batch(q)
        k = len(self.grid.object_names)
        placement = self.robot.rigid_placement(q)
        if placement is not None:                   # the fused kernel: no (n, m, 3) temporaries
            rot, pos, local = placement
            columns, centre, half = self._local_layout(local)
            out = np.zeros((len(q), k))
            rigid_state_breakdown(np.ascontiguousarray(rot), np.ascontiguousarray(pos), columns, centre, half,
                                  self._lower, self._inv_res, self._shape, self.classes, *self._breakdown_form(), out)
            return out
        pts, costs = self._points_and_costs(q)
        flat = self.grid.flat_index(pts)
        obj = self._object_of_voxel[np.where(flat < 0, len(self._object_of_voxel) - 1, flat)]
        out = np.zeros((len(q), k))
        rows = np.repeat(np.arange(len(q)), pts.shape[1])
        hit = obj.reshape(-1) >= 0
        np.add.at(out, (rows[hit], obj.reshape(-1)[hit]), costs.reshape(-1)[hit])
        bad = ~np.isfinite(costs).all(axis=1)
        out[bad] = np.nan
        return out

    def _breakdown_form(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The breakdown kernel's tables: one code per flat voxel for each (material, object) pair present, the cost
        of each class on each code ``(c, k)`` and each code's object ``(k,)``; built on the first breakdown (O(N))."""
        if self._breakdown_tables is None:
            objects = len(self.grid.object_names) + 1                           # FREE (-1) -> 0
            pair = self._materials.astype(np.int64) * objects + (self._object_of_voxel + 1)
            present = np.zeros(int(pair.max()) + 1, dtype=bool)
            present[pair] = True
            ids = np.flatnonzero(present)
            remap = np.cumsum(present) - 1
            self._breakdown_tables = (remap[pair].astype(code_dtype(len(ids))),
                                      np.ascontiguousarray(self._lut[:, ids // objects]), ids % objects - 1)
        return self._breakdown_tables

    def feature_names(self):
        return list(self.grid.object_names)

    def gradient(self, q):
        q = self._batch(q)
        pts, costs = self._points_and_costs(q)
        sdf, sdf_gradient = self._sdf_with_gradient(pts)
        weights = np.where((sdf < 0) & np.isfinite(costs), costs, 0.0)
        if not weights.any():
            return np.zeros((len(q), self.robot.space.tangent_dim))
        jac = self.robot.point_jacobians(q)                             # (n, m, 3, t)
        work = weights[..., None] * -sdf_gradient                        # (n, m, 3): C_i * grad x_i
        return np.einsum("nmk,nmkt->nt", work, jac)

    def _sdf_with_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The grid's interpolated signed distance ``(n, m)`` and its gradient ``(n, m, 3)`` at ``points``
        (one fused numba pass; equal to ``grid.sdf_at`` / ``grid.sdf_gradient_at``)."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        value = np.empty(points.shape[:2])
        gradient = np.empty(points.shape)
        trilinear_with_gradient(self.grid.sdf, self.grid.lower, float(self.grid.resolution), points, value, gradient)
        return value, gradient

    def surrogate(self, q) -> np.ndarray:
        """The smooth surrogate ``S(q) = sum_i C_i max(0, -sdf(x_i))`` whose gradient :meth:`gradient` is.

        ``C_i`` are the points' costs at ``q`` (NaN costs count as 0).  :meth:`gradient` holds them
        fixed, so its finite-difference check must too (as the tests do).
        """
        pts, costs = self._points_and_costs(q)
        return np.sum(np.where(np.isfinite(costs), costs, 0.0) * np.maximum(0.0, -self.grid.sdf_at(pts)), axis=1)

    # --- translation lattices -----------------------------------------------------------------

    def translation_costs(self, origin, spacing, shape, base=None):
        """State costs of every translation on the grid's own lattice, by shifted-field summation.

        For a pure-translation robot (an ``rn`` space of dimension 3 whose body moves rigidly with
        ``q``) on the lattice of voxel centres, the state cost at cell ``x`` is
        ``sum_i F_{c(i)}[x + o_i]`` where ``o_i`` is point ``i``'s voxel offset and ``F_c`` the
        cost field of material class ``c`` (thesis 3.2.3: correlate the robot with the
        environment).  Exact; other lattices fall back to batched :meth:`cost`.
        """
        origin = np.asarray(origin, dtype=np.float64)
        grid = self.grid
        offsets = self._translation_offsets()
        aligned = (offsets is not None and tuple(shape) == grid.shape and abs(spacing - grid.resolution) < 1e-12
                   and np.allclose(origin, grid.lower + 0.5 * grid.resolution, atol=1e-9 * grid.resolution))
        if not aligned:
            return super().translation_costs(origin, spacing, shape, base)
        nx, ny, nz = grid.shape
        pad = int(np.max(np.abs(offsets))) + 1
        total = np.zeros(grid.shape)
        for c in range(len(self.table)):
            field_ = np.full((nx + 2 * pad, ny + 2 * pad, nz + 2 * pad), np.nan)
            field_[pad:-pad, pad:-pad, pad:-pad] = self.table[c, :-1].reshape(grid.shape)
            for o in offsets[self.classes == c]:
                total += field_[pad + o[0]:pad + o[0] + nx, pad + o[1]:pad + o[1] + ny, pad + o[2]:pad + o[2] + nz]
        return total

    def _translation_offsets(self) -> np.ndarray | None:
        space = self.robot.space
        if space.kind != "rn" or space.dim != 3:
            return None
        probe = np.array([space.lower, (space.lower + space.upper) / 2])
        pts = self.robot.body_points(probe)
        rel = pts - probe[:, None, :]
        if not np.allclose(rel[0], rel[1]):
            return None
        units = rel[0] / self.grid.resolution
        offsets = np.round(units).astype(np.int64)
        if not np.allclose(units, offsets, atol=1e-6):
            raise DimensionError("robot points are not on the voxel lattice; translation_costs needs them there",
                                 field="robot.parts", value=float(np.abs(units - offsets).max()))
        return offsets
