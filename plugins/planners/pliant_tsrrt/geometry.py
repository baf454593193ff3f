"""Object footprints on the table and batched collision checks (TS-RRT, poster ICHR 2010, line 12 IN_COLLISION).

An arrangement of ``k`` objects is an array ``(k, 3)`` of poses ``(x, y, theta)`` (m, rad); many arrangements are
``(n, k, 3)``.  Each object's footprint is an oriented box (``half`` extents ``(2,)`` m, in its own frame) or a
circle (radius ``half[0]`` m).  Every check here takes a batch of arrangements and answers one boolean per
arrangement, vectorised over the batch and the object pairs (no Python loop over arrangements):

* object-object and object-obstacle overlap: the separating-axis test for two boxes (the four face normals), the
  closest point of a box for a box and a circle, the centre distance for two circles;
* the table: every footprint (its extreme points) inside the table rectangle.

A ``margin`` (m) grows every footprint by that much on every side: two footprints closer than ``2 * margin`` count
as colliding, and a footprint must stay ``margin`` inside the table (the planner keeps that clearance between model
predictions, so that noisy pushes do not make objects touch).  A negative margin shrinks the footprints (the
execution's collision verdict tolerates the slight overlap of resting contacts in the simulator).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pliant_tsrrt import kernels

BOX, CIRCLE = 0, 1


@dataclass(frozen=True)
class Footprints:
    """The footprints of ``k`` shapes: ``kind`` ``(k,)`` (:data:`BOX` or :data:`CIRCLE`), ``half`` ``(k, 2)`` half
    extents in the shape's frame (m; a circle's radius in both columns)."""

    kind: np.ndarray
    half: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", np.asarray(self.kind, dtype=np.int64).reshape(-1))
        object.__setattr__(self, "half", np.asarray(self.half, dtype=np.float64).reshape(-1, 2))

    def __len__(self) -> int:
        return len(self.kind)

    @property
    def radius(self) -> np.ndarray:
        """``(k,)`` radius of the circle around each footprint's centre (m)."""
        return np.where(self.kind == CIRCLE, self.half[:, 0], np.hypot(self.half[:, 0], self.half[:, 1]))

    def subset(self, index) -> Footprints:
        """The footprints at ``index`` (an index, slice or index array), in that order."""
        return Footprints(self.kind[index], self.half[index])


def wrap(angle, period=2 * np.pi):
    """Angles wrapped to ``[-period / 2, period / 2)`` (default ``[-pi, pi)``; a box's yaw error modulo its
    symmetry with ``period`` pi, or pi / 2 for a square)."""
    return (np.asarray(angle) + period / 2) % period - period / 2


def box_corners(poses: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Corners ``(..., 4, 2)`` of boxes at ``poses`` ``(..., 3)`` with half extents ``half`` ``(..., 2)`` (m)."""
    signs = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    local = signs * half[..., None, :]                                   # (..., 4, 2)
    c, s = np.cos(poses[..., 2])[..., None], np.sin(poses[..., 2])[..., None]
    x = c * local[..., 0] - s * local[..., 1] + poses[..., None, 0]
    y = s * local[..., 0] + c * local[..., 1] + poses[..., None, 1]
    return np.stack([x, y], axis=-1)


def extents(poses: np.ndarray, fp: Footprints) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounds of every footprint: ``lo``, ``hi`` ``(..., k, 2)`` (m) for poses ``(..., k, 3)``."""
    c, s = np.abs(np.cos(poses[..., 2])), np.abs(np.sin(poses[..., 2]))
    ex = np.where(fp.kind == CIRCLE, fp.half[:, 0], c * fp.half[:, 0] + s * fp.half[:, 1])
    ey = np.where(fp.kind == CIRCLE, fp.half[:, 0], s * fp.half[:, 0] + c * fp.half[:, 1])
    e = np.stack([ex, ey], axis=-1)
    return poses[..., :2] - e, poses[..., :2] + e


def _box_box(pa, ha, pb, hb, margin):
    """Bool ``(...)``: boxes a and b (poses ``(..., 3)``, half extents ``(..., 2)``) overlap (separating axes: the
    four face normals; a box's extent along a unit axis ``n`` is ``hx |n . u| + hy |n . v|``)."""
    ca, sa = np.cos(pa[..., 2]), np.sin(pa[..., 2])
    cb, sb = np.cos(pb[..., 2]), np.sin(pb[..., 2])
    dx, dy = pb[..., 0] - pa[..., 0], pb[..., 1] - pa[..., 1]
    cross_c = np.abs(ca * cb + sa * sb)               # |cos(theta_b - theta_a)|
    cross_s = np.abs(sa * cb - ca * sb)               # |sin(theta_b - theta_a)|
    hax, hay, hbx, hby = ha[..., 0], ha[..., 1], hb[..., 0], hb[..., 1]
    m2 = 2 * margin
    # a's axes u_a = (ca, sa), v_a = (-sa, ca); b's extent along them
    sep = np.abs(dx * ca + dy * sa) - hax - (hbx * cross_c + hby * cross_s) >= m2
    sep |= np.abs(-dx * sa + dy * ca) - hay - (hbx * cross_s + hby * cross_c) >= m2
    sep |= np.abs(dx * cb + dy * sb) - hbx - (hax * cross_c + hay * cross_s) >= m2
    sep |= np.abs(-dx * sb + dy * cb) - hby - (hax * cross_s + hay * cross_c) >= m2
    return ~sep


def _box_circle(pb, hb, pc, r, margin):
    """Bool ``(...)``: box (pose, half extents) and circle (pose, radius ``(...)``) overlap."""
    d = pc[..., :2] - pb[..., :2]
    c, s = np.cos(pb[..., 2]), np.sin(pb[..., 2])
    local = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], -1)
    nearest = np.clip(local, -hb, hb)
    return np.linalg.norm(local - nearest, axis=-1) < r + 2 * margin


def _circle_circle(pa, ra, pb, rb, margin):
    return np.linalg.norm(pa[..., :2] - pb[..., :2], axis=-1) < ra + rb + 2 * margin


def pair_overlap(pa: np.ndarray, fa: Footprints, pb: np.ndarray, fb: Footprints, margin: float = 0.0) -> np.ndarray:
    """Bool ``(n, p)``: whether footprint pair ``j`` overlaps, for poses ``pa``, ``pb`` ``(n, p, 3)`` of the pairs'
    first and second members (footprints ``fa``, ``fb`` of ``p`` entries each)."""
    out = np.zeros(pa.shape[:2], dtype=bool)
    bb = (fa.kind == BOX) & (fb.kind == BOX)
    cc = (fa.kind == CIRCLE) & (fb.kind == CIRCLE)
    bc = (fa.kind == BOX) & (fb.kind == CIRCLE)
    cb = (fa.kind == CIRCLE) & (fb.kind == BOX)
    if bb.any():
        out[:, bb] = _box_box(pa[:, bb], fa.half[bb], pb[:, bb], fb.half[bb], margin)
    if cc.any():
        out[:, cc] = _circle_circle(pa[:, cc], fa.half[cc, 0], pb[:, cc], fb.half[cc, 0], margin)
    if bc.any():
        out[:, bc] = _box_circle(pa[:, bc], fa.half[bc], pb[:, bc], fb.half[bc, 0], margin)
    if cb.any():
        out[:, cb] = _box_circle(pb[:, cb], fb.half[cb], pa[:, cb], fa.half[cb, 0], margin)
    return out


@dataclass
class CollisionChecker:
    """IN_COLLISION for arrangements of ``k`` movable objects among fixed obstacles on a table.

    objects: the movable footprints (``k``); obstacles: fixed footprints with their ``obstacle_poses`` ``(m, 3)``;
    table: ``(x0, y0, x1, y1)`` (m) that every movable footprint must stay inside; margin: clearance (m) added to
    every footprint.
    """

    objects: Footprints
    obstacles: Footprints
    obstacle_poses: np.ndarray
    table: tuple[float, float, float, float]
    margin: float = 0.0

    def __post_init__(self) -> None:
        k = len(self.objects)
        self.obstacle_poses = np.ascontiguousarray(self.obstacle_poses, dtype=np.float64).reshape(-1, 3)
        self._table = np.asarray(self.table, dtype=np.float64)
        iu = np.triu_indices(k, 1)
        self._pairs = (iu[0], iu[1])
        self._pair_fp = (self.objects.subset(iu[0]), self.objects.subset(iu[1]))
        m = len(self.obstacles)
        oi, mi = np.repeat(np.arange(k), m), np.tile(np.arange(m), k)
        self._obs_pairs = (oi, mi)
        self._obs_fp = (self.objects.subset(oi), self.obstacles.subset(mi))

    def off_table(self, states: np.ndarray) -> np.ndarray:
        """Bool ``(n, k)``: which objects reach beyond the table (by more than minus the margin)."""
        lo, hi = extents(states, self.objects)
        x0, y0, x1, y1 = self.table
        g = self.margin
        return ((lo[..., 0] < x0 + g) | (lo[..., 1] < y0 + g) | (hi[..., 0] > x1 - g) | (hi[..., 1] > y1 - g))

    def object_pairs(self, states: np.ndarray) -> np.ndarray:
        """Bool ``(n, k (k - 1) / 2)``: which pairs of movable objects overlap."""
        i, j = self._pairs
        if len(i) == 0:
            return np.zeros((len(states), 0), dtype=bool)
        return pair_overlap(states[:, i], self._pair_fp[0], states[:, j], self._pair_fp[1], self.margin)

    def obstacle_pairs(self, states: np.ndarray) -> np.ndarray:
        """Bool ``(n, k m)``: which (object, obstacle) pairs overlap."""
        oi, mi = self._obs_pairs
        if len(oi) == 0:
            return np.zeros((len(states), 0), dtype=bool)
        obs = np.broadcast_to(self.obstacle_poses[mi], (len(states), len(mi), 3))
        return pair_overlap(states[:, oi], self._obs_fp[0], obs, self._obs_fp[1], self.margin)

    def in_collision(self, states: np.ndarray) -> np.ndarray:
        """Bool ``(n,)`` for arrangements ``(n, k, 3)`` (or one ``(k, 3)``: then ``(1,)``); compiled
        (:func:`pliant_tsrrt.kernels.in_collision`, the same tests as :meth:`in_collision_numpy`)."""
        states = np.ascontiguousarray(states, dtype=np.float64)
        if states.ndim == 2:
            states = states[None]
        return kernels.in_collision(states, self.objects.kind, self.objects.half, self.obstacles.kind,
                                    self.obstacles.half, self.obstacle_poses, self._table, float(self.margin))

    def in_collision_numpy(self, states: np.ndarray) -> np.ndarray:
        """:meth:`in_collision` in batched numpy (pair by pair over the batch)."""
        states = np.asarray(states, dtype=np.float64)
        if states.ndim == 2:
            states = states[None]
        bad = self.off_table(states).any(axis=1)
        bad |= self.object_pairs(states).any(axis=1)
        bad |= self.obstacle_pairs(states).any(axis=1)
        return bad

    def boxes_hit(self, states: np.ndarray, boxes: np.ndarray, half: np.ndarray, skip: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: whether a box per arrangement (poses ``boxes`` ``(n, 3)``, half extents ``half`` ``(n, 2)``;
        the pusher's swept area) overlaps any movable object other than ``skip[n]`` or any obstacle."""
        n, k = states.shape[:2]
        box_fp = Footprints(np.zeros(n * k, dtype=np.int64), np.repeat(half, k, axis=0))
        pa = np.repeat(boxes, k, axis=0)[None]                            # (1, n k, 3)
        pb = states.reshape(1, n * k, 3)
        fb = Footprints(np.tile(self.objects.kind, n), np.tile(self.objects.half, (n, 1)))
        hit = pair_overlap(pa, box_fp, pb, fb, 0.0)[0].reshape(n, k)
        hit[np.arange(n), skip] = False
        out = hit.any(axis=1)
        m = len(self.obstacles)
        if m:
            box_fp = Footprints(np.zeros(n * m, dtype=np.int64), np.repeat(half, m, axis=0))
            pa = np.repeat(boxes, m, axis=0)[None]
            pb = np.tile(self.obstacle_poses, (n, 1))[None]
            fb = Footprints(np.tile(self.obstacles.kind, n), np.tile(self.obstacles.half, (n, 1)))
            out |= pair_overlap(pa, box_fp, pb, fb, 0.0)[0].reshape(n, m).any(axis=1)
        return out
