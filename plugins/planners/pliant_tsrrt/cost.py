"""The task cost of an arrangement of objects (TS-RRT, poster ICHR 2010: "orthogonality, circumscribed area,
distance from edge of workspace", and "table setting").

For poses ``s`` ``(n, k, 3)`` (m, rad) of ``k`` objects on the table ``[x0, x1] x [y0, y1]``:

* **orthogonality** ``sum_o sin^2(2 theta_o)`` over the box-shaped objects: 0 when every box is aligned with the
  table's axes, 1 per box turned 45 degrees (circles have no orientation and add nothing);
* **circumscribed area** ``A / (W H)``: the area of the smallest table-aligned rectangle that encloses every
  footprint, as a fraction of the table's area ``W H`` (compactness);
* **edge** ``sum_o (1 - d_o / d_ref)``: ``d_o`` is the distance (m) from object o's footprint to the nearest table
  edge (0 when it touches it), ``d_ref = min(W, H) / 2`` the largest such distance a point can have, so each
  object adds 1 at the edge and 0 at the table's centre line;
* **setting** ``sum_r |p_a - p_b - offset_r|^2 / l^2`` over the relations ``r = (a, b, offset)``: object a's
  centre should sit at ``offset`` (m) from object b's centre (b may be ``table``: the table's lower-left corner),
  with the length scale ``l`` (m); the table-setting task.

The total is ``w_orth * orthogonality + w_area * area + w_edge * edge + w_setting * setting`` (dimensionless).
Everything is batched over ``n`` arrangements; :meth:`TaskCost.gradient` is a central finite difference over
the batch (DIRECTGD needs the direction of steepest descent, line 5).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pliant_tsrrt import kernels
from pliant_tsrrt.geometry import BOX, Footprints, extents

TERMS = ("orthogonality", "area", "edge", "setting")


@dataclass
class TaskCost:
    """The weighted task cost of arrangements of objects with footprints ``fp`` on ``table`` ``(x0, y0, x1, y1)``.

    weights: ``(w_orth, w_area, w_edge, w_setting)``.  relations: ``(a, b, dx, dy)`` rows with object indices ``a``
    and ``b`` (``b = -1``: the table's corner ``(x0, y0)``) and the offset (m).  setting_scale: ``l`` (m).
    """

    fp: Footprints
    table: tuple[float, float, float, float]
    weights: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 0.0)
    relations: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    setting_scale: float = 0.1

    def __post_init__(self) -> None:
        self.relations = np.asarray(self.relations, dtype=np.float64).reshape(-1, 4)
        x0, y0, x1, y1 = self.table
        self.area_ref = (x1 - x0) * (y1 - y0)
        self.d_ref = 0.5 * min(x1 - x0, y1 - y0)
        self.boxes = self.fp.kind == BOX
        rel = self.relations
        self._kernel_args = (self.fp.kind, self.fp.half, np.asarray(self.table, dtype=np.float64),
                             np.asarray(self.weights, dtype=np.float64), rel[:, 0].astype(np.int64),
                             rel[:, 1].astype(np.int64), rel[:, 2].copy(), rel[:, 3].copy(), float(self.setting_scale))

    def terms(self, states: np.ndarray) -> np.ndarray:
        """``(n, 4)``: the unweighted terms (:data:`TERMS`) of arrangements ``(n, k, 3)``."""
        states = np.asarray(states, dtype=np.float64)
        if states.ndim == 2:
            states = states[None]
        x0, y0, x1, y1 = self.table
        orth = np.sum(np.where(self.boxes, np.sin(2 * states[..., 2]) ** 2, 0.0), axis=-1)
        lo, hi = extents(states, self.fp)
        span = hi.max(axis=1) - lo.min(axis=1)                                 # (n, 2)
        area = span[:, 0] * span[:, 1] / self.area_ref
        d = np.minimum(np.minimum(lo[..., 0] - x0, x1 - hi[..., 0]), np.minimum(lo[..., 1] - y0, y1 - hi[..., 1]))
        edge = np.sum(1.0 - np.clip(d, 0.0, None) / self.d_ref, axis=-1)
        setting = np.zeros(len(states))
        if len(self.relations):
            a = self.relations[:, 0].astype(int)
            b = self.relations[:, 1].astype(int)
            pa = states[:, a, :2]
            pb = np.where((b >= 0)[None, :, None], states[:, np.maximum(b, 0), :2], np.array([x0, y0]))
            err = pa - pb - self.relations[None, :, 2:]
            setting = np.sum(err ** 2, axis=(1, 2)) / self.setting_scale ** 2
        return np.stack([orth, area, edge, setting], axis=-1)

    def cost(self, states: np.ndarray) -> np.ndarray:
        """``(n,)``: the weighted total of arrangements ``(n, k, 3)``; compiled (:func:`pliant_tsrrt.kernels.task_cost`,
        the same formulas as :meth:`terms`)."""
        states = np.ascontiguousarray(states, dtype=np.float64)
        if states.ndim == 2:
            states = states[None]
        return kernels.task_cost(states, *self._kernel_args)

    def cost_numpy(self, states: np.ndarray) -> np.ndarray:
        """:meth:`cost` from :meth:`terms` (batched numpy)."""
        return self.terms(states) @ np.asarray(self.weights, dtype=np.float64)

    def gradient(self, states: np.ndarray, h: float = 1e-5) -> np.ndarray:
        """``(n, k, 3)``: central differences of :meth:`cost` (step ``h`` m or rad), one batched evaluation."""
        states = np.asarray(states, dtype=np.float64)
        n, k, _ = states.shape
        eye = np.eye(3 * k).reshape(3 * k, k, 3) * h
        probes = np.concatenate([states[:, None] + eye[None], states[:, None] - eye[None]], axis=1)
        c = self.cost(probes.reshape(-1, k, 3)).reshape(n, 2, 3 * k)
        return ((c[:, 0] - c[:, 1]) / (2 * h)).reshape(n, k, 3)
