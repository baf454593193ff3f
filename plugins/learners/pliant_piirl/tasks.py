"""Where to ask for demonstrations: object adjacency and Algorithm 3's task generation (thesis 4.3.2).

- :func:`adjacency`: objects ``i`` and ``j`` are adjacent when some free point lies within ``distance`` of both
  (a probe passing between them can touch both).  Computed on the voxel grid with Euclidean distance transforms.
- :func:`edge_points`: the medial axis between two adjacent objects: free voxel centres equally far (within one
  voxel) from both, within ``distance`` of each and at least ``edge_isolation`` from every other object (near a
  corner a point lies between three objects, and the task would not ask about the pair).
  GETEDGEPOINTBETWEENOBJECTS picks one at random.
- :func:`inside`: the chapter's footnote: from a point, climb the distance field away from the objects to its
  local maximum; the point is "inside" the environment when that maximum is not on the grid's boundary.
- :func:`generate_task` (Algorithm 3): the target is sampled ``T_range`` (a depth range, m) from the edge point,
  in a direction within ``target_cone`` of the way into the environment there (away from both objects; an
  oblique axis would start the probe against a third object), inside, and at least ``T_clearance`` from every
  object (the text's "at least"; the listing's ``<`` is read as a typo, since a target inside an object could not
  be touched without deforming it); then the collision planes.
  One addition, documented as ``medial_tolerance``: the target also lies on the medial surface of the pair (as
  far from one object as from the other).  Off it, the geometry alone can make the cheapest insertion deform the
  more sensitive object more (it is nearer the tip), and the demonstration would not say which object the
  demonstrator prefers.
- :func:`funnel_planes` (GENERATECOLLISIONPLANES): four half-spaces around the axis from the target out through
  the edge point.  Across the gap between the two objects they open at ``across_angle`` from a half-width
  ``across_width`` at the target, so the probe can press into either object; along the edge they open at
  ``along_angle`` from ``along_width``, which keeps the probe away from the other objects.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import ConfigError, PlanningError, VoxelGrid, cached_arrays, option
from scipy import ndimage

from pliant_piirl.demonstration import DemonstrationTask


@dataclass(frozen=True)
class TaskOptions:
    """Options of task generation (Algorithm 3) and of the funnel (lengths in m, angles in rad)."""

    adjacency_distance: float = option(0.012, "objects are adjacent when a free point lies this close to both (m)",
                                       minimum=1e-9)
    edge_isolation: float = option(0.03, "edge points lie at least this far from every other object (m), so that a "
                                   "task asks about its two objects only", minimum=0.0)
    depth_range: tuple[float, float] = option((0.03, 0.05), "T_range: the target's distance from the edge point "
                                              "(m, lower and upper)")
    target_cone: float = option(0.5, "the target is sampled within this angle of the direction away from both "
                                "objects at the edge point (rad; pi: any direction, as Algorithm 3's listing)",
                                minimum=0.0, maximum=float(np.pi))
    clearance: float = option(0.02, "T_clearance: the target's least distance from every object (m)", minimum=0.0)
    medial_tolerance: float = option(0.004, "the target is as far from one object of the pair as from the other, "
                                     "within this (m; inf: anywhere, as Algorithm 3's listing)", minimum=0.0)
    start_distance: float = option(0.05, "the probe starts with its tip this far out from the edge point (m)",
                                   minimum=0.0)
    across_width: float = option(0.02, "funnel half-width across the gap at the target (m)", minimum=1e-9)
    across_angle: float = option(0.6, "funnel opening across the gap (rad)", minimum=0.0, maximum=1.5)
    along_width: float = option(0.012, "funnel half-width along the edge at the target (m)", minimum=1e-9)
    along_angle: float = option(0.15, "funnel opening along the edge (rad)", minimum=0.0, maximum=1.5)
    attempts: int = option(10_000, "most target samples before giving up", minimum=1)


#: the version of :func:`distance_fields` in the cache's keys: change it when its results would change
FIELDS_VERSION = "1"


def distance_fields(object_id: np.ndarray, occupied: np.ndarray, resolution: float, count: int) -> dict:
    """Distance (m) from every voxel centre to the nearest voxel of each object ``object{i}`` (``i < count``) and to
    the nearest occupied voxel (``clearance``): exact Euclidean transforms of the grid."""
    fields = {f"object{i}": ndimage.distance_transform_edt(object_id != i) * resolution for i in range(count)}
    fields["clearance"] = ndimage.distance_transform_edt(~occupied) * resolution
    return fields


class TaskSpace:
    """The distance fields of a scene's objects and what Algorithms 2 and 3 ask of them."""

    def __init__(self, scene, options: TaskOptions | None = None) -> None:
        self.scene, self.options = scene, options or TaskOptions()
        lo, hi = self.options.depth_range
        if not 0 <= lo <= hi:
            raise ConfigError("must be two lengths, lower <= upper", field="depth_range", value=[lo, hi])
        self.grid = VoxelGrid.from_scene(scene)
        self.names = list(self.grid.object_names)
        grid, count = self.grid, len(self.names)
        # one Euclidean transform per object and one of the free space: built once per grid (pliant.cache)
        fields = cached_arrays("piirl-task-fields", FIELDS_VERSION,
                               (grid.object_id, grid.occupied, float(grid.resolution), count),
                               lambda: distance_fields(grid.object_id, grid.occupied, grid.resolution, count))
        self._each = [fields[f"object{i}"] for i in range(count)]
        self.clearance_field = fields["clearance"]

    # --- Algorithm 2's graph -----------------------------------------------------------------------------------

    def adjacency(self) -> dict[str, set[str]]:
        """``{object: set of adjacent objects}`` (see the module docstring)."""
        near = [d <= self.options.adjacency_distance for d in self._each]
        free = ~self.grid.occupied
        return {a: {b for j, b in enumerate(self.names) if j != i and np.any(near[i] & near[j] & free)}
                for i, a in enumerate(self.names)}

    def edge_points(self, first: str, second: str) -> np.ndarray:
        """Free points ``(n, 3)`` on the medial axis between two objects, within the adjacency distance of both."""
        i, j = self._index(first), self._index(second)
        di, dj = self._each[i], self._each[j]
        res = self.grid.resolution
        near = np.maximum(di, dj) <= self.options.adjacency_distance
        mask = (~self.grid.occupied) & (np.abs(di - dj) <= res) & near
        for k, other in enumerate(self._each):
            if k not in (i, j):
                mask &= other >= self.options.edge_isolation
        return self.grid.centres(np.argwhere(mask))

    # --- Algorithm 3 -------------------------------------------------------------------------------------------

    def inside(self, point: np.ndarray) -> bool:
        """The footnote's test: steepest ascent of the clearance field from ``point`` ends away from the bounds."""
        field = self.clearance_field
        index = np.clip(np.floor((np.asarray(point) - self.grid.lower) / self.grid.resolution).astype(int), 0,
                        np.array(field.shape) - 1)
        offsets = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)])
        shape = np.array(field.shape)
        for _ in range(int(shape.sum()) * 2):
            around = np.clip(index + offsets, 0, shape - 1)
            values = field[tuple(around.T)]
            best = int(np.argmax(values))
            if values[best] <= field[tuple(index)]:
                break
            index = around[best]
        return bool(np.all(index > 0) and np.all(index < shape - 1))

    def medial(self, first: str, second: str, point: np.ndarray) -> bool:
        """Whether ``point`` is as far from one object as from the other, within :attr:`TaskOptions.medial_tolerance`
        (always true when the tolerance is infinite)."""
        tolerance = self.options.medial_tolerance
        if not np.isfinite(tolerance):
            return True
        index = np.floor((np.asarray(point) - self.grid.lower) / self.grid.resolution).astype(int)
        if np.any(index < 0) or np.any(index >= np.array(self.clearance_field.shape)):
            return False
        i, j = self._index(first), self._index(second)
        return bool(abs(self._each[i][tuple(index)] - self._each[j][tuple(index)]) <= tolerance)

    def clearance(self, point: np.ndarray) -> float:
        """Distance (m) from ``point`` to the nearest object, from the grid's distance field."""
        index = np.floor((np.asarray(point) - self.grid.lower) / self.grid.resolution).astype(int)
        if np.any(index < 0) or np.any(index >= np.array(self.clearance_field.shape)):
            return 0.0
        return float(self.clearance_field[tuple(index)])

    def generate_task(self, first: str, second: str, rng: np.random.Generator, tip_offset: np.ndarray,
                      rotation_of) -> DemonstrationTask:
        """Algorithm 3 for the pair: edge point, target, collision planes, and the probe's start configuration.

        ``tip_offset``: the tip in the probe's body frame (m); ``rotation_of(axis)``: a unit quaternion
        (x, y, z, w) turning the body z axis onto ``axis``.  The probe starts outside, on the funnel's axis, its
        tip :attr:`TaskOptions.start_distance` beyond the edge point, pointing at the target.
        """
        edges = self.edge_points(first, second)
        if len(edges) == 0:
            raise PlanningError(f"objects {first!r} and {second!r} are not adjacent: no edge point between them",
                                field="objects", value=[first, second])
        o = self.options
        i, j = self._index(first), self._index(second)
        for _ in range(o.attempts):
            edge = edges[rng.integers(len(edges))]
            direction = self._within_cone(self._inward(i, j, edge), o.target_cone, rng)
            target = edge + direction * rng.uniform(*o.depth_range)
            if self.clearance(target) >= o.clearance and self.medial(first, second, target) and self.inside(target):
                break
        else:
            raise PlanningError(f"no target inside the environment within {o.depth_range} m of the edge between "
                                f"{first!r} and {second!r} and {o.clearance} m from every object after {o.attempts} "
                                "samples", field="depth_range", value=list(o.depth_range))
        axis = edge - target
        axis /= np.linalg.norm(axis)
        planes = self.funnel_planes(first, second, edge, target)
        orientation = np.asarray(rotation_of(axis), dtype=np.float64)
        tip = edge + axis * o.start_distance
        start = np.concatenate([tip - _rotate(orientation, tip_offset), orientation])
        return DemonstrationTask(start, target, planes, (first, second), edge)

    def _inward(self, i: int, j: int, point: np.ndarray) -> np.ndarray:
        """Unit vector at ``point`` away from both objects: the sum of their distance fields' gradients."""
        index = np.clip(np.floor((point - self.grid.lower) / self.grid.resolution).astype(int), 1,
                        np.array(self.clearance_field.shape) - 2)
        g = np.zeros(3)
        for field in (self._each[i], self._each[j]):
            for axis in range(3):
                up, down = index.copy(), index.copy()
                up[axis] += 1
                down[axis] -= 1
                g[axis] += field[tuple(up)] - field[tuple(down)]
        norm = np.linalg.norm(g)
        return g / norm if norm > 0 else np.array([0.0, 0.0, 1.0])

    @staticmethod
    def _within_cone(axis: np.ndarray, half_angle: float, rng: np.random.Generator) -> np.ndarray:
        """A unit vector drawn uniformly (by solid angle) within ``half_angle`` rad of unit vector ``axis``."""
        cos_t = rng.uniform(np.cos(half_angle), 1.0)
        phi = rng.uniform(0.0, 2 * np.pi)
        u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(axis, u)
        sin_t = np.sqrt(1.0 - cos_t**2)
        return cos_t * axis + sin_t * (np.cos(phi) * u + np.sin(phi) * v)

    def funnel_planes(self, first: str, second: str, edge: np.ndarray, target: np.ndarray) -> np.ndarray:
        """GENERATECOLLISIONPLANES: four rows ``(n, offset)``, ``n . x <= offset`` (see the module docstring)."""
        o = self.options
        axis = edge - target
        axis /= np.linalg.norm(axis)
        across = self._centre_near(first, edge) - self._centre_near(second, edge)
        across -= axis * (across @ axis)
        if np.linalg.norm(across) < 1e-12:
            across = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        across /= np.linalg.norm(across)
        along = np.cross(axis, across)
        rows = []
        for side, width, angle in ((across, o.across_width, o.across_angle), (along, o.along_width, o.along_angle)):
            for sign in (1.0, -1.0):
                normal = sign * side * np.cos(angle) - axis * np.sin(angle)
                rows.append(np.r_[normal, normal @ (target + sign * side * width)])
        return np.array(rows)

    def _centre_near(self, name: str, point: np.ndarray) -> np.ndarray:
        i = self._index(name)
        cells = np.argwhere(self.grid.object_id == i)
        centres = self.grid.centres(cells)
        near = np.linalg.norm(centres - point, axis=1) <= self.options.adjacency_distance * 2
        return centres[near].mean(axis=0) if near.any() else centres.mean(axis=0)

    def _index(self, name: str) -> int:
        if name not in self.names:
            raise ConfigError(f"no object of that name (the scene has {self.names})", field="objects", value=name)
        return self.names.index(name)


def _rotate(quaternion: np.ndarray, vector: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(quaternion).apply(vector)


def rotation_onto(axis: np.ndarray) -> np.ndarray:
    """The unit quaternion (x, y, z, w) of the shortest rotation taking the z axis onto unit vector ``axis``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    c = float(z @ axis)
    if c < -1 + 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])
    v = np.cross(z, axis)
    q = np.r_[v, 1.0 + c]
    return q / np.linalg.norm(q)
