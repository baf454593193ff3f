"""Demonstrations and demonstration tasks (thesis 4.3.1), and their JSON file format.

A *task* is what a demonstrator is asked to do: from the probe's start configuration, touch ``target`` with the
probe tip while staying inside the *collision planes* (the funnel of Figure 4.3).  A *demonstration* is a task
and the path that was shown for it.  Files hold a list of demonstrations::

    {"format": "pliant-demonstrations", "version": 1, "scene": "hollow-cube",
     "demonstrations": [{"task": {"start": [...], "target": [x, y, z], "planes": [[nx, ny, nz, offset], ...],
                                  "objects": ["L1", "M1"], "edge": [x, y, z]},
                         "path": [[...], ...], "source": "simulated-expert"}]}

Planes are half-spaces ``n . x <= offset`` (``n`` a unit normal, metres) that every point of the probe must
satisfy; ``objects`` and ``edge`` (the pair the task was generated for and its edge point) are optional, and so is
``goal``, a goal configuration for tasks that end at one.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pliant.api import ConfigError, write_json

FORMAT = "pliant-demonstrations"
VERSION = 1
#: most demonstrations in a file and most waypoints in a path: checked before arrays are built
MAX_DEMONSTRATIONS = 10_000
MAX_WAYPOINTS = 100_000


@dataclass(frozen=True, eq=False)
class DemonstrationTask:
    """Start configuration ``(d,)``, target point ``(3,)`` (m), collision planes ``(p, 4)`` rows ``(n, offset)``
    meaning ``n . x <= offset``; ``objects``: the object pair the task asks about; ``edge``: its edge point (m);
    ``goal``: a goal configuration ``(d,)`` for tasks that end at one (the planar environment) rather than with
    a tip on the target (the target is then the goal's position)."""

    start: np.ndarray
    target: np.ndarray
    planes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    objects: tuple[str, ...] = ()
    edge: np.ndarray | None = None
    goal: np.ndarray | None = None

    def allows(self, points: np.ndarray, tolerance: float = 1e-9) -> np.ndarray:
        """Whether points ``(..., 3)`` lie inside every collision plane; bool ``(...)``."""
        points = np.asarray(points, dtype=np.float64)
        if len(self.planes) == 0:
            return np.ones(points.shape[:-1], dtype=bool)
        return np.all(points @ self.planes[:, :3].T <= self.planes[:, 3] + tolerance, axis=-1)

    def to_dict(self) -> dict:
        data = {"start": self.start.tolist(), "target": self.target.tolist(), "planes": self.planes.tolist(),
                "objects": list(self.objects)}
        if self.edge is not None:
            data["edge"] = self.edge.tolist()
        if self.goal is not None:
            data["goal"] = self.goal.tolist()
        return data

    @classmethod
    def from_dict(cls, data, *, source: str = "<dict>", field_name: str = "task", dim: int | None = None):
        """Validated: every field named in the error."""
        if not isinstance(data, dict):
            raise ConfigError("must be a table", source=source, field=field_name, value=data)
        unknown = set(data) - {"start", "target", "planes", "objects", "edge", "goal"}
        if unknown:
            raise ConfigError(f"unknown key(s) {sorted(unknown)}", source=source, field=field_name, value=data)
        start = _vector(data, "start", dim, source, field_name)
        target = _vector(data, "target", 3, source, field_name)
        planes = _matrix(data.get("planes", []), 4, source, f"{field_name}.planes")
        norms = np.linalg.norm(planes[:, :3], axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-6):
            raise ConfigError("every plane normal must be a unit vector", source=source, field=f"{field_name}.planes",
                              value=norms.tolist())
        objects = data.get("objects", [])
        if not isinstance(objects, list) or not all(isinstance(o, str) and o for o in objects):
            raise ConfigError("must be a list of object names", source=source, field=f"{field_name}.objects",
                              value=objects)
        edge = _vector(data, "edge", 3, source, field_name) if "edge" in data else None
        goal = _vector(data, "goal", len(start), source, field_name) if "goal" in data else None
        return cls(start, target, planes, tuple(objects), edge, goal)


@dataclass(frozen=True, eq=False)
class Demonstration:
    """A demonstrated path ``(k, d)`` for ``task``; ``source`` says who showed it (``simulated-expert``,
    ``capture``, ``rosbag:<topic>``, ...)."""

    task: DemonstrationTask
    path: np.ndarray
    source: str = "unknown"

    def to_dict(self) -> dict:
        return {"task": self.task.to_dict(), "path": self.path.tolist(), "source": self.source}

    @classmethod
    def from_dict(cls, data, *, source: str = "<dict>", field_name: str = "demonstration", dim: int | None = None):
        if not isinstance(data, dict):
            raise ConfigError("must be a table", source=source, field=field_name, value=data)
        unknown = set(data) - {"task", "path", "source"}
        if unknown:
            raise ConfigError(f"unknown key(s) {sorted(unknown)}", source=source, field=field_name, value=data)
        if "task" not in data:
            raise ConfigError("is missing", source=source, field=f"{field_name}.task")
        task = DemonstrationTask.from_dict(data["task"], source=source, field_name=f"{field_name}.task", dim=dim)
        path = _matrix(data.get("path"), len(task.start), source, f"{field_name}.path")
        if len(path) < 2:
            raise ConfigError("a path needs at least two configurations", source=source, field=f"{field_name}.path",
                              value=len(path))
        if len(path) > MAX_WAYPOINTS:
            raise ConfigError(f"more than {MAX_WAYPOINTS} configurations", source=source, field=f"{field_name}.path",
                              value=len(path))
        who = data.get("source", "unknown")
        if not isinstance(who, str):
            raise ConfigError("must be a string", source=source, field=f"{field_name}.source", value=who)
        return cls(task, path, who)


def check_demonstrations(demonstrations, scene, space, *, source: str | None = None,
                         field_name: str = "demonstrations") -> list[Demonstration]:
    """``demonstrations`` checked against the scene they are to be learned in, before any array is built from them:
    a non-empty list of :class:`Demonstration` whose paths are ``(k, d)`` with ``2 <= k <=`` :data:`MAX_WAYPOINTS`
    and ``d`` the ``space``'s dimension, finite, and inside the space (its bounds: the workspace of a rigid robot,
    the joint limits of a URDF robot; unit quaternions); the task's start and goal likewise, its target and edge
    point (m) inside the scene's bounds, its planes finite and its objects the scene's.  A
    :class:`~pliant.errors.ConfigError` names the demonstration, the waypoint or field, and the bounds.  (A waypoint
    1e6 m away would otherwise make the sampler allocate hundreds of GiB.)"""
    if isinstance(demonstrations, (str, bytes)) or not isinstance(demonstrations, (list, tuple)) or \
            not demonstrations:
        raise ConfigError("must be a non-empty list of demonstrations", source=source, field=field_name,
                          value=type(demonstrations).__name__)
    if len(demonstrations) > MAX_DEMONSTRATIONS:
        raise ConfigError(f"more than {MAX_DEMONSTRATIONS} demonstrations", source=source, field=field_name,
                          value=len(demonstrations))
    names = [o.name for o in scene.objects]
    lower, upper = np.asarray(scene.lower, dtype=np.float64), np.asarray(scene.upper, dtype=np.float64)
    space_lower, space_upper = getattr(space, "lower", None), getattr(space, "upper", None)
    rigid = space.kind in ("se2", "se3")
    bounds = (f"{np.round(space_lower, 6).tolist()} .. {np.round(space_upper, 6).tolist()}" + (" m" if rigid else "")
              if space_lower is not None and space_upper is not None else "")
    where_bounds = "the workspace bounds" if rigid else f"the {space.kind} space's bounds"

    def configurations(value, what: str, at_least: int) -> np.ndarray:
        try:
            q = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise ConfigError("must be numbers", source=source, field=what, value=repr(value)[:80]) from None
        if q.ndim == 1 and at_least == 1:
            q = q[None]
        if q.ndim != 2 or q.shape[1] != space.dim:
            raise ConfigError(f"must have {space.dim} coordinates per configuration (a {space.kind} space)",
                              source=source, field=what, value=list(np.shape(value)))
        if len(q) < at_least or len(q) > MAX_WAYPOINTS:
            raise ConfigError(f"needs {at_least} to {MAX_WAYPOINTS} configurations", source=source, field=what,
                              value=len(q))
        finite = np.all(np.isfinite(q), axis=1)
        valid = np.zeros(len(q), dtype=bool)
        valid[finite] = np.asarray(space.is_valid(q[finite]), dtype=bool).reshape(-1)
        if not valid.all():
            j = int(np.argmin(valid))
            at = f"{what}[{j}]" if at_least > 1 else what
            reason = space.explain_invalid(q[j:j + 1]) if finite[j] else "is not finite"
            why = f"lies outside {where_bounds} {bounds}" if "bounds" in (reason or "bounds") else reason
            raise ConfigError(f"{'waypoint ' + str(j) + ' ' if at_least > 1 else ''}{why}", source=source,
                              field=at, value=q[j].tolist())
        return q

    def point(value, what: str) -> None:
        p = np.asarray(value, dtype=np.float64).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)) or np.any(p < lower - 1e-9) or np.any(p > upper + 1e-9):
            raise ConfigError(f"must be a point (m) inside the scene's bounds {lower.tolist()} .. {upper.tolist()}",
                              source=source, field=what, value=p.tolist())

    for i, demonstration in enumerate(demonstrations):
        at = f"{field_name}[{i}]"
        if not isinstance(demonstration, Demonstration):
            raise ConfigError("must be a Demonstration", source=source, field=at, value=type(demonstration).__name__)
        task = demonstration.task
        configurations(demonstration.path, f"{at}.path", 2)
        configurations(task.start, f"{at}.task.start", 1)
        if task.goal is not None:
            configurations(task.goal, f"{at}.task.goal", 1)
        point(task.target, f"{at}.task.target")
        if task.edge is not None:
            point(task.edge, f"{at}.task.edge")
        planes = np.asarray(task.planes, dtype=np.float64)
        if planes.ndim != 2 or planes.shape[1] != 4 or not np.all(np.isfinite(planes)):
            raise ConfigError("must be rows (nx, ny, nz, offset) of finite numbers", source=source,
                              field=f"{at}.task.planes", value=list(planes.shape))
        for m, name in enumerate(task.objects):
            if name not in names:
                raise ConfigError(f"names an object the scene {scene.name!r} lacks (its objects: "
                                  f"{', '.join(names) or 'none'})", source=source, field=f"{at}.task.objects[{m}]",
                                  value=name)
    return list(demonstrations)


def save_demonstrations(path: str | Path, demonstrations: list[Demonstration], scene: str) -> Path:
    """Write ``demonstrations`` (atomically) as a demonstrations file of ``scene``."""
    return write_json(path, {"format": FORMAT, "version": VERSION, "scene": scene,
                             "demonstrations": [d.to_dict() for d in demonstrations]})


def load_demonstrations(path: str | Path, dim: int | None = None) -> tuple[str, list[Demonstration]]:
    """Read a demonstrations file; returns ``(scene name, demonstrations)``.  Errors name the file and field."""
    if not isinstance(path, (str, Path)) or str(path) == "":
        raise ConfigError("must be a file path", field="demonstrations", value=path)
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise ConfigError("no such file", source=source, value=str(path))
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise ConfigError(f"not a JSON file: {exc}", source=source) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ConfigError(f"not a demonstrations file (format must be {FORMAT!r})", source=source, field="format",
                          value=data.get("format") if isinstance(data, dict) else type(data).__name__)
    if data.get("version") != VERSION:
        raise ConfigError(f"unsupported version (this pliant reads {VERSION})", source=source, field="version",
                          value=data.get("version"))
    scene = data.get("scene")
    if not isinstance(scene, str) or not scene:
        raise ConfigError("must name the scene the demonstrations were shown in", source=source, field="scene",
                          value=scene)
    items = data.get("demonstrations")
    if not isinstance(items, list):
        raise ConfigError("must be a list", source=source, field="demonstrations", value=items)
    if len(items) > MAX_DEMONSTRATIONS:
        raise ConfigError(f"more than {MAX_DEMONSTRATIONS} demonstrations", source=source, field="demonstrations",
                          value=len(items))
    return scene, [Demonstration.from_dict(d, source=source, field_name=f"demonstrations[{i}]", dim=dim)
                   for i, d in enumerate(items)]


def _vector(data: dict, key: str, size: int | None, source: str, prefix: str) -> np.ndarray:
    if key not in data:
        raise ConfigError("is missing", source=source, field=f"{prefix}.{key}")
    value = data[key]
    wrong_size = size is not None and isinstance(value, list) and len(value) != size
    if not isinstance(value, list) or not all(_is_number(v) for v in value) or wrong_size:
        wanted = f"{size} finite numbers" if size is not None else "a list of finite numbers"
        raise ConfigError(f"must be {wanted}", source=source, field=f"{prefix}.{key}", value=value)
    if not value:
        raise ConfigError("must not be empty", source=source, field=f"{prefix}.{key}", value=value)
    return np.asarray(value, dtype=np.float64)


def _matrix(value, columns: int, source: str, name: str) -> np.ndarray:
    if not isinstance(value, list) or not all(
            isinstance(row, list) and len(row) == columns and all(_is_number(v) for v in row) for row in value):
        raise ConfigError(f"must be a list of rows of {columns} finite numbers", source=source, field=name,
                          value=value)
    return np.asarray(value, dtype=np.float64).reshape(len(value), columns)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
