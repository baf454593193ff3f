"""Penetration of robot points into the voxelised environment, with motion-dependent normals.

Thesis app. B: the SDF gives wrong normals on edges and corners, where *the direction of motion*
decides which face was hit.  For every occupied voxel we know which of its six faces are exposed
(their neighbour is free).  A penetrating point is traced back along its motion: the face it
entered through is the exposed face it would leave through first, ``argmin_f depth_f / (-n_f . d)``
over faces with ``n_f . d < 0``.  Its penetration is the distance to that face's plane.  Points
in voxels with no exposed face (deep inside) use the SDF gradient and depth instead; points outside
the grid are pushed back across the violated bounds (the grid's boundary is a wall).

Tracing alone fails where a *face of the robot* slides past an obstacle's convex edge: a point of the
robot's face that passes the edge "entered" through the obstacle face it crossed last, which may be
the one the robot's face is perpendicular to, and the push-out along it jams the robot at the edge
(seen on se2-maze: the L-block stopped sliding down a wall's end, and, tilted, at a passage's exit
where the dynamic simulator slides on).  Where an obstacle edge meets a robot face the contact normal
is the robot face's.  So when the robot says which of its faces a point lies on
(:meth:`pliant.interfaces.RobotModel.surface_faces`), a point inside an *edge voxel* of the obstacle
(exposed faces on two or more axes) that lies on exactly one robot face facing them (normals within
60 degrees of anti-parallel to an exposed face) is pushed out along that robot face's normal, by the
distance along it to the voxel's boundary — also when the robot face is tilted.  Robot edges and
corners (two faces facing the obstacle), points in voxels with exposed faces on one axis (flat faces,
where the obstacle's normal is right), and robots that do not report faces are traced.
"""

from __future__ import annotations

import numba
import numpy as np
from pliant.api import ProcessMemo, VoxelGrid, cached_arrays, fingerprint

from pliant_kinematic.rigid_kernel import ROBOT_FACE_COS

#: version of the cached contact tables: change it whenever _tables' output changes
TABLES_VERSION = "kinematic-contact-2"
#: outward normals of the six faces: -x, +x, -y, +y, -z, +z
FACE_NORMALS = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]], dtype=np.float64)
#: the per-voxel arrays of the contact models this process built (a metric's cells, a test session's simulators
#: over one scene: one build each), read-only and shared by every model of the same occupancy; the least recently
#: used are dropped beyond either bound
_models = ProcessMemo(entries=4, max_bytes=512 * 2**20)
#: the arrays a contact model shares with the others of its occupancy
SHARED = ("occupied_flat", "exposed", "free_clearance", "deep_normal", "deep_depth")


class ContactModel:
    """Collision queries of points against a :class:`~pliant.geometry.voxelgrid.VoxelGrid`'s occupied voxels.

    ``planar``: the points move only within the grid's one layer (an SE(2) body in a planar scene), so the grid's
    z faces are no walls in :attr:`free_clearance`, the broad phase's bound (with them, every voxel of a one-layer
    grid is half a voxel from a "wall" and the bound is zero everywhere).
    """

    def __init__(self, grid: VoxelGrid, planar: bool = False) -> None:
        self.grid = grid
        occ = grid.occupied
        self.lower = grid.lower
        self.upper = grid.lower + np.array(grid.shape) * grid.resolution
        self.res = grid.resolution
        self._shape = np.asarray(grid.shape, dtype=np.int64)
        self.planar = bool(planar) and occ.shape[2] == 1
        inputs = (occ, np.asarray(grid.lower, dtype=np.float64), float(grid.resolution), self.planar)
        key = fingerprint("kinematic-contact-model", TABLES_VERSION, inputs)
        arrays = _models.get(key, lambda: _derive(grid, occ, self.planar, inputs))
        for name in SHARED:
            setattr(self, name, arrays[name])

    def colliding(self, points: np.ndarray) -> np.ndarray:
        """Bool ``(n, k)``: points ``(n, k, 3)`` inside an occupied voxel or outside the grid."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        out = np.empty(points.shape[:2], dtype=np.bool_)
        _colliding(points, self.lower, 1.0 / self.res, self._shape, self.occupied_flat, out)
        return out

    def penetration(self, points: np.ndarray, motion: np.ndarray, robot_faces: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Normals ``(k, 3)`` and depths ``(k,)`` (m) of colliding points ``(k, 3)`` moving along ``motion``.

        ``robot_faces`` ``(k, 6, 3)``: world directions of the robot faces each point lies on (zero rows
        where it lies on fewer than six; see the module docstring), or ``None``.
        """
        k = len(points)
        normals = np.zeros((k, 3))
        depth = np.zeros(k)
        idx, inside = self.grid.index(points)
        out = ~inside
        if out.any():
            below = np.maximum(self.lower - points[out], 0.0)
            above = np.maximum(points[out] - self.upper, 0.0)
            push = below - above
            depth[out] = np.linalg.norm(push, axis=1)
            normals[out] = push / np.maximum(depth[out], 1e-300)[:, None]
        ins = np.nonzero(inside)[0]
        if len(ins):
            i = idx[ins]
            _, ny, nz = self.grid.shape
            flat = (i[:, 0] * ny + i[:, 1]) * nz + i[:, 2]
            exposed = self.exposed[flat]                                   # (k, 6)
            lo = self.lower + i * self.res
            p = points[ins]
            # distance to each face plane, measured along that face's outward normal
            d = np.stack([p[:, 0] - lo[:, 0], lo[:, 0] + self.res - p[:, 0],
                          p[:, 1] - lo[:, 1], lo[:, 1] + self.res - p[:, 1],
                          p[:, 2] - lo[:, 2], lo[:, 2] + self.res - p[:, 2]], axis=1)
            m = motion[ins]
            ndotd = m @ FACE_NORMALS.T                                      # (k, 6)
            with np.errstate(divide="ignore", invalid="ignore"):
                t_exit = np.where(exposed & (ndotd < -1e-15), d / -ndotd, np.inf)
            best = np.argmin(t_exit, axis=1)
            none_entered = ~np.isfinite(t_exit[np.arange(len(ins)), best])
            if none_entered.any():
                alt = np.argmin(np.where(exposed, d, np.inf), axis=1)
                best = np.where(none_entered, alt, best)
            has_face = exposed[np.arange(len(ins)), best]
            normals[ins] = FACE_NORMALS[best]
            depth[ins] = d[np.arange(len(ins)), best]
            if robot_faces is not None:
                self._robot_face_normals(robot_faces[ins], exposed, np.isfinite(t_exit), d, normals, depth, ins)
            deep = ~has_face
            if deep.any():
                g = self.grid.sdf_gradient_at(p[deep])
                g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
                normals[ins[deep]] = g
                depth[ins[deep]] = np.maximum(-self.grid.sdf_at(p[deep]), 0.5 * self.res)
        return normals, depth


    @staticmethod
    def _robot_face_normals(robot_faces, exposed, entered, d, normals, depth, ins) -> None:
        """Overwrite the normals and depths of points in obstacle edge voxels that lie on one robot face
        facing them (see the module docstring).  ``robot_faces`` ``(k, 6, 3)`` world directions (zero rows
        where the point is not on that face), ``exposed`` / ``entered`` ``(k, 6)`` the voxel's exposed faces
        and those the point moved into, ``d`` ``(k, 6)`` distances to the voxel's face planes."""
        cos = np.einsum("fc,kec->kef", FACE_NORMALS, robot_faces)                 # (k, e, f)
        score = np.where(exposed[:, None, :], -cos, -np.inf).max(axis=2)           # (k, e)
        facing = score > ROBOT_FACE_COS
        axes = exposed.reshape(-1, 3, 2).any(axis=2).sum(axis=1)
        use = entered.any(axis=1) & (axes >= 2) & (facing.sum(axis=1) == 1)
        if not use.any():
            return
        rows = np.nonzero(use)[0]
        n = -robot_faces[rows, np.argmax(facing[rows], axis=1)]                   # (u, 3)
        along = n @ FACE_NORMALS.T                                                   # (u, 6)
        with np.errstate(divide="ignore", invalid="ignore"):
            exit_ = np.where(along > 1e-9, d[rows] / along, np.inf).min(axis=1)
        normals[ins[rows]] = n
        depth[ins[rows]] = exit_


def _derive(grid: VoxelGrid, occ: np.ndarray, planar: bool, inputs: tuple) -> dict[str, np.ndarray]:
    """The arrays a contact model queries (:data:`SHARED`), per voxel of the grid: ``occupied_flat`` ``(N + 1,)``
    (the last entry: outside the grid, solid), ``exposed`` ``(N, 6)`` (the faces whose neighbour is free; outside
    the grid counts as solid), ``free_clearance`` ``(N,)`` and the deep voxels' ``deep_normal`` ``(N, 3)`` and
    ``deep_depth`` ``(N,)`` (zeros elsewhere)."""
    padded = np.pad(occ, 1, constant_values=True)               # outside counts as solid
    exposed = np.zeros(occ.shape + (6,), dtype=bool)
    for f, (dx, dy, dz) in enumerate(FACE_NORMALS.astype(int)):
        neighbour = padded[1 + dx:padded.shape[0] - 1 + dx, 1 + dy:padded.shape[1] - 1 + dy,
                           1 + dz:padded.shape[2] - 1 + dz]
        exposed[..., f] = occ & ~neighbour
    exposed = exposed.reshape(-1, 6)
    # the distance transforms below take seconds on a large grid: kept in the content-addressed cache, under the
    # occupancy, the grid's placement and resolution and the planar flag (pliant.cache; docs/architecture.md)
    tables = cached_arrays("kinematic-contact", TABLES_VERSION, inputs,
                           lambda: _tables(grid, occ, exposed, planar))
    # voxels with no exposed face: the SDF's normal and depth at their centre
    deep_normal = np.zeros((occ.size, 3))
    deep_depth = np.zeros(occ.size)
    deep = tables["deep"].astype(np.int64)
    deep_normal[deep] = tables["deep_normal"]
    deep_depth[deep] = tables["deep_depth"]
    arrays = {"occupied_flat": np.append(occ.reshape(-1), True), "exposed": exposed,
              "free_clearance": tables["free_clearance"], "deep_normal": deep_normal, "deep_depth": deep_depth}
    for a in arrays.values():
        a.flags.writeable = False                   # shared by every model of this occupancy
    return arrays


def _tables(grid: VoxelGrid, occ: np.ndarray, exposed: np.ndarray, planar: bool) -> dict[str, np.ndarray]:
    """What :class:`ContactModel` derives from the occupancy with distance transforms: ``free_clearance`` ``(N,)``
    float32 and, for the ``deep`` voxels (occupied, no exposed face; flat indices ``(k,)``), the SDF's unit normal
    ``deep_normal`` ``(k, 3)`` and depth ``deep_depth`` ``(k,)`` at their centres."""
    from scipy.ndimage import binary_dilation, distance_transform_edt

    # free_clearance (m, float32 rounded down, per voxel): for a free voxel a lower bound on the distance from
    # any point of it to any obstacle (the grid's boundary included): the distance between its box and the
    # nearest occupied voxel's box, i.e. the centre distance to the occupancy dilated by one voxel (3 x 3 x 3;
    # 3 x 3 x 1 in the plane); -1 for an occupied voxel, so that one lookup answers both questions (the fused
    # kernel's broad phase, rigid_kernel._accumulate)
    pad = ((1, 1), (1, 1), (0, 0)) if planar else 1
    solid = np.pad(occ, pad, constant_values=True)
    near = binary_dilation(solid, structure=np.ones((3, 3, 1) if planar else (3, 3, 3), dtype=bool))
    box = distance_transform_edt(~near, sampling=grid.resolution)
    box = box[1:-1, 1:-1, :] if planar else box[1:-1, 1:-1, 1:-1]
    bound = box.reshape(-1)
    single = bound.astype(np.float32)
    single = np.where(single > bound, np.nextafter(single, np.float32(-np.inf)), single)   # rounded down
    free_clearance = np.where(occ.reshape(-1), np.float32(-1.0), single)
    deep = np.nonzero(occ.reshape(-1) & ~exposed.any(axis=1))[0]
    normal = np.zeros((len(deep), 3))
    depth = np.zeros(len(deep))
    if len(deep):
        idx = np.column_stack(np.unravel_index(deep, occ.shape))
        centres = grid.centres(idx)
        g = grid.sdf_gradient_at(centres)
        normal = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
        depth = np.maximum(-grid.sdf_at(centres), 0.5 * grid.resolution)
    return {"free_clearance": free_clearance, "deep": deep.astype(np.int32 if occ.size < 2**31 else np.int64),
            "deep_normal": normal,
            "deep_depth": depth}


@numba.njit(cache=True, nogil=True)
def _colliding(points, lower, inv_res, shape, occupied_flat, out):
    nx, ny, nz = shape[0], shape[1], shape[2]
    for a in range(points.shape[0]):
        for i in range(points.shape[1]):
            ix = int(np.floor((points[a, i, 0] - lower[0]) * inv_res))
            iy = int(np.floor((points[a, i, 1] - lower[1]) * inv_res))
            iz = int(np.floor((points[a, i, 2] - lower[2]) * inv_res))
            if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
                out[a, i] = occupied_flat[(ix * ny + iy) * nz + iz]
            else:
                out[a, i] = True
