"""How close a robot configuration is to the environment: colliding, near contact, or free (thesis 6.4.2).

The thesis approximates C-space proximity to contact by workspace proximity, checking the robot against an
expanded environment.  Here every surface point of the robot looks up the signed distance of its voxel
(:attr:`pliant.geometry.voxelgrid.VoxelGrid.sdf`, metres, at voxel centres) and whether that voxel is occupied; a
configuration *collides* when any surface point lies in an occupied voxel or outside the grid (the test the
kinematic simulator resolves), and its *clearance* is the smallest signed distance over its points.  Rigid
bodies go through one numba kernel that fuses the transform and the lookups (split over ``threads`` threads for
large batches; it releases the GIL); articulated robots through
:meth:`~pliant.interfaces.RobotModel.body_points` in chunks.
"""

from __future__ import annotations

import numba
import numpy as np
from pliant.api import RobotModel, VoxelGrid, spatial_runs

#: configurations per chunk on the articulated path (bounds memory: chunk x points x 3 floats)
CHUNK = 256
#: rigid queries of at least this many configurations are split over the threads (the kernel releases the GIL)
THREADED = 1024


#: the broad phase: runs of at most this many consecutive surface points ...
SEGMENT_POINTS = 32
#: ... within this many voxels of their bounding box's centre
SEGMENT_RADIUS = 3.0
#: voxels: the signed distances at two voxel centres differ by at most the centres' distance plus (sqrt(3) - 1) h
#: (both 1-Lipschitz distance fields meet within sqrt(3)/2 h of a centre where the sign changes), and a point lies
#: within sqrt(3)/2 h of its voxel's centre, so every point of a segment has at least ``sdf(centre's voxel) -
#: radius - SLACK h``; the 1e-6 covers the rounding of the placements
SLACK = 2.0 * np.sqrt(3.0) - 1.0 + 1e-6


@numba.njit(cache=True, nogil=True, inline="always")
def _placed(rot, trans, i, x, y, z):  # pragma: no cover - numba
    """The body-frame point ``(x, y, z)`` placed by configuration ``i``'s rotation and translation."""
    return (rot[i, 0, 0] * x + rot[i, 0, 1] * y + rot[i, 0, 2] * z + trans[i, 0],
            rot[i, 1, 0] * x + rot[i, 1, 1] * y + rot[i, 1, 2] * z + trans[i, 1],
            rot[i, 2, 0] * x + rot[i, 2, 1] * y + rot[i, 2, 2] * z + trans[i, 2])


@numba.njit(cache=True, nogil=True)
def _rigid_clearance(rot, trans, local, index, sdf, occupied, shape, lower, resolution, starts, centres, extents,
                     radii):  # pragma: no cover - numba
    """Per configuration ``(rot[i], trans[i])``: the smallest signed distance over the surface points ``local``
    (``-inf`` when a point is off the grid), the index of the first point that has it, and whether a point is in an
    occupied voxel or off the grid.

    ``local`` is the surface in the broad phase's order and ``index`` each point's place in the surface's own order:
    "first" is in the surface's order (the smallest ``index`` among the points with the smallest distance, or among
    those off the grid), so the order the kernel walks changes no result.

    Broad phase (the results are the same, bit for bit, without it): once a smallest distance ``best`` is known, a
    segment of points (``starts`` / ``centres`` / ``extents`` / ``radii``, ``pliant.api.point_runs``) whose box lies
    inside the grid and whose lower bound ``sdf(centre's voxel) - radius - SLACK h`` is positive and above ``best``
    is skipped: none of its points is off the grid, in an occupied voxel (their distance is negative), at ``best``
    or below it."""
    n = rot.shape[0]
    clearance = np.empty(n)
    closest = np.empty(n, dtype=np.int64)
    colliding = np.zeros(n, dtype=np.bool_)
    nx, ny, nz = shape[0], shape[1], shape[2]
    margin = 1e-6 * resolution
    upper0, upper1, upper2 = (lower[0] + nx * resolution - margin, lower[1] + ny * resolution - margin,
                              lower[2] + nz * resolution - margin)
    lower0, lower1, lower2 = lower[0] + margin, lower[1] + margin, lower[2] + margin
    slack = SLACK * resolution
    for i in range(n):
        best = np.inf
        arg = 0
        hit = False
        off = False
        for s in range(starts.shape[0] - 1):
            if best < np.inf:
                c0, c1, c2 = _placed(rot, trans, i, centres[s, 0], centres[s, 1], centres[s, 2])
                e0 = abs(rot[i, 0, 0]) * extents[s, 0] + abs(rot[i, 0, 1]) * extents[s, 1] \
                    + abs(rot[i, 0, 2]) * extents[s, 2]
                e1 = abs(rot[i, 1, 0]) * extents[s, 0] + abs(rot[i, 1, 1]) * extents[s, 1] \
                    + abs(rot[i, 1, 2]) * extents[s, 2]
                e2 = abs(rot[i, 2, 0]) * extents[s, 0] + abs(rot[i, 2, 1]) * extents[s, 1] \
                    + abs(rot[i, 2, 2]) * extents[s, 2]
                if (c0 - e0 >= lower0 and c1 - e1 >= lower1 and c2 - e2 >= lower2 and c0 + e0 <= upper0
                        and c1 + e1 <= upper1 and c2 + e2 <= upper2):
                    a = int(np.floor((c0 - lower[0]) / resolution))
                    b = int(np.floor((c1 - lower[1]) / resolution))
                    c = int(np.floor((c2 - lower[2]) / resolution))
                    if 0 <= a < nx and 0 <= b < ny and 0 <= c < nz:
                        bound = sdf[(a * ny + b) * nz + c] - radii[s] - slack
                        if bound > 0.0 and bound > best:
                            continue
            for j in range(starts[s], starts[s + 1]):
                p0, p1, p2 = _placed(rot, trans, i, local[j, 0], local[j, 1], local[j, 2])
                a = int(np.floor((p0 - lower[0]) / resolution))
                b = int(np.floor((p1 - lower[1]) / resolution))
                c = int(np.floor((p2 - lower[2]) / resolution))
                if a < 0 or b < 0 or c < 0 or a >= nx or b >= ny or c >= nz:
                    off = True
                    break
                flat = (a * ny + b) * nz + c
                if occupied[flat]:
                    hit = True
                d = sdf[flat]
                if d < best or (d == best and index[j] < arg):
                    best = d
                    arg = index[j]
            if off:
                break
        if off:     # the first point off the grid in the surface's order (rare: every point is looked at)
            hit = True
            best = -np.inf
            arg = local.shape[0]
            for j in range(local.shape[0]):
                if index[j] < arg:
                    p0, p1, p2 = _placed(rot, trans, i, local[j, 0], local[j, 1], local[j, 2])
                    a = int(np.floor((p0 - lower[0]) / resolution))
                    b = int(np.floor((p1 - lower[1]) / resolution))
                    c = int(np.floor((p2 - lower[2]) / resolution))
                    if a < 0 or b < 0 or c < 0 or a >= nx or b >= ny or c >= nz:
                        arg = index[j]
        clearance[i] = best
        closest[i] = arg
        colliding[i] = hit
    return clearance, closest, colliding


class Clearance:
    """Collision and clearance queries of a robot's surface points against a voxel grid."""

    def __init__(self, robot: RobotModel, grid: VoxelGrid, threads: int = 1) -> None:
        self.robot = robot
        self.threads = max(1, int(threads))
        self.grid = grid
        self.surface = np.asarray(robot.surface_indices(), dtype=np.int64)
        self.sdf = np.ascontiguousarray(grid.sdf.reshape(-1), dtype=np.float64)
        self.occupied = np.ascontiguousarray(grid.occupied.reshape(-1))
        self.shape = np.asarray(grid.shape, dtype=np.int64)
        self.lower = np.asarray(grid.lower, dtype=np.float64)
        # a rigid body's surface points in its frame (they do not depend on the configuration), and their reach
        # the body-frame points do not depend on the configuration: any sample gives them (no result depends on it)
        placement = robot.rigid_placement(robot.space.sample(np.random.default_rng(0), 1))
        self.local = None if placement is None else np.ascontiguousarray(placement[2][self.surface])
        self.reach = None if self.local is None else \
            (float(np.max(np.linalg.norm(self.local, axis=1))) if len(self.local) else 0.0)
        #: the rigid kernel's broad phase: the surface in a spatial order (``order``: each point's place in
        #: ``local``) and its runs (``pliant.api.spatial_runs``).  The surface's own order jumps about the body (the
        #: peg's runs averaged 3 points); grouped by cells a run across, they average 15 on the peg and 13 on the
        #: L-block, and the kernel skips them whole.
        self.order = self._walked = self.segments = None
        if self.local is not None:
            self.order, *runs = spatial_runs(self.local, SEGMENT_RADIUS * float(grid.resolution), SEGMENT_POINTS)
            self._walked = np.ascontiguousarray(self.local[self.order])
            self.segments = tuple(runs)

    def query(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For configurations ``(n, d)``: clearance ``(n,)`` (m; ``-inf`` outside the grid), the index into
        :attr:`surface` of the closest point ``(n,)``, and whether each collides ``(n,)``."""
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        if len(q) == 0:
            return np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)
        placement = self.robot.rigid_placement(q)
        if placement is not None:
            rot, trans = np.ascontiguousarray(placement[0]), np.ascontiguousarray(placement[1])
            if self.threads == 1 or len(q) < THREADED:
                return self._rigid(rot, trans)
            from concurrent.futures import ThreadPoolExecutor

            parts = np.array_split(np.arange(len(q)), self.threads)
            with ThreadPoolExecutor(self.threads) as pool:
                out = list(pool.map(lambda rows: self._rigid(rot[rows], trans[rows]), parts))
            return tuple(np.concatenate(values) for values in zip(*out))
        out = [self._articulated(q[s:s + CHUNK]) for s in range(0, len(q), CHUNK)]
        return tuple(np.concatenate(parts) for parts in zip(*out))

    def _rigid(self, rot, trans):
        starts, centres, extents, radii = self.segments
        return _rigid_clearance(np.ascontiguousarray(rot), np.ascontiguousarray(trans), self._walked, self.order,
                                self.sdf, self.occupied, self.shape, self.lower, float(self.grid.resolution), starts,
                                centres, extents, radii)

    def _articulated(self, q):
        points = self.robot.body_points(q, self.surface)
        flat = self.grid.flat_index(points)
        outside = flat < 0
        safe = np.where(outside, 0, flat)
        distance = np.where(outside, -np.inf, self.sdf[safe])
        colliding = (outside | self.occupied[safe]).any(axis=1)
        closest = np.argmin(distance, axis=1)
        return distance[np.arange(len(q)), closest], closest, colliding

    def lower_bound(self, q: np.ndarray, clearance: np.ndarray) -> np.ndarray:
        """A lower bound ``(n,)`` (m) on how far any surface point of rigid configurations ``q`` ``(n, d)`` can move
        before it enters an occupied voxel or leaves the grid, from their :meth:`query` clearance.

        A point anywhere in a voxel whose centre has signed distance ``s`` is at least ``s - (sqrt(3)/2) h`` from
        occupied space (one voxel ``h`` is used); the grid's faces (along the axes the grid has more than one voxel)
        are at least the frame origin's distance to them minus :attr:`reach`.
        """
        placement = self.robot.rigid_placement(np.atleast_2d(q))
        origin = placement[1]
        upper = self.lower + self.shape * self.grid.resolution
        axes = self.shape > 1
        faces = np.minimum(origin - self.lower, upper - origin)[:, axes]
        boundary = (np.min(faces, axis=1) if faces.size else np.full(len(origin), np.inf)) - self.reach
        return np.minimum(clearance - self.grid.resolution, boundary)

    def colliding(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: configurations with a surface point in an occupied voxel or outside the grid."""
        return self.query(q)[2]
