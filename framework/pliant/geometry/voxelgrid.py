"""The voxelised environment of a scene (thesis 3.2.1), shared by cost models, simulators and metrics.

A :class:`VoxelGrid` stores, per voxel of the scene's grid (x-major numpy order, voxel ``(i, j, k)``
centred at ``lower + (idx + 0.5) * resolution``), the deformability, the sensitivity and the id of
the object occupying it (-1: free space, deformability 1, sensitivity 0).  Later objects override
earlier ones where they overlap.  The signed distance field (metres, negative inside objects) is
computed on first use with an exact Euclidean distance transform.

Both are kept in the content-addressed cache (:mod:`pliant.cache`): a grid under a hash of the scene's objects,
bounds and resolution, the padding and the flags; a distance field under a hash of the occupancy and the
resolution.  A second run over the same scene loads them instead of voxelising again.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from pliant import cache
from pliant.errors import DimensionError

if TYPE_CHECKING:
    from pliant.scene import Scene

FREE = -1
#: versions of the cached builds: change one whenever its algorithm's output changes
GRID_VERSION = "voxelgrid-2"
SDF_VERSION = "sdf-1"


@dataclass
class VoxelGrid:
    """Per-voxel materials and object ids of an environment.

    lower: ``(3,)`` world position of the grid's lower corner (m).
    resolution: voxel edge (m).
    deformability, sensitivity: ``(nx, ny, nz)`` float64.
    object_id: ``(nx, ny, nz)`` int32, index into ``object_names`` or -1 for free space.
    """

    lower: np.ndarray
    resolution: float
    deformability: np.ndarray
    sensitivity: np.ndarray
    object_id: np.ndarray
    object_names: list[str]
    _sdf: np.ndarray | None = field(default=None, repr=False)
    _sdf_gradient: np.ndarray | None = field(default=None, repr=False)

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.object_id.shape

    @property
    def occupied(self) -> np.ndarray:
        """Bool ``(nx, ny, nz)``: voxels that belong to an object."""
        return self.object_id != FREE

    def centres(self, index: np.ndarray) -> np.ndarray:
        """World positions ``(n, 3)`` of voxel indices ``(n, 3)``."""
        return self.lower + (np.asarray(index, dtype=np.float64) + 0.5) * self.resolution

    def index(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Voxel indices ``(..., 3)`` of points ``(..., 3)`` and a bool mask of those inside the grid."""
        idx = np.floor((np.asarray(points, dtype=np.float64) - self.lower) / self.resolution).astype(np.int64)
        inside = np.all((idx >= 0) & (idx < np.array(self.shape)), axis=-1)
        return idx, inside

    def flat_index(self, points: np.ndarray) -> np.ndarray:
        """Flat (C-order) voxel index of each point ``(..., 3)``; -1 where the point lies outside."""
        idx, inside = self.index(points)
        _, ny, nz = self.shape
        flat = (idx[..., 0] * ny + idx[..., 1]) * nz + idx[..., 2]
        return np.where(inside, flat, -1)

    # --- signed distance ----------------------------------------------------------------------

    @property
    def sdf(self) -> np.ndarray:
        """Signed distance (m) from each voxel centre to the nearest object boundary; < 0 inside.

        Exact Euclidean transform (``scipy.ndimage.distance_transform_edt``) of the voxel
        occupancy; a voxel's value is the distance to the nearest voxel of the other kind, minus
        half a voxel, so the zero level set lies on voxel faces.
        """
        if self._sdf is None:
            occ = self.occupied
            if not occ.any():
                self._sdf = np.full(self.shape, np.inf)
            elif occ.all():
                self._sdf = np.full(self.shape, -np.inf)
            else:
                self._sdf = cache.cached_arrays("sdf", SDF_VERSION, (occ, float(self.resolution)),
                                                lambda: {"sdf": _signed_distance(occ, self.resolution)})["sdf"]
        return self._sdf

    @property
    def sdf_gradient(self) -> np.ndarray:
        """``(nx, ny, nz, 3)`` central-difference gradient of :attr:`sdf` (dimensionless, ~unit length)."""
        if self._sdf_gradient is None:
            sdf = self.sdf
            if not np.all(np.isfinite(sdf)):
                self._sdf_gradient = np.zeros(self.shape + (3,))
            else:
                axes = [i for i in range(3) if self.shape[i] > 1]
                grad = np.zeros(self.shape + (3,))
                parts = np.gradient(sdf, self.resolution, axis=axes)
                parts = parts if isinstance(parts, (list, tuple)) else [parts]
                for a, g in zip(axes, parts):
                    grad[..., a] = g
                self._sdf_gradient = grad
        return self._sdf_gradient

    def sdf_at(self, points: np.ndarray) -> np.ndarray:
        """Trilinearly interpolated signed distance at world points ``(..., 3)`` (clamped to the grid)."""
        return _trilinear(self.sdf, self._continuous(points))

    def sdf_gradient_at(self, points: np.ndarray) -> np.ndarray:
        """Exact gradient ``(..., 3)`` of :meth:`sdf_at` (the trilinear interpolant) at world points.

        Being the derivative of the interpolant itself, it matches finite differences of
        :meth:`sdf_at` everywhere except on voxel-centre planes, where the interpolant has kinks.
        """
        return _trilinear_gradient(self.sdf, self._continuous(points)) / self.resolution

    def _continuous(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64)
        if points.shape[-1] != 3:
            raise DimensionError("points must be (..., 3)", field="points", value=list(points.shape))
        return (points - self.lower) / self.resolution - 0.5

    def boxes(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The occupied voxels as few axis-aligned boxes ``(lower (3,), upper (3,))`` in metres.

        Greedy merging: runs along x, then equal runs on consecutive y rows, then equal rectangles on
        consecutive z layers.  Exact (the union is the occupied set); backends that need primitive
        shapes (pybullet, pymunk) use it so that cut-outs and meshes are represented faithfully.
        """
        occ = self.occupied
        padded = np.zeros((occ.shape[0] + 2,) + occ.shape[1:], dtype=np.int8)
        padded[1:-1] = occ
        edges = np.diff(padded, axis=0)
        starts = np.argwhere(edges == 1)                 # (x0, y, z)
        stops = np.argwhere(edges == -1)                 # (x1, y, z), same order (x-runs per (y, z) row)
        order_a = np.lexsort((starts[:, 0], starts[:, 1], starts[:, 2]))
        order_b = np.lexsort((stops[:, 0], stops[:, 1], stops[:, 2]))
        runs = [(int(a[0]), int(b[0]), int(a[1]), int(a[2])) for a, b in zip(starts[order_a], stops[order_b])]
        # merge along y: key (x0, x1, z) -> open rectangle (y0, y1)
        rects: dict[tuple[int, int, int, int], int] = {}
        open_rect: dict[tuple[int, int, int], tuple[int, int]] = {}
        for x0, x1, y, z in sorted(runs, key=lambda r: (r[3], r[2], r[0])):
            key = (x0, x1, z)
            if key in open_rect and open_rect[key][1] == y:
                open_rect[key] = (open_rect[key][0], y + 1)
            else:
                if key in open_rect:
                    y0, y1 = open_rect[key]
                    rects[(x0, x1, y0, y1, z)] = 1
                open_rect[key] = (y, y + 1)
        for (x0, x1, z), (y0, y1) in open_rect.items():
            rects[(x0, x1, y0, y1, z)] = 1
        # merge along z
        out: list[tuple[int, int, int, int, int, int]] = []
        open_box: dict[tuple[int, int, int, int], tuple[int, int]] = {}
        for x0, x1, y0, y1, z in sorted(rects, key=lambda r: (r[4], r[0], r[2])):
            key = (x0, x1, y0, y1)
            if key in open_box and open_box[key][1] == z:
                open_box[key] = (open_box[key][0], z + 1)
            else:
                if key in open_box:
                    out.append((*key, *open_box[key]))
                open_box[key] = (z, z + 1)
        out.extend((*key, *span) for key, span in open_box.items())
        res = self.resolution
        return [(self.lower + np.array([x0, y0, z0]) * res, self.lower + np.array([x1, y1, z1]) * res)
                for x0, x1, y0, y1, z0, z1 in out]

    # --- construction -------------------------------------------------------------------------

    @classmethod
    def from_scene(cls, scene: Scene, padding: float = 0.0, static_only: bool = False) -> VoxelGrid:
        """Voxelise ``scene``'s objects at its resolution.

        ``padding`` (m, >= 0) dilates every object by that distance (thesis 3.3.3: widening the
        low-cost chasm); padded voxels take the material of the object they grow from.
        ``static_only`` leaves out the movable objects (those with a ``mass``), for dynamic backends
        that simulate them as bodies and build walls from the rest; object ids still index
        ``scene.objects`` (``object_names`` lists every object), so ids mean the same in both grids.
        By default every object is voxelised at its scene pose (the voxel cost and the kinematic
        simulator hold movable objects fixed).
        """
        if padding < 0 or not np.isfinite(padding):
            raise DimensionError("padding must be a finite distance >= 0", field="padding", value=padding)
        # the key: what the grid depends on (static_only only through the objects it leaves out, so that a scene
        # without movable objects has one grid)
        voxelised = [("left out", o.name) if static_only and o.movable else o for o in scene.objects]
        inputs = (np.asarray(scene.lower, dtype=np.float64), np.asarray(scene.upper, dtype=np.float64),
                  float(scene.resolution), tuple(scene.shape), voxelised, float(padding))
        materials = _material_tables(scene)
        arrays = cache.cached_arrays("voxelgrid", GRID_VERSION, inputs,
                                     lambda: _compact(cls._build(scene, padding, static_only), materials))
        ids = arrays["object_id"]
        object_id = ids.astype(np.int32)
        if ids.dtype == np.int8:          # ids' bytes index a 256-entry table (free, -1, is byte 255): no int temporary
            index, tables = ids.view(np.uint8), [_byte_table(t) for t in materials]
        else:
            index, tables = object_id + 1, materials
        defo = arrays["deformability"] if "deformability" in arrays else tables[0][index]
        sens = arrays["sensitivity"] if "sensitivity" in arrays else tables[1][index]
        return cls(scene.lower.copy(), scene.resolution, defo, sens, object_id, [o.name for o in scene.objects])

    def arrays(self) -> dict[str, np.ndarray]:
        """The per-voxel arrays by name (what the cache keeps of a grid)."""
        return {"deformability": self.deformability, "sensitivity": self.sensitivity, "object_id": self.object_id}

    @classmethod
    def _build(cls, scene: Scene, padding: float, static_only: bool) -> VoxelGrid:
        """:meth:`from_scene` without the cache."""
        shape = scene.shape
        res = scene.resolution
        axes = [scene.lower[i] + (np.arange(shape[i]) + 0.5) * res for i in range(3)]
        centres = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        object_id = np.full(len(centres), FREE, dtype=np.int32)
        defo = np.ones(len(centres))
        sens = np.zeros(len(centres))
        for k, obj in enumerate(scene.objects):
            if static_only and obj.movable:
                continue
            lo, hi = obj.part.bounds()
            near = np.all((centres >= lo - res) & (centres <= hi + res), axis=1)
            cand = np.nonzero(near)[0]
            inside = cand[obj.contains(centres[cand])]
            object_id[inside] = k
            shape_obj = obj.part.shape
            if getattr(shape_obj, "kind", "") == "voxels":
                local = obj.part.pose.to_local(centres[inside])
                defo[inside] = shape_obj.values(local, "deformability", obj.material.deformability)
                sens[inside] = shape_obj.values(local, "sensitivity", obj.material.sensitivity)
            else:
                defo[inside] = obj.material.deformability
                sens[inside] = obj.material.sensitivity
        grid = cls(scene.lower.copy(), res, defo.reshape(shape), sens.reshape(shape), object_id.reshape(shape),
                   [o.name for o in scene.objects])
        if padding > 0:
            grid._pad(padding)
        return grid

    def _pad(self, padding: float) -> None:
        from scipy.ndimage import distance_transform_edt

        occ = self.occupied
        if not occ.any():
            return
        dist, (ix, iy, iz) = distance_transform_edt(~occ, sampling=self.resolution, return_indices=True)
        grow = (~occ) & (dist <= padding + 1e-12)
        for arr in (self.deformability, self.sensitivity, self.object_id):
            arr[grow] = arr[ix[grow], iy[grow], iz[grow]]
        self._sdf = self._sdf_gradient = None


def _material_tables(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Deformability and sensitivity by ``object_id + 1`` (free space first): the objects' materials."""
    defo = np.array([1.0] + [o.material.deformability for o in scene.objects], dtype=np.float64)
    sens = np.array([0.0] + [o.material.sensitivity for o in scene.objects], dtype=np.float64)
    return defo, sens


def _byte_table(table: np.ndarray) -> np.ndarray:
    """A material table by ``object_id + 1`` (:func:`_material_tables`, at most 128 entries) as a table by the byte
    of an int8 object id: objects 0..126 at their own index, free space (-1) at 255, NaN elsewhere."""
    out = np.full(256, np.nan)
    out[:len(table) - 1] = table[1:]
    out[255] = table[0]
    return out


def _compact(grid: VoxelGrid, materials: tuple[np.ndarray, np.ndarray]) -> dict[str, np.ndarray]:
    """What the cache keeps of ``grid``: its object ids in the smallest integer type, and its deformability and
    sensitivity only where they are not the objects' materials (an object with per-voxel values)."""
    ids = grid.object_id
    small = np.int8 if ids.max(initial=0) < 127 else np.int16 if ids.max(initial=0) < 32767 else np.int32
    out: dict[str, np.ndarray] = {"object_id": ids.astype(small)}
    for name, table, values in (("deformability", materials[0], grid.deformability),
                                ("sensitivity", materials[1], grid.sensitivity)):
        rebuilt = table[ids + 1]
        if not (np.array_equal(rebuilt, values, equal_nan=True)
                and np.array_equal(np.signbit(rebuilt), np.signbit(values))):
            out[name] = values
    return out


def _signed_distance(occ: np.ndarray, resolution: float) -> np.ndarray:
    """The signed distance field of occupancy ``occ`` (some voxels occupied, some free); see :attr:`VoxelGrid.sdf`."""
    from scipy.ndimage import distance_transform_edt

    outside = distance_transform_edt(~occ, sampling=resolution)  # free: to the nearest object
    inside = distance_transform_edt(occ, sampling=resolution)    # object: to the nearest free
    half = 0.5 * resolution
    return np.where(occ, half - inside, outside - half)


def _trilinear(field_: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Interpolate ``field_`` ``(nx, ny, nz)`` at continuous voxel coordinates ``u`` ``(..., 3)``."""
    shape = np.array(field_.shape)
    u = np.clip(u, 0.0, shape - 1.0)
    i0 = np.minimum(np.floor(u).astype(np.int64), np.maximum(shape - 2, 0))
    f = u - i0
    i1 = np.minimum(i0 + 1, shape - 1)
    out = 0.0
    for dx in (0, 1):
        wx = f[..., 0] if dx else 1 - f[..., 0]
        x = i1[..., 0] if dx else i0[..., 0]
        for dy in (0, 1):
            wy = f[..., 1] if dy else 1 - f[..., 1]
            y = i1[..., 1] if dy else i0[..., 1]
            for dz in (0, 1):
                wz = f[..., 2] if dz else 1 - f[..., 2]
                z = i1[..., 2] if dz else i0[..., 2]
                out = out + wx * wy * wz * field_[x, y, z]
    return out


def _trilinear_gradient(field_: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Gradient (per voxel unit) of the trilinear interpolant of ``field_`` at coordinates ``u``."""
    shape = np.array(field_.shape)
    inside = (u >= 0.0) & (u <= shape - 1.0)
    u = np.clip(u, 0.0, shape - 1.0)
    i0 = np.minimum(np.floor(u).astype(np.int64), np.maximum(shape - 2, 0))
    f = u - i0
    i1 = np.minimum(i0 + 1, shape - 1)
    grad = np.zeros(u.shape)
    for dx in (0, 1):
        x = i1[..., 0] if dx else i0[..., 0]
        for dy in (0, 1):
            y = i1[..., 1] if dy else i0[..., 1]
            for dz in (0, 1):
                z = i1[..., 2] if dz else i0[..., 2]
                v = field_[x, y, z]
                wx = f[..., 0] if dx else 1 - f[..., 0]
                wy = f[..., 1] if dy else 1 - f[..., 1]
                wz = f[..., 2] if dz else 1 - f[..., 2]
                grad[..., 0] += (1.0 if dx else -1.0) * wy * wz * v
                grad[..., 1] += wx * (1.0 if dy else -1.0) * wz * v
                grad[..., 2] += wx * wy * (1.0 if dz else -1.0) * v
    # a clamped coordinate (outside the grid, or an axis one voxel thick) does not vary the value
    return np.where(inside & (shape > 1), grad, 0.0)
