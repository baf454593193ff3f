"""Solid shapes of scene objects and robot parts, with batched point-membership tests.

Every shape lives in its own frame (centred at the origin unless stated) and answers
``contains(points)`` for points ``(n, 3)`` in that frame (metres).  Scene objects place shapes with
a pose; voxelisation and the simple validity checks of the core are built on ``contains``.
"""

from __future__ import annotations

import struct
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pliant.errors import SceneError
from pliant.validation import check_regular_file, size_limit

#: the most triangles a mesh may have: the inside test costs (points x triangles), so a 30,000-triangle mesh over a
#: scene's voxels takes minutes; simplify the mesh, or raise it with the environment variable PLIANT_MAX_MESH_TRIANGLES
MAX_MESH_TRIANGLES = 20_000
#: the largest mesh file read (bytes; PLIANT_MAX_MESH_BYTES)
MAX_MESH_BYTES = 64 * 2**20
#: the largest voxel-array file read (bytes; PLIANT_MAX_VOXEL_BYTES) and the most entries of one of its arrays
#: (PLIANT_MAX_GRID_CELLS, as a scene's grid), checked from the file's headers before any array is loaded
MAX_VOXEL_BYTES = 512 * 2**20
MAX_VOXEL_CELLS = 64_000_000
#: the farthest a mesh vertex may lie from its object's origin after scaling (m)
MAX_MESH_EXTENT = 1e6
#: memory the inside test of a mesh may use at once (bytes): points are processed in chunks that fit
WINDING_BUDGET = 64 * 2**20


class Shape:
    """A solid in its local frame.  Subclasses implement :meth:`contains` and :meth:`bounds`."""

    kind: str = ""

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: whether each local point ``(n, 3)`` lies inside the solid (boundary inclusive)."""
        raise NotImplementedError

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds ``(lower (3,), upper (3,))`` in the local frame (metres)."""
        raise NotImplementedError


@dataclass(frozen=True)
class Box(Shape):
    """A box of full extents ``size`` ``(sx, sy, sz)`` centred at the origin."""

    size: np.ndarray
    kind = "box"

    def contains(self, points):
        return np.all(np.abs(points) <= 0.5 * self.size + 1e-12, axis=-1)

    def bounds(self):
        return -0.5 * self.size, 0.5 * self.size


@dataclass(frozen=True)
class Sphere(Shape):
    """A ball of ``radius`` centred at the origin."""

    radius: float
    kind = "sphere"

    def contains(self, points):
        return np.sum(points * points, axis=-1) <= self.radius ** 2 + 1e-12

    def bounds(self):
        r = np.full(3, self.radius)
        return -r, r


@dataclass(frozen=True)
class Cylinder(Shape):
    """A solid cylinder of ``radius`` and ``length`` along the local z axis, centred at the origin."""

    radius: float
    length: float
    kind = "cylinder"

    def contains(self, points):
        radial = points[..., 0] ** 2 + points[..., 1] ** 2 <= self.radius ** 2 + 1e-12
        return radial & (np.abs(points[..., 2]) <= 0.5 * self.length + 1e-12)

    def bounds(self):
        h = np.array([self.radius, self.radius, 0.5 * self.length])
        return -h, h


@dataclass(frozen=True, eq=False)
class Mesh(Shape):
    """A closed triangle mesh read from an STL (ASCII or binary) or OBJ file, scaled by ``scale``.

    Membership uses the generalised winding number (Jacobson et al. 2013), which is robust to small
    defects in the mesh: a point is inside when the winding number exceeds one half.
    """

    path: Path
    scale: float
    triangles: np.ndarray = field(repr=False)  # (m, 3, 3) metres
    kind = "mesh"

    @classmethod
    def load(cls, path: Path, scale: float = 1.0, *, source: str | None = None, field_name: str = "file") -> Mesh:
        """Read ``path`` (``.stl`` or ``.obj``) or raise :class:`SceneError` naming the field: a file that is not a
        regular file or larger than :data:`MAX_MESH_BYTES`, more than :data:`MAX_MESH_TRIANGLES` triangles, or a
        ``scale`` that puts vertices beyond :data:`MAX_MESH_EXTENT` metres (or overflows) is refused."""
        check_regular_file(path, max_bytes=size_limit("PLIANT_MAX_MESH_BYTES", MAX_MESH_BYTES),
                           limit_name="PLIANT_MAX_MESH_BYTES", error=SceneError, source=source, field=field_name)
        try:
            suffix = path.suffix.lower()
            if suffix == ".stl":
                tris = _read_stl(path)
            elif suffix == ".obj":
                tris = _read_obj(path)
            else:
                raise SceneError("mesh files must be .stl or .obj", source=source, field=field_name, value=str(path))
        except SceneError:
            raise
        except (OSError, ValueError, IndexError, struct.error) as exc:
            raise SceneError(f"cannot read mesh file: {exc}", source=source, field=field_name,
                             value=str(path)) from None
        if tris.size == 0 or not np.all(np.isfinite(tris)):
            raise SceneError("mesh file has no finite triangles", source=source, field=field_name, value=str(path))
        limit = size_limit("PLIANT_MAX_MESH_TRIANGLES", MAX_MESH_TRIANGLES)
        if len(tris) > limit:
            raise SceneError(f"mesh has {len(tris):,} triangles, more than the limit of {limit:,} (simplify it, or "
                             "set PLIANT_MAX_MESH_TRIANGLES)", source=source, field=field_name, value=str(path))
        if not (np.isfinite(scale) and scale > 0):
            raise SceneError("must be a finite positive number", source=source, field="scale", value=scale)
        with np.errstate(over="ignore", invalid="ignore"):
            scaled = tris * scale
        reach = float(np.max(np.abs(scaled))) if np.all(np.isfinite(scaled)) else np.inf
        if reach > MAX_MESH_EXTENT:
            raise SceneError(f"scale {scale:g} puts mesh vertices {reach:.3g} m from the object's origin (at most "
                             f"{MAX_MESH_EXTENT:g} m); the mesh's units are probably not metres", source=source,
                             field=field_name.rsplit(".", 1)[0] + ".scale" if "." in field_name else "scale",
                             value=scale)
        return cls(path=path, scale=scale, triangles=scaled)

    def winding_number(self, points: np.ndarray, chunk: int | None = None) -> np.ndarray:
        """Generalised winding number of each point ``(n, 3)`` with respect to the mesh.

        Points go in chunks (``chunk``; default as many as fit in :data:`WINDING_BUDGET` bytes of temporaries,
        about 20 floats per point and triangle), so memory stays bounded whatever the mesh and the point count."""
        if chunk is None:
            chunk = max(1, min(4096, WINDING_BUDGET // (20 * 8 * max(1, len(self.triangles)))))
        out = np.empty(len(points))
        for s in range(0, len(points), chunk):
            p = points[s:s + chunk, None, None, :]
            v = self.triangles[None] - p                       # (c, m, 3, 3)
            a, b, c = v[:, :, 0], v[:, :, 1], v[:, :, 2]
            la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
            det = np.einsum("ijk,ijk->ij", a, np.cross(b, c))
            den = (la * lb * lc + np.einsum("ijk,ijk->ij", a, b) * lc
                   + np.einsum("ijk,ijk->ij", b, c) * la + np.einsum("ijk,ijk->ij", c, a) * lb)
            out[s:s + chunk] = np.sum(2.0 * np.arctan2(det, den), axis=1) / (4 * np.pi)
        return out

    def contains(self, points):
        return self.winding_number(np.asarray(points, dtype=np.float64)) > 0.5

    def bounds(self):
        flat = self.triangles.reshape(-1, 3)
        return flat.min(axis=0), flat.max(axis=0)


@dataclass(frozen=True, eq=False)
class VoxelArray(Shape):
    """Occupancy on a regular grid, read from an ``.npz`` file.

    The file holds ``occupancy`` (bool ``(nx, ny, nz)``, x-major numpy order) and optionally
    per-voxel ``deformability`` and ``sensitivity`` arrays of the same shape.  The grid's lower
    corner sits at the local origin; voxel ``(i, j, k)`` spans ``[i, i+1) * resolution`` etc.
    """

    path: Path
    resolution: float
    occupancy: np.ndarray = field(repr=False)
    deformability: np.ndarray | None = field(default=None, repr=False)
    sensitivity: np.ndarray | None = field(default=None, repr=False)
    kind = "voxels"

    @classmethod
    def load(cls, path: Path, resolution: float, *, source: str | None = None, field_name: str = "file") -> VoxelArray:
        """Read ``path`` or raise :class:`SceneError` naming the field and what is wrong.

        Only a regular ``.npz`` file of at most :data:`MAX_VOXEL_BYTES` is opened; every array's shape is read from
        its header and checked against :data:`MAX_VOXEL_CELLS` before it is loaded (a small compressed file may
        hold a huge array); ``occupancy`` must hold booleans or the numbers 0 and 1 (strings, NaN, other numbers are
        an error, not "occupied")."""
        check_regular_file(path, max_bytes=size_limit("PLIANT_MAX_VOXEL_BYTES", MAX_VOXEL_BYTES),
                           limit_name="PLIANT_MAX_VOXEL_BYTES", error=SceneError, source=source, field=field_name)
        try:
            _check_npz_headers(path, size_limit("PLIANT_MAX_GRID_CELLS", MAX_VOXEL_CELLS))
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except SceneError as exc:
            raise SceneError(exc.message, source=source, field=field_name, value=str(path)) from None
        except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
            raise SceneError(f"cannot read voxel file: {exc}", source=source, field=field_name,
                             value=str(path)) from None
        if "occupancy" not in arrays:
            raise SceneError("voxel file has no 'occupancy' array", source=source, field=field_name, value=str(path))
        occ = arrays["occupancy"]
        if occ.ndim != 3 or occ.size == 0:
            raise SceneError("'occupancy' must be a non-empty 3-D array", source=source, field=field_name,
                             value=list(occ.shape))
        if occ.dtype != np.bool_:
            if occ.dtype.kind not in "iuf":
                raise SceneError(f"'occupancy' must hold booleans or 0 / 1, not {occ.dtype} values", source=source,
                                 field=field_name, value=str(path))
            if not np.all((occ == 0) | (occ == 1)):
                raise SceneError("'occupancy' numbers must each be 0 or 1 (NaN and other values are not occupancy)",
                                 source=source, field=field_name, value=str(path))
        for name in ("deformability", "sensitivity"):
            if name in arrays and arrays[name].dtype.kind not in "iuf":
                raise SceneError(f"'{name}' must hold numbers, not {arrays[name].dtype} values", source=source,
                                 field=field_name, value=str(path))
        extra = {}
        for name, lo, hi in (("deformability", 0.0, 1.0), ("sensitivity", 0.0, np.inf)):
            if name in arrays:
                arr = np.asarray(arrays[name], dtype=np.float64)
                if arr.shape != occ.shape:
                    raise SceneError(f"'{name}' must have the shape of 'occupancy'", source=source,
                                     field=field_name, value=list(arr.shape))
                vals = arr[occ.astype(bool)]
                bad = vals[~np.isnan(vals)] if name == "sensitivity" else vals
                if np.any(np.isnan(bad)) or np.any(bad < lo) or np.any(bad > hi):
                    raise SceneError(f"'{name}' values must lie in [{lo}, {hi}]", source=source, field=field_name,
                                     value=str(path))
                extra[name] = arr
        return cls(path=path, resolution=resolution, occupancy=occ.astype(bool), **extra)

    def _index(self, points):
        return np.floor(np.asarray(points) / self.resolution).astype(np.int64)

    def contains(self, points):
        idx = self._index(points)
        inside = np.all((idx >= 0) & (idx < np.array(self.occupancy.shape)), axis=-1)
        out = np.zeros(len(idx), dtype=bool)
        i = idx[inside]
        out[inside] = self.occupancy[i[:, 0], i[:, 1], i[:, 2]]
        return out

    def values(self, points, name: str, default: float) -> np.ndarray:
        """Per-voxel ``deformability`` or ``sensitivity`` at local points, ``default`` where absent."""
        arr = getattr(self, name)
        out = np.full(len(points), default)
        if arr is None:
            return out
        idx = self._index(points)
        inside = np.all((idx >= 0) & (idx < np.array(self.occupancy.shape)), axis=-1)
        i = idx[inside]
        out[inside] = arr[i[:, 0], i[:, 1], i[:, 2]]
        return out

    def bounds(self):
        return np.zeros(3), np.array(self.occupancy.shape) * self.resolution


def _check_npz_headers(path: Path, max_cells: int) -> None:
    """Read the shape of every array in the ``.npz`` at ``path`` from its ``.npy`` header (nothing is decompressed
    beyond the header) and raise :class:`SceneError` for one with more than ``max_cells`` entries."""
    with zipfile.ZipFile(path) as archive:
        for member in archive.namelist():
            if not member.endswith(".npy"):
                continue
            with archive.open(member) as stream:
                version = np.lib.format.read_magic(stream)
                if version == (1, 0):
                    shape, _, _ = np.lib.format.read_array_header_1_0(stream)
                else:
                    shape, _, _ = np.lib.format.read_array_header_2_0(stream)
            cells = int(np.prod(shape, dtype=np.float64))
            if cells > max_cells:
                raise SceneError(f"array '{member[:-4]}' has {cells:,} entries {list(shape)}, more than the limit of "
                                 f"{max_cells:,} (set PLIANT_MAX_GRID_CELLS to raise it)")


def _read_stl(path: Path) -> np.ndarray:
    data = path.read_bytes()
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count:
            rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                                count=count, offset=84)
            return rec["v"].astype(np.float64)
    text = data.decode("ascii")
    if not text.lstrip().startswith("solid"):
        raise ValueError("neither binary nor ASCII STL")
    verts = [list(map(float, line.split()[1:4])) for line in text.splitlines() if line.strip().startswith("vertex")]
    if len(verts) % 3:
        raise ValueError("ASCII STL vertex count is not a multiple of 3")
    return np.asarray(verts, dtype=np.float64).reshape(-1, 3, 3)


def _read_obj(path: Path) -> np.ndarray:
    verts, faces = [], []
    for line in path.read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            idx = [int(p.split("/")[0]) for p in parts[1:]]
            idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
            faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    v = np.asarray(verts, dtype=np.float64)
    return v[np.asarray(faces, dtype=np.int64)] if faces else np.zeros((0, 3, 3))
