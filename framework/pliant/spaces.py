"""Configuration spaces: R^n, SE(2), SE(3) and their compounds.

Every operation is batched: a configuration is ``(d,)``, many are ``(n, d)``; functions broadcast a
single configuration against a batch.  SE(2) is ``(x, y, theta)``; SE(3) is
``(x, y, z, qx, qy, qz, qw)`` as in pinocchio.  Lengths in metres, angles in radians.

The distance of every space is a weighted Euclidean-style metric (weights are dimensionless
multipliers; see each class), the one RRT-family planners use for nearest neighbours and steering.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np

from pliant.errors import DimensionError
from pliant.geometry.rotations import (
    UNIT_QUATERNION_TOLERANCE,
    quat_angle,
    quat_conjugate,
    quat_from_axis_angle,
    quat_multiply,
    quat_slerp,
    quat_to_rotvec,
    random_quaternions,
    wrap_angle,
)


def _as_vector(value, size: int, name: str, field: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape == ():
        arr = np.full(size, float(arr))
    if arr.shape != (size,):
        raise DimensionError(f"{name} must have {size} entries", field=field, value=value)
    return arr


#: the most states :meth:`Space.discretize` makes of one edge; a smaller step than length / this is refused before
#: anything is allocated (a planner step of 1e-9 would otherwise ask for gigabytes)
MAX_STATES_PER_EDGE = 1_000_000

class Space(ABC):
    """A configuration space.

    Subclasses define :attr:`dim` (coordinates per configuration), sampling, distance,
    interpolation and validity.  Every method accepts a single configuration ``(d,)`` or a batch
    ``(n, d)`` and follows numpy broadcasting between its two arguments.
    """

    #: short name used in files (``"rn"``, ``"se2"``, ``"se3"``, ``"compound"``)
    kind: str = ""
    dim: int

    @abstractmethod
    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` configurations drawn uniformly over the space, ``(n, d)``."""

    @abstractmethod
    def distance(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Distance between ``a`` and ``b`` (broadcast), shape of the broadcast batch."""

    @abstractmethod
    def interpolate(self, a: np.ndarray, b: np.ndarray, t) -> np.ndarray:
        """The configuration a fraction ``t`` in [0, 1] of the way from ``a`` to ``b``.

        ``a`` and ``b`` are ``(d,)`` or ``(n, d)``; ``t`` is a scalar or an array that broadcasts
        against the batch.  ``t = 0`` gives ``a`` and ``t = 1`` gives ``b`` (up to angle wrapping).
        """

    @abstractmethod
    def is_valid(self, q: np.ndarray) -> np.ndarray:
        """Whether each configuration is finite, in bounds and well formed; bool ``()`` or ``(n,)``."""

    def enforce_bounds(self, q: np.ndarray) -> np.ndarray:
        """A copy of ``q`` moved into the bounds and normalised (wrapped angles, unit quaternions)."""
        return np.array(q, dtype=np.float64, copy=True)

    @property
    def tangent_dim(self) -> int:
        """Dimension of velocities, gradients and Jacobian columns (6 for SE(3), else :attr:`dim`)."""
        return self.dim

    def retract(self, q: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """``q`` moved by a tangent vector ``delta`` ``(..., tangent_dim)``.

        For R^n and SE(2) this is ``q + delta`` (angle wrapped).  For SE(3), ``delta`` is
        ``(vx, vy, vz, wx, wy, wz)``: a translation plus a rotation vector applied in the world frame.
        """
        return np.asarray(q, dtype=np.float64) + np.asarray(delta, dtype=np.float64)

    def difference(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """The tangent vector ``delta`` with ``retract(b, delta) == a`` (the shortest one), ``(..., t)``."""
        return np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)

    # --- shared behaviour -------------------------------------------------------------------

    def check(self, q, *, field: str = "configuration", source: str | None = None) -> np.ndarray:
        """Return ``q`` as float64 ``(d,)`` or ``(n, d)``, or raise :class:`DimensionError`.

        The error names ``source:field`` and the value: wrong length, non-finite entries,
        non-unit quaternions and out-of-bounds coordinates are all reported.
        """
        try:
            arr = np.asarray(q, dtype=np.float64)
        except (TypeError, ValueError):
            raise DimensionError("must be a list of numbers", source=source, field=field, value=q) from None
        if arr.ndim not in (1, 2) or arr.shape[-1] != self.dim:
            raise DimensionError(f"must have {self.dim} coordinates for a {self.kind} space",
                                 source=source, field=field, value=q)
        if not np.all(np.isfinite(arr)):
            raise DimensionError("must be finite (no NaN or infinity)", source=source, field=field, value=q)
        problem = self.explain_invalid(arr)
        if problem:
            raise DimensionError(problem, source=source, field=field, value=q)
        return arr

    def explain_invalid(self, q: np.ndarray) -> str | None:
        """Why a finite, well-shaped ``q`` is invalid, or ``None`` when every entry is valid."""
        return None if np.all(self.is_valid(q)) else "is outside the space's bounds"

    def steer(self, a: np.ndarray, b: np.ndarray, max_step: float) -> np.ndarray:
        """Move from ``a`` toward ``b`` by at most ``max_step`` (in this space's distance)."""
        d = np.asarray(self.distance(a, b))
        frac = np.where(d > max_step, max_step / np.where(d > 0, d, 1.0), 1.0)
        return self.interpolate(a, b, frac)

    def discretize(self, a: np.ndarray, b: np.ndarray, step: float) -> np.ndarray:
        """Configurations from ``a`` to ``b`` inclusive, no two consecutive further than ``step`` (to a relative
        1e-9: an edge within rounding of ``k`` steps is cut into ``k`` pieces).

        Returns ``(k, d)`` with ``k >= 2``.
        """
        if not step > 0:
            raise DimensionError("step must be positive", field="step", value=step)
        if float(self.distance(a, b)) > MAX_STATES_PER_EDGE * step:
            raise DimensionError(f"splits one edge of length {float(self.distance(a, b)):.6g} into more than "
                                 f"{MAX_STATES_PER_EDGE:,} states (pliant.spaces.MAX_STATES_PER_EDGE); use a larger "
                                 "step", field="step", value=step)
        # a relative 1e-9 of slack: an edge a hair longer than k steps (rounding) is split into k pieces, not k + 1,
        # so that every caller -- a planner's edge checks and costs, PlanningProblem.path_cost -- splits it alike
        n = max(1, int(np.ceil(float(self.distance(a, b)) / step - 1e-9)))
        return self.interpolate(np.asarray(a)[None], np.asarray(b)[None], np.linspace(0.0, 1.0, n + 1)[:, None])

    def mean(self, q: np.ndarray, weights: np.ndarray | None = None, iterations: int = 10) -> np.ndarray:
        """The (weighted) mean ``(d,)`` of configurations ``(n, d)``: the Karcher mean through
        :meth:`difference` / :meth:`retract` (angles wrap, quaternions stay unit), plain for R^n."""
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        if len(q) == 0:
            raise DimensionError("the mean of no configuration is undefined", field="q", value=[])
        ref = q[0]
        for _ in range(max(1, iterations)):
            delta = np.average(self.difference(q, ref), axis=0, weights=weights)
            ref = self.retract(ref, delta)
            if float(np.max(np.abs(delta))) < 1e-12:
                break
        return ref

    def variance(self, q: np.ndarray) -> np.ndarray:
        """Per tangent coordinate, the mean squared difference ``(t,)`` of configurations ``(n, d)`` from their
        :meth:`mean` (m^2, rad^2); zeros for a single configuration."""
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        d = self.difference(q, self.mean(q))
        return np.mean(d * d, axis=0)

    def path_length(self, path: np.ndarray) -> float:
        """Sum of distances between consecutive configurations of ``path`` ``(k, d)``."""
        path = np.asarray(path, dtype=np.float64)
        if len(path) < 2:
            return 0.0
        return float(np.sum(self.distance(path[:-1], path[1:])))

    def to_dict(self) -> dict:
        """A description that :func:`space_from_dict` turns back into an equal space."""
        raise NotImplementedError


class RealVectorSpace(Space):
    """R^n with box bounds and per-axis weights: ``d(a, b) = || w * (a - b) ||_2``.

    Parameters
    ----------
    lower, upper:
        Bounds per axis (units of the axis: metres or radians); ``lower < upper``.
    weights:
        Positive per-axis multipliers of the difference (default 1), e.g. ``1 / [0.27, ...]`` for
        Baxter's joints in thesis ch. 5.
    """

    kind = "rn"

    def __init__(self, lower: Sequence[float], upper: Sequence[float], weights=None) -> None:
        lower = np.asarray(lower, dtype=np.float64)
        if lower.ndim != 1 or lower.size == 0:
            raise DimensionError("lower bounds must be a non-empty list", field="lower", value=lower.tolist())
        self.dim = lower.size
        self.lower = lower
        self.upper = _as_vector(upper, self.dim, "upper bounds", "upper")
        self.weights = _as_vector(1.0 if weights is None else weights, self.dim, "weights", "weights")
        if not (np.all(np.isfinite(self.lower)) and np.all(np.isfinite(self.upper))):
            raise DimensionError("bounds must be finite", field="lower/upper",
                                 value=(self.lower.tolist(), self.upper.tolist()))
        if np.any(self.lower >= self.upper):
            raise DimensionError("every lower bound must be below its upper bound", field="lower/upper",
                                 value=(self.lower.tolist(), self.upper.tolist()))
        if np.any(~np.isfinite(self.weights)) or np.any(self.weights <= 0):
            raise DimensionError("weights must be positive and finite", field="weights", value=self.weights.tolist())

    def sample(self, rng, n):
        return self.lower + (self.upper - self.lower) * rng.random((n, self.dim))

    def distance(self, a, b):
        diff = (np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)) * self.weights
        return np.sqrt(np.sum(diff * diff, axis=-1))

    def interpolate(self, a, b, t):
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        return a + np.asarray(t, dtype=np.float64) * (b - a)

    def is_valid(self, q):
        q = np.asarray(q, dtype=np.float64)
        return np.all(np.isfinite(q) & (q >= self.lower) & (q <= self.upper), axis=-1)

    def enforce_bounds(self, q):
        return np.clip(np.asarray(q, dtype=np.float64), self.lower, self.upper)

    def to_dict(self):
        return {"kind": self.kind, "lower": self.lower.tolist(), "upper": self.upper.tolist(),
                "weights": self.weights.tolist()}


class _RigidMotionSpace(Space):
    """Shared parts of SE(2) and SE(3): bounded positions, translation and rotation weights."""

    _position_dims = 3

    def __init__(self, lower, upper, translation_weight: float = 1.0, rotation_weight: float = 1.0) -> None:
        n = self._position_dims
        self.position = RealVectorSpace(_as_vector(lower, n, "lower bounds", "lower"),
                                        _as_vector(upper, n, "upper bounds", "upper"))
        self.translation_weight = _positive(translation_weight, "translation_weight")
        self.rotation_weight = _positive(rotation_weight, "rotation_weight")

    @property
    def lower(self):
        return self.position.lower

    @property
    def upper(self):
        return self.position.upper

    def to_dict(self):
        return {"kind": self.kind, "lower": self.lower.tolist(), "upper": self.upper.tolist(),
                "translation_weight": self.translation_weight, "rotation_weight": self.rotation_weight}


class SE2Space(_RigidMotionSpace):
    """The plane of rigid motions ``(x, y, theta)``.

    ``d = sqrt(wt^2 (dx^2 + dy^2) + wr^2 dtheta^2)`` with ``dtheta`` the wrapped angle difference.
    ``lower``/``upper`` bound ``(x, y)`` in metres; ``theta`` is free (wrapped to [-pi, pi)).
    """

    kind = "se2"
    dim = 3
    _position_dims = 2

    def sample(self, rng, n):
        xy = self.position.sample(rng, n)
        return np.column_stack([xy, rng.uniform(-np.pi, np.pi, n)])

    def distance(self, a, b):
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        if a.ndim in (1, 2) and b.ndim in (1, 2) and a.shape[-1] == 3 == b.shape[-1]:
            a2, b2 = a.reshape(-1, 3), b.reshape(-1, 3)
            n = max(len(a2), len(b2))
            if len(a2) in (1, n) and len(b2) in (1, n):        # one against many, or pairs: compiled, same bits
                from pliant.geometry import space_kernels  # numba: loaded on the first distance, not at import

                out = np.empty(n)
                space_kernels.se2_distances(np.ascontiguousarray(a2), np.ascontiguousarray(b2),
                                            self.translation_weight ** 2, float(self.rotation_weight), out)
                return out[0] if a.ndim == 1 and b.ndim == 1 else out
        dxy = a[..., :2] - b[..., :2]
        dth = wrap_angle(a[..., 2] - b[..., 2])
        return np.sqrt(self.translation_weight ** 2 * np.sum(dxy * dxy, axis=-1)
                       + (self.rotation_weight * dth) ** 2)

    def interpolate(self, a, b, t):
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        t = np.asarray(t, dtype=np.float64)
        xy = a[..., :2] + t * (b[..., :2] - a[..., :2])
        th = wrap_angle(a[..., 2:] + t * wrap_angle(b[..., 2:] - a[..., 2:]))
        shape = np.broadcast_shapes(xy.shape[:-1], th.shape[:-1])      # leading (batch) axes only
        return np.concatenate([np.broadcast_to(xy, shape + (2,)), np.broadcast_to(th, shape + (1,))], axis=-1)

    def is_valid(self, q):
        q = np.asarray(q, dtype=np.float64)
        return self.position.is_valid(q[..., :2]) & np.isfinite(q[..., 2])

    def enforce_bounds(self, q):
        q = np.array(q, dtype=np.float64, copy=True)
        q[..., :2] = self.position.enforce_bounds(q[..., :2])
        q[..., 2] = wrap_angle(q[..., 2])
        return q

    def retract(self, q, delta):
        out = np.asarray(q, dtype=np.float64) + np.asarray(delta, dtype=np.float64)
        out[..., 2] = wrap_angle(out[..., 2])
        return out

    def difference(self, a, b):
        out = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
        out[..., 2] = wrap_angle(out[..., 2])
        return out


class SE3Space(_RigidMotionSpace):
    """Rigid motions in space ``(x, y, z, qx, qy, qz, qw)``.

    ``d = sqrt(wt^2 |dp|^2 + wr^2 angle^2)`` where ``angle`` (rad) is the rotation between the two
    orientations.  ``lower``/``upper`` bound the position in metres.
    """

    kind = "se3"
    dim = 7

    def sample(self, rng, n):
        return np.column_stack([self.position.sample(rng, n), random_quaternions(rng, n)])

    def distance(self, a, b):
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        dp = a[..., :3] - b[..., :3]
        ang = quat_angle(a[..., 3:], b[..., 3:])
        return np.sqrt(self.translation_weight ** 2 * np.sum(dp * dp, axis=-1) + (self.rotation_weight * ang) ** 2)

    def interpolate(self, a, b, t):
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        t = np.asarray(t, dtype=np.float64)
        p = a[..., :3] + t * (b[..., :3] - a[..., :3])
        tq = t[..., 0] if t.ndim else t
        q = quat_slerp(a[..., 3:], b[..., 3:], tq)
        p, q = np.broadcast_arrays(p, q[..., :3])[0], q
        shape = np.broadcast_shapes(p.shape[:-1], q.shape[:-1])
        return np.concatenate([np.broadcast_to(p, shape + (3,)), np.broadcast_to(q, shape + (4,))], axis=-1)

    def is_valid(self, q):
        q = np.asarray(q, dtype=np.float64)
        norm = np.linalg.norm(q[..., 3:], axis=-1)
        return self.position.is_valid(q[..., :3]) & (np.abs(norm - 1.0) <= UNIT_QUATERNION_TOLERANCE)

    def explain_invalid(self, q):
        norm = np.linalg.norm(q[..., 3:], axis=-1)
        if np.any(np.abs(norm - 1.0) > UNIT_QUATERNION_TOLERANCE):
            return "quaternion (qx, qy, qz, qw) must have unit norm"
        if not np.all(self.position.is_valid(q[..., :3])):
            return "position is outside the space's bounds"
        return None

    def enforce_bounds(self, q):
        q = np.array(q, dtype=np.float64, copy=True)
        q[..., :3] = self.position.enforce_bounds(q[..., :3])
        q[..., 3:] /= np.linalg.norm(q[..., 3:], axis=-1, keepdims=True)
        return q

    @property
    def tangent_dim(self) -> int:
        return 6

    def retract(self, q, delta):
        q = np.asarray(q, dtype=np.float64)
        delta = np.asarray(delta, dtype=np.float64)
        shape = np.broadcast_shapes(q.shape[:-1], delta.shape[:-1])
        out = np.empty(shape + (7,))
        out[..., :3] = q[..., :3] + delta[..., :3]
        w = delta[..., 3:]
        angle = np.linalg.norm(w, axis=-1)
        axis = w / np.where(angle > 0, angle, 1.0)[..., None]
        out[..., 3:] = quat_multiply(quat_from_axis_angle(axis, angle), q[..., 3:])
        out[..., 3:] /= np.linalg.norm(out[..., 3:], axis=-1, keepdims=True)
        return out

    def difference(self, a, b):
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        rot = quat_to_rotvec(quat_multiply(a[..., 3:], quat_conjugate(b[..., 3:])))
        dp = a[..., :3] - b[..., :3]
        dp, rot = np.broadcast_arrays(dp, rot)
        return np.concatenate([dp, rot], axis=-1)


class CompoundSpace(Space):
    """A product of spaces; ``d = sqrt(sum_i w_i d_i^2)`` over the components.

    Configurations are the concatenation of the components' coordinates, in order.
    """

    kind = "compound"

    def __init__(self, components: Sequence[Space], weights=None) -> None:
        if not components:
            raise DimensionError("a compound space needs at least one component", field="components", value=[])
        self.components = list(components)
        self.weights = _as_vector(1.0 if weights is None else weights, len(self.components), "weights", "weights")
        if np.any(self.weights <= 0):
            raise DimensionError("weights must be positive", field="weights", value=self.weights.tolist())
        self.offsets = np.cumsum([0] + [c.dim for c in self.components])
        self.dim = int(self.offsets[-1])

    def _parts(self, q):
        q = np.asarray(q, dtype=np.float64)
        return [q[..., self.offsets[i]:self.offsets[i + 1]] for i in range(len(self.components))]

    def sample(self, rng, n):
        return np.concatenate([c.sample(rng, n) for c in self.components], axis=1)

    def distance(self, a, b):
        total = 0.0
        for w, c, pa, pb in zip(self.weights, self.components, self._parts(a), self._parts(b)):
            total = total + w * c.distance(pa, pb) ** 2
        return np.sqrt(total)

    def interpolate(self, a, b, t):
        parts = [c.interpolate(pa, pb, t) for c, pa, pb in zip(self.components, self._parts(a), self._parts(b))]
        shape = np.broadcast_shapes(*(p.shape[:-1] for p in parts))
        return np.concatenate([np.broadcast_to(p, shape + p.shape[-1:]) for p in parts], axis=-1)

    def is_valid(self, q):
        valid = True
        for c, p in zip(self.components, self._parts(q)):
            valid = valid & c.is_valid(p)
        return valid

    def explain_invalid(self, q):
        for i, (c, p) in enumerate(zip(self.components, self._parts(q))):
            why = c.explain_invalid(p)
            if why:
                return f"component {i} ({c.kind}): {why}"
        return None

    def enforce_bounds(self, q):
        return np.concatenate([c.enforce_bounds(p) for c, p in zip(self.components, self._parts(q))], axis=-1)

    @property
    def tangent_dim(self) -> int:
        return sum(c.tangent_dim for c in self.components)

    def difference(self, a, b):
        parts = [c.difference(pa, pb) for c, pa, pb in zip(self.components, self._parts(a), self._parts(b))]
        shape = np.broadcast_shapes(*(p.shape[:-1] for p in parts))
        return np.concatenate([np.broadcast_to(p, shape + p.shape[-1:]) for p in parts], axis=-1)

    def retract(self, q, delta):
        delta = np.asarray(delta, dtype=np.float64)
        toff = np.cumsum([0] + [c.tangent_dim for c in self.components])
        parts = [c.retract(p, delta[..., toff[i]:toff[i + 1]])
                 for i, (c, p) in enumerate(zip(self.components, self._parts(q)))]
        shape = np.broadcast_shapes(*(p.shape[:-1] for p in parts))
        return np.concatenate([np.broadcast_to(p, shape + p.shape[-1:]) for p in parts], axis=-1)

    def to_dict(self):
        return {"kind": self.kind, "components": [c.to_dict() for c in self.components],
                "weights": self.weights.tolist()}


def _positive(value, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise DimensionError(f"{name} must be a number", field=name, value=value) from None
    if not (np.isfinite(v) and v > 0):
        raise DimensionError(f"{name} must be positive and finite", field=name, value=value)
    return v


def space_from_dict(spec: dict) -> Space:
    """Build a space from the dictionary :meth:`Space.to_dict` produces (also the scene format)."""
    kind = spec.get("kind")
    args = {k: v for k, v in spec.items() if k != "kind"}
    if kind == "rn":
        return RealVectorSpace(**args)
    if kind == "se2":
        return SE2Space(**args)
    if kind == "se3":
        return SE3Space(**args)
    if kind == "compound":
        return CompoundSpace([space_from_dict(c) for c in args["components"]], args.get("weights"))
    raise DimensionError("unknown space kind (expected rn, se2, se3 or compound)", field="kind", value=kind)
