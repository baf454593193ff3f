"""Validity of states and motions: the core's collision checker of a scene and a robot (DESIGN rule 11).

A planner that reports ``solved`` returns a path whose every state, and every motion between states, is
valid.  Validity depends on the scene and the robot only, never on the cost model:

- **States.**  A configuration is valid when no body point of the robot (:meth:`RobotModel.body_points`) lies
  where its material may not be: a point of deformability 0 in a voxel of deformability 0 (the thesis's
  "implicit collision", eq. 3.1 undefined), any point in a voxel of a forbidden object (NaN sensitivity),
  a point of NaN sensitivity in any object, or any point outside the workspace -- exactly the states the voxel
  cost marks NaN, but computed from the scene's :class:`~pliant.geometry.voxelgrid.VoxelGrid` without a cost
  model.  Movable objects (those with a ``mass``) are not obstacles: a robot may push them.  A point exactly
  on a face between a free and a forbidden voxel touches the obstacle and is valid (to a relative 1e-7
  voxel, so rounding does not decide).  A robot with a collision model of its own (URDF robots:
  :meth:`RobotModel.collisions`, the pinocchio plugin's coal geometry and self-collision) must pass it too.
- **Motions.**  The motion ``a -> b`` is the space's interpolation.  It is checked by conservative advancement
  on the body points: samples no further apart than one voxel of body-point displacement, then every interval
  whose two ends are far enough from the obstacles (per point, clearance at both ends summing to more than
  the interval's displacement bound) is certified collision-free for the whole continuum; the others are
  bisected, down to ``floor`` (a fraction of a voxel) where the samples themselves decide.  The displacement
  bound of a rigid body is exact: ``|dt| + r_max * angle`` (``r_max`` the farthest body point from the
  reference point); other robots use the largest body-point chord times pi/2 (the arc of one rotation up to
  half a turn), on samples at which every joint turns through at most a voxel at the body's reach.

Everything is batched: ``(n, d)`` configurations, ``(m, d)`` motion pairs.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pliant.cache import cached_arrays
from pliant.errors import PlanningError
from pliant.geometry.voxelgrid import VoxelGrid

#: version of the cached far-field clearance: change it whenever _far_clearance_build's output changes
FAR_CLEARANCE_VERSION = "validity-far-clearance-1"

#: relative slack (voxel units) under which a point on a voxel face counts as touching, not inside
FACE_SLACK = 1e-7
#: default bisection floor: motions are resolved down to this fraction of a voxel of body-point displacement
FLOOR_FRACTION = 1.0 / 64.0
#: states evaluated per batch (bounds memory: states x body points)
CHUNK_POINTS = 2_000_000


@dataclass
class Verdict:
    """The outcome of checking a path: ``valid``; otherwise ``index`` (the first invalid state, or the start
    of the first invalid motion, in the path's order), ``kind`` (``"state"`` or ``"motion"``) and ``reason``
    (one sentence naming the configuration)."""

    valid: bool
    index: int = -1
    kind: str = ""
    reason: str = ""
    checked_states: int = 0
    details: dict[str, Any] = field(default_factory=dict)


class ValidityChecker:
    """States and motions of ``robot`` among ``scene``'s obstacles (see the module docstring).

    ``floor``: bisection floor of the motion check as a fraction of a voxel (default 1/64).
    """

    def __init__(self, scene, robot, *, floor: float = FLOOR_FRACTION) -> None:
        if scene is None or robot is None:
            raise PlanningError("a validity checker needs the scene and the robot", field="scene" if scene is None
                                else "robot")
        if not 0.0 < floor <= 1.0:
            raise PlanningError("the bisection floor must be a fraction of a voxel in (0, 1]", field="floor",
                                value=floor)
        self.scene = scene
        self.robot = robot
        self.space = robot.space
        self.grid = VoxelGrid.from_scene(scene, static_only=True)
        self.resolution = float(self.grid.resolution)
        self.floor = floor * self.resolution
        materials = np.asarray(robot.point_materials(), dtype=np.float64)
        self.classes, forbidden = _forbidden_grids(materials, self.grid)
        self._lower = np.asarray(self.grid.lower, dtype=np.float64)
        self._shape = np.asarray(self.grid.shape, dtype=np.int64)
        # planar robots (SE(2)) never move their points along z: the layer is theirs, its faces are not obstacles
        self._moving_axes = np.array([True, True, self.space.kind != "se2"])
        offsets = np.array(list(itertools.product((-1, 0, 1), repeat=3)), dtype=np.int64)
        self._offsets = offsets[np.all((offsets == 0) | self._moving_axes, axis=1) & np.any(offsets != 0, axis=1)]
        # per material class, padded by one voxel of "outside" (forbidden): the forbidden cubes, and the voxels
        # with a forbidden cube among their neighbours along the moving axes (only their points need exact clearance)
        self._padded_shape = self._shape + 2
        grids = np.ones((len(forbidden), *self._padded_shape), dtype=bool)
        grids[:, 1:-1, 1:-1, 1:-1] = forbidden.reshape(len(forbidden), *self._shape)
        near = grids.copy()
        for axis in range(3):
            if self._moving_axes[axis]:
                grown = near.copy()
                grown[(slice(None),) * (axis + 1) + (slice(1, None),)] |= near[(slice(None),) * (axis + 1)
                                                                                + (slice(None, -1),)]
                grown[(slice(None),) * (axis + 1) + (slice(None, -1),)] |= near[(slice(None),) * (axis + 1)
                                                                                 + (slice(1, None),)]
                near = grown
        self._forbidden_padded = grids.reshape(len(forbidden), -1)
        self._near_padded = near.reshape(len(forbidden), -1)
        self._grids = grids
        self._far_table: np.ndarray | None = None       # the far-field bound, on the first motion check
        self._rigid = self._rigid_layout()
        self._reach = self._body_reach()
        self._has_collisions = type(robot).collisions is not _robot_base_collisions()

    @classmethod
    def from_context(cls, context) -> ValidityChecker | None:
        """The checker of a pipeline's scene and robot (built once and kept in ``context.extras["validity"]``);
        ``None`` without a scene or a robot."""
        if context is None or getattr(context, "scene", None) is None or getattr(context, "robot", None) is None:
            return None
        cached = context.extras.get("validity")
        if isinstance(cached, ValidityChecker) and cached.robot is context.robot and cached.scene is context.scene:
            return cached
        checker = cls(context.scene, context.robot)
        context.extras["validity"] = checker
        return checker

    # --- states ----------------------------------------------------------------------------------

    def states_valid(self, q: np.ndarray, tolerance: float = 0.0) -> np.ndarray:
        """Bool ``(n,)``: each configuration ``(n, d)`` (or ``(d,)``) is in the space's bounds and collision-free.

        ``tolerance`` (m, below half a voxel): a point that far (per axis) from a cube it may enter still counts
        as touching -- the contact slop of a simulator's own states (``Simulator.start_tolerance``); 0 for plans.
        """
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        ok = np.asarray(self.space.is_valid(q), dtype=bool).reshape(-1)
        if ok.any():
            idx = np.nonzero(ok)[0]
            ok[idx] = self._free(q[idx], clearance=False, tolerance=tolerance)[0]
        return ok

    def explain(self, q: np.ndarray) -> str | None:
        """Why the configuration ``(d,)`` is invalid (which object or the workspace), or ``None`` when it is valid."""
        q = np.asarray(q, dtype=np.float64).reshape(1, -1)
        if not np.all(self.space.is_valid(q)):
            return "outside the space's bounds"
        points = self.robot.body_points(q)[0]
        bad = ~self._points_free(points)
        if bad.any():
            i = int(np.argmax(bad))
            idx, inside = self.grid.index(points[i])
            if not inside:
                return f"body point {i} at {np.round(points[i], 6).tolist()} leaves the workspace"
            obj = int(self.grid.object_id[tuple(idx)])
            name = self.grid.object_names[obj] if obj >= 0 else "?"
            return f"body point {i} at {np.round(points[i], 6).tolist()} collides with object '{name}'"
        if self._has_collisions and bool(np.asarray(self.robot.collisions(q))[0]):
            return "the robot's collision model collides (with an obstacle or itself)"
        return None

    # --- motions ---------------------------------------------------------------------------------

    def motions_valid(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Bool ``(m,)``: the motions ``a[i] -> b[i]`` (``(m, d)`` or ``(d,)``, broadcast) are valid at every
        instant (states at both ends included)."""
        return self._motions(a, b)[0]

    def _motions(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, int]:
        a, b = np.broadcast_arrays(np.atleast_2d(np.asarray(a, dtype=np.float64)),
                                   np.atleast_2d(np.asarray(b, dtype=np.float64)))
        m = len(a)
        ok = np.ones(m, dtype=bool)
        if m == 0:
            return ok, 0
        # the initial samples: a rigid body's motions start whole (far from obstacles the clearance certifies long
        # intervals; near them the intervals are bisected); other robots' one voxel of body-point displacement apart
        if self._rigid is not None:
            pieces = np.ones(m, dtype=np.int64)
        else:
            pieces = np.maximum(1, np.ceil(self._sample_bound(a, b) / self.resolution - 1e-9)).astype(np.int64)
        owner = np.repeat(np.arange(m), pieces + 1)
        first = np.concatenate([[0], np.cumsum(pieces + 1)])[:-1]
        j = np.arange(len(owner)) - first[owner]
        t = j / pieces[owner]
        states = self.space.interpolate(a[owner], b[owner], t[:, None])
        free, clear, points = self._free(states, clearance=True)
        checked = len(states)
        np.logical_and.at(ok, owner, free)
        # intervals between consecutive samples of the same motion: (owner, t0, t1, clearance0, clearance1)
        left = np.nonzero(j[:-1] < pieces[owner[:-1]])[0]
        iv = _Intervals(owner[left], t[left], t[left + 1], clear[left], clear[left + 1],
                        points[left], points[left + 1])
        while len(iv.owner):
            keep = ok[iv.owner]
            iv = iv.take(keep)
            if not len(iv.owner):
                break
            delta = self._interval_bound(a[iv.owner], b[iv.owner], iv)
            certified = np.all(iv.c0 + iv.c1 > delta[:, None], axis=1)
            settled = certified | (delta <= self.floor)
            iv = iv.take(~settled)
            if not len(iv.owner):
                break
            mid = 0.5 * (iv.t0 + iv.t1)
            states = self.space.interpolate(a[iv.owner], b[iv.owner], mid[:, None])
            free, clear, points = self._free(states, clearance=True)
            checked += len(states)
            np.logical_and.at(ok, iv.owner, free)
            iv = _Intervals(np.concatenate([iv.owner, iv.owner]), np.concatenate([iv.t0, mid]),
                            np.concatenate([mid, iv.t1]), np.concatenate([iv.c0, clear]),
                            np.concatenate([clear, iv.c1]), np.concatenate([iv.p0, points]),
                            np.concatenate([points, iv.p1]))
        return ok, checked

    def path_verdict(self, configurations: np.ndarray) -> Verdict:
        """Check a path ``(k, d)``: every state, then every motion between consecutive states."""
        path = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
        if path.shape[-1] != self.space.dim or not np.all(np.isfinite(path)):
            return Verdict(False, 0, "state", f"the path is not a sequence of finite {self.space.dim}-coordinate "
                                              "configurations")
        states = self.states_valid(path)
        if not states.all():
            i = int(np.argmin(states))
            return Verdict(False, i, "state", f"state {i} {np.round(path[i], 6).tolist()} is not valid: "
                                              f"{self.explain(path[i]) or 'collides'}", len(path))
        if len(path) < 2:
            return Verdict(True, checked_states=len(path))
        motions, checked = self._motions(path[:-1], path[1:])
        if not motions.all():
            i = int(np.argmin(motions))
            return Verdict(False, i, "motion", f"the motion from state {i} to state {i + 1} collides between "
                                               f"them (checked to 1/{round(self.resolution / self.floor)} voxel)",
                           len(path) + checked)
        return Verdict(True, checked_states=len(path) + checked)

    # --- internals -------------------------------------------------------------------------------

    def _free(self, q: np.ndarray, clearance: bool,
              tolerance: float = 0.0) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Per configuration: collision-free ``(n,)``; with ``clearance`` also each body point's distance (m) to
        the nearest cube its material may not enter ``(n, m)`` and the points ``(n, m, 3)``."""
        n = len(q)
        count = max(1, self.robot.point_count())
        chunk = max(1, CHUNK_POINTS // count)
        free = np.empty(n, dtype=bool)
        clear = np.empty((n, count)) if clearance else None
        # the points themselves only where the displacement bound needs them (articulated robots)
        kept = 0 if self._rigid is not None else count
        pts_out = np.empty((n, kept, 3)) if clearance else None
        for s in range(0, n, chunk):
            part = q[s:s + chunk]
            points = np.asarray(self.robot.body_points(part), dtype=np.float64)
            ok = self._points_free(points, tolerance)
            free[s:s + chunk] = ok.all(axis=1)
            if clearance:
                c = self._clearance(points)
                clear[s:s + chunk] = np.where(ok, c, 0.0)
                if kept:
                    pts_out[s:s + chunk] = points
        if self._has_collisions and free.any():
            idx = np.nonzero(free)[0]
            free[idx] &= ~np.asarray(self.robot.collisions(q[idx]), dtype=bool).reshape(-1)
        return free, clear, pts_out

    def _points_free(self, points: np.ndarray, tolerance: float = 0.0) -> np.ndarray:
        """Bool ``(..., m)``: each point ``(..., m, 3)`` is outside every cube its material may not enter (a point on
        the face between such a cube and an allowed one touches it and is free; so is one within ``tolerance`` m of
        it).  One compiled pass (:func:`pliant.components.validity_kernels.points_free`)."""
        from pliant.components import validity_kernels as kernels  # numba: loaded on the first check, not at import

        flat = _as_points(points)
        out = np.empty(flat.shape[:2], dtype=bool)
        slack = min(max(FACE_SLACK, tolerance / self.resolution), 0.5)
        kernels.points_free(flat, self.classes, self._lower, 1.0 / self.resolution, self._padded_shape,
                            self._forbidden_padded, slack, out)
        return out.reshape(np.shape(points)[:-1])

    def _clearance(self, points: np.ndarray) -> np.ndarray:
        """Lower bound ``(..., m)`` (m) of each point's distance to the nearest cube its material may not enter:
        exact for the cubes next to the point's voxel, and at least the distance to the edge of that 3 x 3 x 3
        block beyond (the moving axes only).  One compiled pass (:func:`pliant.components.validity_kernels.
        clearances`)."""
        from pliant.components import validity_kernels as kernels

        if self._far_table is None:
            self._far_table = self._far_clearance(self._grids)
        flat = _as_points(points)
        out = np.empty(flat.shape[:2])
        kernels.clearances(flat, self.classes, self._lower, self.resolution, self._padded_shape,
                           self._forbidden_padded, self._near_padded, self._far_table, self._moving_axes,
                           self._offsets, out)
        return out.reshape(np.shape(points)[:-1])

    def _far_clearance(self, grids: np.ndarray) -> np.ndarray:
        """Per class and padded voxel, a lower bound (m) on the distance from the voxel's centre to the nearest cube
        the class may not enter: with ``e`` the Euclidean distance between the centres (moving axes only), the gap
        to that cube is at least ``max(e / 2, e - sqrt(k) h / 2)`` (``k`` moving axes); flat ``(c, N)``.  Kept in
        the preprocessing cache (:mod:`pliant.cache`) under the forbidden grids, the resolution and the moving axes:
        its distance transforms take seconds on a large grid."""
        inputs = (grids, float(self.resolution), self._moving_axes)
        return cached_arrays("validity-far-clearance", FAR_CLEARANCE_VERSION, inputs,
                             lambda: {"far": self._far_clearance_build(grids)})["far"]

    def _far_clearance_build(self, grids: np.ndarray) -> np.ndarray:
        """:meth:`_far_clearance` without the cache."""
        from scipy.ndimage import distance_transform_edt

        h = self.resolution
        k = int(self._moving_axes.sum())
        sampling = np.where(self._moving_axes, h, 1e9 * h)     # a fixed axis: its layers are out of reach
        out = np.empty(grids.shape, dtype=np.float64)
        for c, grid in enumerate(grids):
            if grid.all():
                out[c] = 0.0
                continue
            e = distance_transform_edt(~grid, sampling=sampling)
            out[c] = np.maximum(np.minimum(e / 2.0, e), e - np.sqrt(k) * h / 2.0)
        return out.reshape(len(grids), -1)

    def _rigid_layout(self) -> tuple[np.ndarray, float] | None:
        """For a rigid body in r3 / se2 / se3: its local points and the farthest one's distance (m); else None."""
        if self.space.kind not in ("rn", "se2", "se3") or (self.space.kind == "rn" and self.space.dim != 3):
            return None
        probe = np.asarray(self.space.enforce_bounds(np.atleast_2d(self.scene.start)), dtype=np.float64)
        try:
            placement = self.robot.rigid_placement(probe)
        except Exception:       # a robot whose placement cannot be asked here is treated as articulated
            return None
        if placement is None:
            return None
        local = np.asarray(placement[2], dtype=np.float64)
        return local, float(np.max(np.linalg.norm(local, axis=1))) if len(local) else 0.0

    def _body_reach(self) -> float:
        """The body's extent (m): the diagonal of its points' bounding box at the scene's start (at least a
        voxel); an articulated robot's joint turns by ``resolution / reach`` per sample."""
        try:
            pts = np.asarray(self.robot.body_points(np.atleast_2d(self.scene.start)))[0]
        except Exception:       # a start outside the space: any configuration will do for an extent
            # any configuration gives the body's extent (a geometric probe: no result depends on the draw)
            pts = np.asarray(self.robot.body_points(self.space.sample(np.random.default_rng(0), 1)))[0]
        return max(float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))), self.resolution)

    def _rigid_bound(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Exact bound (m) on any body point's displacement along the whole motion ``a -> b`` of a rigid body."""
        rot_a, pos_a, _ = self.robot.rigid_placement(a)
        rot_b, pos_b, _ = self.robot.rigid_placement(b)
        cos = (np.einsum("nij,nij->n", rot_a, rot_b) - 1.0) / 2.0
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        return np.linalg.norm(pos_b - pos_a, axis=-1) + self._rigid[1] * angle

    def _sample_bound(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        if self._rigid is not None:
            return self._rigid_bound(a, b)
        diff = np.abs(np.asarray(self.space.difference(b, a), dtype=np.float64))
        return np.max(diff, axis=-1) * max(self._reach, 1.0) * np.sqrt(diff.shape[-1])

    def _interval_bound(self, a: np.ndarray, b: np.ndarray, iv: _Intervals) -> np.ndarray:
        if self._rigid is not None:
            return self._rigid_bound(a, b) * (iv.t1 - iv.t0)
        chord = np.max(np.linalg.norm(iv.p1 - iv.p0, axis=-1), axis=-1)
        return chord * (np.pi / 2.0)


@dataclass
class _Intervals:
    """Pending sub-motions: owner motion, parameters and the per-point clearances and points at both ends."""

    owner: np.ndarray
    t0: np.ndarray
    t1: np.ndarray
    c0: np.ndarray
    c1: np.ndarray
    p0: np.ndarray
    p1: np.ndarray

    def take(self, mask: np.ndarray) -> _Intervals:
        return _Intervals(self.owner[mask], self.t0[mask], self.t1[mask], self.c0[mask], self.c1[mask],
                          self.p0[mask], self.p1[mask])


def _as_points(points) -> np.ndarray:
    """Body points ``(..., m, 3)`` as a C-contiguous float64 ``(n, m, 3)`` array for the kernels."""
    points = np.asarray(points, dtype=np.float64)
    return np.ascontiguousarray(points.reshape(-1, *points.shape[-2:]))


def _forbidden_grids(materials: np.ndarray, grid: VoxelGrid) -> tuple[np.ndarray, np.ndarray]:
    """Per robot material class, the flat voxels its points may not enter: ``classes`` ``(m,)`` and ``forbidden``
    ``(c, N)`` bool -- where eq. 3.1 is undefined (both deformabilities 0) or poisoned (a NaN sensitivity)."""
    unique, classes = np.unique(materials, axis=0, return_inverse=True)
    occupied = grid.occupied.reshape(-1)
    d_env = grid.deformability.reshape(-1)
    s_env = grid.sensitivity.reshape(-1)
    forbidden = np.zeros((len(unique), occupied.size), dtype=bool)
    for c, (d_robot, s_robot) in enumerate(unique):
        undefined = ~(d_robot + d_env > 0.0) | np.isnan(s_env) | bool(np.isnan(s_robot))
        forbidden[c] = occupied & undefined
    return classes.reshape(-1).astype(np.int64), forbidden


def _robot_base_collisions():
    from pliant.components.robot import RobotModel

    return RobotModel.collisions
