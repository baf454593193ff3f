"""How deep a robot would start inside the scene's obstacles: the measure simulators give the core's start check.

Every simulator refuses a start (``reset``, ``simulate``, a first ``step``) that puts the robot inside a rigid
obstacle (:func:`pliant.contracts.check_starts`); it supplies the measure through
:meth:`pliant.interfaces.Simulator.start_penetration`.  The built-in simulators share this one: the robot model's
surface points (:meth:`pliant.interfaces.RobotModel.surface_indices`) against the voxels of the obstacles the
simulator builds its world from (the kinematic simulator collides with the grid itself; pymunk and pybullet build
their static walls from the same voxels, merged into boxes), so a start means the same thing in every simulator.

A point's depth is its distance (m) to the nearest free voxel: exact below one voxel, which is all a tolerance
of a fraction of a voxel needs (a free voxel outside the 3 x 3 x 3 block around the point's own is a voxel or more
away); deeper points get the signed distance field's depth, at least one voxel.
"""

from __future__ import annotations

import itertools

import numpy as np

from pliant.geometry.voxelgrid import VoxelGrid


class VoxelStartCheck:
    """Penetration of a robot's surface points into ``grid``'s occupied voxels.

    ``outside_solid``: points outside the grid are inside an obstacle (the kinematic simulator and pymunk close the
    scene's bounds with walls), else free (pybullet has no walls there).  ``robot``: a
    :class:`~pliant.interfaces.RobotModel`.
    """

    def __init__(self, grid: VoxelGrid, robot, *, outside_solid: bool = True) -> None:
        self.grid = grid
        self.robot = robot
        self.outside_solid = outside_solid
        self.surface = np.asarray(robot.surface_indices(), dtype=np.int64)
        # the occupancy with one layer of "outside" around it: any index clipped to [-1, n] looks up in one step
        self._solid_padded = np.pad(grid.occupied, 1, constant_values=outside_solid)
        self._last = np.asarray(grid.shape, dtype=np.int64)

    def _solid(self, index: np.ndarray) -> np.ndarray:
        """Bool ``(m,)``: voxel indices ``(m, 3)`` that are occupied (or outside the grid, when that is solid)."""
        i = np.clip(index, -1, self._last) + 1
        return self._solid_padded[i[:, 0], i[:, 1], i[:, 2]]

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Depth (m) of points ``(m, 3)`` inside the obstacles: 0 in a free voxel, else the distance to the nearest
        free voxel (exact below one voxel; deeper, the signed distance field's depth, at least one voxel)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        res = self.grid.resolution
        index = np.floor((points - self.grid.lower) / res).astype(np.int64)
        out = np.zeros(len(points))
        inside = np.nonzero(self._solid(index))[0]
        if len(inside) == 0:
            return out
        p, index = points[inside], index[inside]
        best = np.full(len(p), np.inf)
        for offset in itertools.product((-1, 0, 1), repeat=3):
            j = index + offset
            free = ~self._solid(j)
            if not free.any():
                continue
            lower = self.grid.lower + j * res
            gap = np.maximum(np.maximum(lower - p, p - (lower + res)), 0.0)
            best = np.where(free, np.minimum(best, np.linalg.norm(gap, axis=1)), best)
        deep = ~np.isfinite(best)
        if deep.any():
            best[deep] = np.maximum(res, -self.grid.sdf_at(p[deep]))
        out[inside] = best
        return out

    def penetration(self, configurations: np.ndarray) -> np.ndarray:
        """Depth (m) of the deepest surface point at each configuration ``(n, d)``: ``(n,)``, 0 where all are free."""
        q = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
        points = self.robot.body_points(q, self.surface)
        return self.depth(points.reshape(-1, 3)).reshape(len(q), -1).max(axis=1, initial=0.0)

    def describe(self, q: np.ndarray) -> str:
        """What holds the deepest surface point at ``q`` ``(d,)`` (:meth:`describe_points`)."""
        return self.describe_points(self.robot.body_points(np.asarray(q, dtype=np.float64)[None], self.surface)[0])

    def describe_points(self, points: np.ndarray) -> str:
        """What holds the deepest of points ``(m, 3)``: ``object 'name'``, the walls closing the scene's bounds
        (outside the grid), or ``""`` when no point is inside."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        depth = self.depth(points)
        if not (depth > 0).any():
            return ""
        deepest = points[int(np.argmax(depth))]
        index, in_grid = self.grid.index(deepest[None])
        if not in_grid[0]:
            return "the walls closing the scene's bounds (outside the grid)"
        k = int(self.grid.object_id[tuple(index[0])])
        return f"object '{self.grid.object_names[k]}'" if k >= 0 else "an obstacle"
