"""Displacement models ``P(delta s | a, o)`` per object class and primitive, and LEARN_MODEL (poster ICHR 2010).

A model is a Gaussian over the displacement ``delta s = (dx, dy, dtheta)`` that one primitive gives an object of
one class, expressed in the object's frame before the push (m, m, rad), so it applies at any pose:
``MODEL(s, a) = (x, y) + R(theta) (dx, dy), theta + dtheta`` with the model's mean (TASK_SPACE_RRT lines 10-11).

LEARN_MODEL (the poster's pseudo code):

    1  s = s_init
    2  for i <- 1 to |A|
    3  do while sigma^2 > sigma^2_ref
    4    do (delta s, s) = APPLY_ACTION(a_i, o)
    5    P(delta s | a_i, o) = UPDATE_DISTR(P(delta s | a_i, o), a_i, delta s)
    6    sigma^2 <- VARIANCE(P(delta s | a_i, o))

UPDATE_DISTR is Welford's running mean and covariance; VARIANCE is the variance of the model's mean,
``s_j^2 / n`` per dimension (the spread of the displacement itself does not shrink with more pushes, the
uncertainty of the model does), and the loop ends when it is below ``sigma_ref^2`` in every dimension (with
``sigma_ref`` in m for dx, dy and in rad for dtheta), after at least ``min_pushes`` and at most ``max_pushes``
pushes.  The object's class is its scene name without a trailing ``-<number>`` (``plate-2`` is a ``plate``).

The models file (JSON, ``format = "pliant-tsrrt-push-models"``, ``version = 1``) holds, per class, the footprint
(``shape``: ``box`` or ``circle``, ``half`` extents in m), and per primitive ``n``, ``mean`` (3), ``cov`` (3 x 3)
and the ``samples`` (n x 3) the model was fitted to.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pliant.api import ConfigError

from pliant_tsrrt.geometry import BOX, CIRCLE, Footprints, wrap
from pliant_tsrrt.pushing import PRIMITIVES

FORMAT = "pliant-tsrrt-push-models"
VERSION = 1


def object_class(name: str) -> str:
    """The class of a scene object: its name without a trailing ``-<number>`` (``book-2`` -> ``book``)."""
    return re.sub(r"-\d+$", "", name)


@dataclass
class Displacement:
    """``P(delta s | a, o)`` for one class and primitive: Welford's running mean ``(3,)`` and scatter ``(3, 3)``
    of the displacements ``(dx, dy, dtheta)`` (object frame; m, m, rad) seen so far."""

    n: int = 0
    mean: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scatter: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    samples: list[list[float]] = field(default_factory=list)

    def update(self, delta: np.ndarray) -> None:
        """UPDATE_DISTR (LEARN_MODEL line 5): add one observed displacement ``(3,)``."""
        delta = np.asarray(delta, dtype=np.float64)
        self.n += 1
        d0 = delta - self.mean
        self.mean = self.mean + d0 / self.n
        self.scatter = self.scatter + np.outer(d0, delta - self.mean)
        self.samples.append(delta.tolist())

    @property
    def cov(self) -> np.ndarray:
        """Sample covariance ``(3, 3)`` of the displacement (zeros before two samples)."""
        return self.scatter / (self.n - 1) if self.n > 1 else np.zeros((3, 3))

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(np.maximum(np.diag(self.cov), 0.0))

    def mean_variance(self) -> np.ndarray:
        """VARIANCE (LEARN_MODEL line 6): the variance ``(3,)`` of the mean estimate, ``s_j^2 / n`` (inf below 2
        samples)."""
        if self.n < 2:
            return np.full(3, np.inf)
        return np.diag(self.cov) / self.n

    def to_dict(self) -> dict:
        return {"n": self.n, "mean": self.mean.tolist(), "cov": self.cov.tolist(), "samples": self.samples}

    @classmethod
    def from_dict(cls, data: dict, where: str) -> Displacement:
        try:
            samples = np.asarray(data["samples"], dtype=np.float64).reshape(-1, 3)
        except (KeyError, TypeError, ValueError):
            raise ConfigError("needs samples: a list of [dx, dy, dtheta]", field=f"{where}.samples",
                              value=data.get("samples") if isinstance(data, dict) else data) from None
        if not np.all(np.isfinite(samples)) or len(samples) == 0:
            raise ConfigError("samples must be finite and at least one", field=f"{where}.samples",
                              value=samples.tolist())
        out = cls()
        for row in samples:
            out.update(row)
        return out


@dataclass
class PushModels:
    """Models per object class (``footprints``: class -> (kind, half extents)) and per primitive (``models``:
    class -> list of six :class:`Displacement` in the order of :data:`PRIMITIVES`)."""

    footprints: dict[str, tuple[int, np.ndarray]] = field(default_factory=dict)
    models: dict[str, list[Displacement]] = field(default_factory=dict)

    def means(self, classes: list[str]) -> np.ndarray:
        """``(k, 6, 3)``: the mean displacement of every primitive for objects of ``classes`` (one per object);
        a :class:`ConfigError` names a class without a model."""
        missing = [c for c in classes if c not in self.models]
        if missing:
            raise ConfigError(f"no push model for this object class (models for: {', '.join(self.models) or 'none'})",
                              field="models", value=missing[0])
        return np.array([[d.mean for d in self.models[c]] for c in classes])

    def to_dict(self) -> dict:
        return {"format": FORMAT, "version": VERSION, "primitives": list(PRIMITIVES),
                "classes": {c: {"shape": "circle" if self.footprints[c][0] == CIRCLE else "box",
                                "half": np.asarray(self.footprints[c][1]).tolist(),
                                "primitives": {p: d.to_dict() for p, d in zip(PRIMITIVES, self.models[c])}}
                            for c in self.models}}

    @classmethod
    def from_dict(cls, data: dict, source: str = "<models>") -> PushModels:
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise ConfigError(f"not a push-models file (format must be '{FORMAT}')", source=source, field="format",
                              value=data.get("format") if isinstance(data, dict) else data)
        if data.get("version") != VERSION:
            raise ConfigError(f"unsupported version (this reader knows {VERSION})", source=source, field="version",
                              value=data.get("version"))
        out = cls()
        classes = data.get("classes")
        if not isinstance(classes, dict):
            raise ConfigError("must be a table of classes", source=source, field="classes", value=classes)
        for name, entry in classes.items():
            where = f"classes.{name}"
            if not isinstance(entry, dict) or entry.get("shape") not in ("box", "circle"):
                raise ConfigError("needs shape = box or circle", source=source, field=f"{where}.shape",
                                  value=entry.get("shape") if isinstance(entry, dict) else entry)
            half = np.asarray(entry.get("half"), dtype=np.float64).reshape(-1)
            prims = entry.get("primitives")
            if not isinstance(prims, dict) or sorted(prims) != sorted(PRIMITIVES):
                shown = sorted(prims) if isinstance(prims, dict) else prims
                raise ConfigError(f"needs the six primitives {', '.join(PRIMITIVES)}", source=source,
                                  field=f"{where}.primitives", value=shown)
            try:
                models = [Displacement.from_dict(prims[p], f"{where}.primitives.{p}") for p in PRIMITIVES]
            except ConfigError as exc:
                raise ConfigError(exc.message, source=source, field=exc.field, value=exc.value) from None
            out.footprints[name] = (CIRCLE if entry["shape"] == "circle" else BOX, half)
            out.models[name] = models
        return out

    def save(self, path: str | Path) -> None:
        """Write the models as JSON (atomically; parent directories are created)."""
        from pliant.api import write_json

        Path(path).parent.mkdir(parents=True, exist_ok=True)
        write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | Path) -> PushModels:
        try:
            data = json.loads(Path(path).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ConfigError(f"cannot read the push-models file: {exc}", source=str(path), field="<file>") from None
        return cls.from_dict(data, source=str(path))


def compose(poses: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """MODEL(s, a): poses ``(..., 3)`` moved by displacements ``(..., 3)`` given in each pose's frame."""
    c, s = np.cos(poses[..., 2]), np.sin(poses[..., 2])
    x = poses[..., 0] + c * delta[..., 0] - s * delta[..., 1]
    y = poses[..., 1] + s * delta[..., 0] + c * delta[..., 1]
    return np.stack([x, y, wrap(poses[..., 2] + delta[..., 2])], axis=-1)


def relative(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """The displacement ``(..., 3)`` from ``before`` to ``after`` in ``before``'s frame (inverse of :func:`compose`)."""
    d = after[..., :2] - before[..., :2]
    c, s = np.cos(before[..., 2]), np.sin(before[..., 2])
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1],
                     wrap(after[..., 2] - before[..., 2])], axis=-1)


def footprints_from_scene(scene, names: list[str]) -> Footprints:
    """The planar footprints of the named scene objects (boxes and z-axis cylinders/spheres as circles)."""
    kinds, halves = [], []
    for name in names:
        obj = scene.object(name)
        shape = obj.part.shape
        if shape.kind == "box":
            kinds.append(BOX)
            halves.append(np.asarray(shape.size[:2], dtype=np.float64) / 2)
        elif shape.kind in ("cylinder", "sphere"):
            kinds.append(CIRCLE)
            halves.append(np.array([shape.radius, shape.radius], dtype=np.float64))
        else:
            raise ConfigError("TS-RRT needs box, cylinder or sphere footprints", source=scene.source,
                              field=f"objects.{name}.shape", value=shape.kind)
    return Footprints(np.array(kinds, dtype=np.int64), np.array(halves).reshape(-1, 2))


def scene_pose(scene, name: str) -> np.ndarray:
    """``(x, y, theta)`` of a scene object (m, rad; its yaw about z)."""
    part = scene.object(name).part
    q = part.pose.orientation
    return np.array([part.pose.position[0], part.pose.position[1], float(wrap(2 * np.arctan2(q[2], q[3])))])
