"""What the viewer shows, as plain arrays: the translation from pliant's scenes and results to 3-D primitives.

Nothing here imports viser, so the translation is tested without a browser.  Every function reads the core's
data only (:class:`~pliant.scene.Scene`, :class:`~pliant.geometry.voxelgrid.VoxelGrid`, the ``RobotModel`` interface,
the JSON of results, policies and executions) -- never another plugin.

Colours (RGB, 0-255):

- a voxel object's colour is its material: deformability 0 (rigid) is slate blue, 1 (free to deform) is green,
  in between a blend; ``nan`` deformability or sensitivity (forbidden) is dark red.  Where a voxel object holds
  per-voxel materials (a voxel-array shape) every voxel has its own colour.
- the planned path is orange, the executed trajectory blue, the belief tree grey with its particles coloured
  by the node's probability to reach the goal; a Pareto front's paths run from purple to yellow.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path as FilePath

import numpy as np
from pliant.api import FREE_VOXEL as FREE
from pliant.api import ConfigError, VoxelGrid
from pliant.api import read_json as _read_json

RIGID = np.array([70, 90, 160], dtype=np.float64)        # deformability 0
SOFT = np.array([90, 200, 110], dtype=np.float64)        # deformability 1
FORBIDDEN = np.array([140, 20, 30], dtype=np.uint8)       # nan material
PATH_COLOUR = (255, 140, 0)
TRAJECTORY_COLOUR = (30, 110, 255)
TREE_COLOUR = (150, 150, 150)


def material_colours(deformability: np.ndarray, sensitivity: np.ndarray) -> np.ndarray:
    """``(n, 3)`` uint8 colours of voxels with these materials (see the module's docstring)."""
    d = np.asarray(deformability, dtype=np.float64)
    s = np.asarray(sensitivity, dtype=np.float64)
    bad = ~np.isfinite(d) | ~np.isfinite(s)
    t = np.clip(np.nan_to_num(d), 0.0, 1.0)[:, None]
    rgb = np.rint(RIGID * (1.0 - t) + SOFT * t).astype(np.uint8)
    rgb[bad] = FORBIDDEN
    return rgb


@dataclass
class VoxelObject:
    """The voxels of one scene object: its surface voxels (those with a face not touching the same object)
    ``centres`` ``(n, 3)`` (m) and ``colours`` ``(n, 3)`` uint8, the number of voxels it occupies in all (``total``),
    and the mesh the page draws: its exposed voxel faces, merged into strips of one colour (``vertices`` ``(4q, 3)``,
    ``faces`` ``(2q, 3)``, ``vertex_colours`` ``(4q, 3)``)."""

    name: str
    centres: np.ndarray
    colours: np.ndarray
    total: int
    deformability: float
    sensitivity: float
    vertices: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    faces: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.uint32))
    vertex_colours: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.uint8))


def exposed_faces(code: np.ndarray, lower: np.ndarray, resolution: float):
    """The faces between the voxels of one object and the rest, as quads merged along runs of one colour, wound
    counter-clockwise seen from outside the object (so a renderer may cull back faces).

    ``code`` ``(nx, ny, nz)`` int: the colour index of each of the object's voxels, -1 elsewhere.  Returns
    ``(vertices (4q, 3), faces (2q, 3), colour index per quad (q,))``.  A 3 m wall of 3 cm voxels is ~200 strips
    instead of ~20,000 voxel cubes, which is what keeps software WebGL interactive.
    """
    quads, codes = [], []
    inside = code >= 0
    for axis in range(3):
        for side in (-1, 1):
            neighbour = np.full(code.shape, False)
            src = [slice(None)] * 3
            dst = [slice(None)] * 3
            if side > 0:
                src[axis], dst[axis] = slice(1, None), slice(None, -1)
            else:
                src[axis], dst[axis] = slice(None, -1), slice(1, None)
            neighbour[tuple(dst)] = inside[tuple(src)]
            key = np.where(inside & ~neighbour, code, -1)
            # runs along the last remaining axis: move (axis, u, v) to the front
            others = [a for a in range(3) if a != axis]
            k = np.transpose(key, (axis, others[0], others[1]))
            padded = np.concatenate([np.full(k.shape[:2] + (1,), -1), k, np.full(k.shape[:2] + (1,), -1)], axis=2)
            change = padded[:, :, 1:] != padded[:, :, :-1]
            starts = np.argwhere(change[:, :, :-1] & (k >= 0))
            ends = np.argwhere(change[:, :, 1:] & (k >= 0))
            if not len(starts):
                continue
            layer, u, v0 = starts.T
            v1 = ends[:, 2] + 1
            plane = layer + (1 if side > 0 else 0)
            corners = []
            order = ((u, v0), (u + 1, v0), (u + 1, v1), (u, v1))
            # counter-clockwise seen from outside (three.js front faces): that order's normal is +axis for x and z
            # and -axis for y (the (x, z) plane), so flip it where that is not the side the face looks to
            if (side > 0) == (axis == 1):
                order = order[::-1]
            for uu, vv in order:
                c = np.empty((len(layer), 3))
                c[:, axis], c[:, others[0]], c[:, others[1]] = plane, uu, vv
                corners.append(c)
            quads.append(np.stack(corners, axis=1))
            codes.append(k[layer, u, v0])
    if not quads:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.uint32), np.zeros(0, dtype=np.int64)
    q = np.concatenate(quads)
    vertices = (np.asarray(lower, dtype=np.float64) + q * resolution).reshape(-1, 3)
    base = 4 * np.arange(len(q), dtype=np.uint32)[:, None]
    faces = np.concatenate([base + np.array([0, 1, 2], dtype=np.uint32), base + np.array([0, 2, 3], dtype=np.uint32)])
    return vertices, faces, np.concatenate(codes)


def voxel_objects(grid: VoxelGrid, surface_only: bool = True) -> list[VoxelObject]:
    """One :class:`VoxelObject` per object of ``grid`` that occupies any voxel, in the grid's object order."""
    ids = grid.object_id
    out = []
    totals = np.bincount(ids[ids != FREE].ravel(), minlength=len(grid.object_names))
    for k, name in enumerate(grid.object_names):
        if totals[k] == 0:
            continue
        # work inside the object's bounding box (plus one voxel), not over the whole grid
        where = np.nonzero(ids == k)
        lo = np.maximum(np.array([w.min() for w in where]) - 1, 0)
        hi = np.minimum(np.array([w.max() for w in where]) + 2, ids.shape)
        box = tuple(slice(a, b) for a, b in zip(lo, hi))
        mine = ids[box] == k
        d_box, s_box = grid.deformability[box], grid.sensitivity[box]
        # a voxel is drawn when one of its six neighbours is not the same object (or it is on the grid's edge)
        keep = mine & ~_interior(mine) if surface_only else mine
        index = np.argwhere(keep)
        d, s = d_box[tuple(index.T)], s_box[tuple(index.T)]
        obj = VoxelObject(name, grid.centres(index + lo), material_colours(d, s), int(totals[k]),
                          float(np.mean(d_box[mine])), float(np.mean(s_box[mine])))
        dm, sm = d_box[mine], s_box[mine]
        code = np.full(mine.shape, -1, dtype=np.int64)
        if np.all(dm == dm[0]) and (np.all(sm == sm[0]) or np.all(np.isnan(sm))):
            palette = material_colours(dm[:1], sm[:1])
            code[mine] = 0
        else:
            palette, codes = np.unique(material_colours(dm, sm), axis=0, return_inverse=True)
            code[mine] = codes.ravel()
        obj.vertices, obj.faces, quad_codes = exposed_faces(code, grid.lower + lo * grid.resolution,
                                                            grid.resolution)
        obj.vertex_colours = np.repeat(palette[quad_codes], 4, axis=0)
        out.append(obj)
    return out


def _interior(mine: np.ndarray) -> np.ndarray:
    """Voxels of ``mine`` whose six face neighbours are all in ``mine`` (outside the array counts as not)."""
    padded = np.pad(mine, 1, constant_values=False)
    inner = padded[1:-1, 1:-1, 1:-1].copy()
    for axis in range(3):
        for shift in (-1, 1):
            inner &= np.roll(padded, shift, axis=axis)[1:-1, 1:-1, 1:-1]
    return inner


class Tracer:
    """Where a configuration is in 3-D, for drawing paths, trajectories and trees.

    A free-flying body (R^3, SE(2), SE(3)) is drawn at its translation, so a path's polyline is the path's own
    positions.  An articulated robot is drawn at its *tip*: the body point that moves farthest between the
    scene's start and goal (the hand, for a reaching arm), through ``RobotModel.body_points``.
    """

    def __init__(self, space_kind: str, robot=None, start: np.ndarray | None = None,
                 goal: np.ndarray | None = None, z: float = 0.0) -> None:
        self.space_kind = space_kind
        self.robot = robot
        self.z = z
        self.tip: int | None = None
        if space_kind not in ("r3", "se2", "se3") and robot is not None:
            ends = robot.body_points(np.stack([np.asarray(start, float), np.asarray(goal, float)]))
            self.tip = int(np.argmax(np.linalg.norm(ends[1] - ends[0], axis=1)))

    def points(self, q: np.ndarray) -> np.ndarray:
        """``(n, 3)`` positions of configurations ``(n, d)``."""
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        if self.space_kind in ("r3", "se3"):
            return q[:, :3].copy()
        if self.space_kind == "se2":
            return np.column_stack([q[:, 0], q[:, 1], np.full(len(q), self.z)])
        if self.tip is None:
            raise ValueError(f"cannot place configurations of a '{self.space_kind}' space without a robot")
        out = np.empty((len(q), 3))
        for i in range(0, len(q), 2048):        # body_points is batched; keep memory bounded
            out[i:i + 2048] = self.robot.body_points(q[i:i + 2048], np.array([self.tip]))[:, 0]
        return out


@dataclass
class Tree:
    """A belief tree / partial policy as drawn: node positions ``(n, 3)``, edges ``(e, 2)`` node indices,
    particles ``(p, 3)`` with the node each belongs to, per-node probability of reaching the goal, the nodes of the
    solutions, and action targets ``(a, 3)``."""

    nodes: np.ndarray
    edges: np.ndarray
    particles: np.ndarray
    particle_node: np.ndarray
    probability: np.ndarray
    solution_nodes: np.ndarray
    action_targets: np.ndarray


def policy_tree(policy: dict, tracer: Tracer, max_particles: int = 50_000) -> Tree:
    """The tree of a partial policy's JSON (``PartialPolicy.to_dict``: ``nodes`` with ``particles``, ``parent``,
    ``expected``...; ``actions`` with ``target``; ``solutions``), placed by ``tracer``.

    A node sits at its expected configuration (the mean of its particles when it has none).  At most
    ``max_particles`` particles are kept (every k-th, evenly), so a huge tree stays drawable.
    """
    nodes = policy.get("nodes") or []
    centres, parents, probs, parts, owner = [], [], [], [], []
    for i, node in enumerate(nodes):
        particles = np.asarray(node.get("particles") or [], dtype=np.float64)
        expected = node.get("expected")
        centre = np.asarray(expected, dtype=np.float64) if expected is not None else particles.mean(axis=0)
        centres.append(centre)
        parents.append(node.get("parent"))
        probs.append(float(node.get("path_probability", node.get("probability", 0.0)) or 0.0))
        if particles.size:
            parts.append(particles.reshape(len(particles), -1))
            owner.append(np.full(len(particles), i))
    q = np.array(centres) if centres else np.zeros((0, len(policy.get("goal") or [0, 0, 0])))
    positions = tracer.points(q) if len(q) else np.zeros((0, 3))
    edges = np.array([[p, i] for i, p in enumerate(parents) if p is not None and 0 <= p < len(nodes)],
                     dtype=np.int64).reshape(-1, 2)
    if parts:
        allp = np.concatenate(parts)
        owners = np.concatenate(owner)
        if len(allp) > max_particles:
            keep = np.linspace(0, len(allp) - 1, max_particles).astype(np.int64)
            allp, owners = allp[keep], owners[keep]
        particle_xyz = tracer.points(allp)
    else:
        particle_xyz, owners = np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    solution_nodes = np.unique(np.array([i for s in policy.get("solutions") or [] for i in s], dtype=np.int64))
    targets = [a["target"] for a in policy.get("actions") or [] if a.get("target") is not None]
    action_xyz = tracer.points(np.array(targets)) if targets else np.zeros((0, 3))
    return Tree(positions, edges, particle_xyz, owners.astype(np.int64), np.array(probs), solution_nodes,
                action_xyz)


def probability_colours(p: np.ndarray) -> np.ndarray:
    """``(n, 3)`` uint8: red (0) through yellow to green (1)."""
    p = np.clip(np.nan_to_num(np.asarray(p, dtype=np.float64)), 0.0, 1.0)[:, None]
    low, mid, high = np.array([220, 50, 40.0]), np.array([240, 200, 40.0]), np.array([40, 180, 60.0])
    rgb = np.where(p < 0.5, low + (mid - low) * (p / 0.5), mid + (high - mid) * ((p - 0.5) / 0.5))
    return np.rint(rgb).astype(np.uint8)


def pareto_paths(statistics: dict, grid_lower: np.ndarray, resolution: float) -> list[dict]:
    """The Pareto-optimal paths of an ``astar-pareto`` result (``statistics["pareto"]`` and ``["pareto_paths"]``,
    lattice cells of the scene's voxel grid) as world polylines with their length and deformation."""
    front = statistics.get("pareto") or []
    cells = statistics.get("pareto_paths") or []
    out = []
    for point, c in zip(front, cells):
        xyz = np.asarray(grid_lower, dtype=np.float64) + (np.asarray(c, dtype=np.float64) + 0.5) * resolution
        out.append({"points": xyz, "length_voxels": float(point["length_voxels"]),
                    "deformation": float(point["deformation"]), "p_values": list(point["p_values"])})
    return out


def front_colours(n: int) -> np.ndarray:
    """``(n, 3)`` uint8 colours from purple to yellow for ``n`` Pareto paths."""
    t = np.linspace(0.0, 1.0, max(n, 1))[:n, None]
    return np.rint(np.array([90, 20, 140.0]) * (1 - t) + np.array([250, 210, 40.0]) * t).astype(np.uint8)


@dataclass
class RunData:
    """What a run folder (``out/<name>/``) holds, read as JSON: the pipeline (``run.json``), the result
    (``result.json``: status, path, policy, statistics) and the execution (``execution.json``)."""

    folder: FilePath | None = None
    pipeline: dict = field(default_factory=dict)
    result: dict | None = None
    execution: dict | None = None

    @property
    def scene_name(self) -> str | None:
        scene = self.pipeline.get("scene")
        return scene.get("name") if isinstance(scene, dict) else scene

    @property
    def scene_variant(self) -> str | None:
        """The scene's variant when the run named one (``scene = {name, variant}``)."""
        scene = self.pipeline.get("scene")
        return scene.get("variant") if isinstance(scene, dict) else None

    @property
    def robot_name(self) -> str | None:
        robot = self.pipeline.get("robot")
        if isinstance(robot, dict):
            return robot.get("name")
        return robot

    @property
    def robot_options(self) -> dict:
        """The options the run's robot was built with (``run.json``), without its name."""
        robot = self.pipeline.get("robot")
        return {k: v for k, v in robot.items() if k != "name"} if isinstance(robot, dict) else {}

    @property
    def path(self) -> np.ndarray | None:
        p = (self.result or {}).get("path")
        return None if not p else np.asarray(p["configurations"], dtype=np.float64)

    @property
    def policy(self) -> dict | None:
        return (self.result or {}).get("policy")

    @property
    def trajectory(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``(times (k,), configurations (k, d))`` of the execution, or ``None``."""
        if not self.execution or not self.execution.get("configurations"):
            return None
        return (np.asarray(self.execution["times"], dtype=np.float64),
                np.asarray(self.execution["configurations"], dtype=np.float64))


def read_json(path: FilePath) -> dict:
    """The JSON object in the file at ``path``; a file cut off, not JSON or not an object is one ConfigError naming
    it (:func:`pliant.files.read_json`)."""
    return _read_json(path)


def _array(value, source: FilePath, name: str, ndim: int) -> np.ndarray:
    """``value`` as a finite float64 array of ``ndim`` dimensions with at least one entry per axis, or a
    ConfigError naming the file and field."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or a.ndim != ndim or 0 in a.shape or not np.isfinite(a).all():
        shown = value if a is None else f"an array of shape {a.shape}" + ("" if a.size == 0 or np.isfinite(
            a).all() else " with non-finite entries")
        raise ConfigError(f"must be a {'list' if ndim == 1 else 'table'} of finite numbers", source=str(source),
                          field=name, value=shown)
    return a


def _mapping(data: dict, key: str, source: FilePath) -> dict | None:
    value = data.get(key)
    if value is not None and not isinstance(value, dict):
        raise ConfigError("must be an object", source=str(source), field=key, value=type(value).__name__)
    return value


def check_result(data: dict, source: FilePath) -> dict:
    """A result's JSON (``result.json``) as the viewer reads it: ``path.configurations`` a table of finite numbers,
    ``policy`` and ``statistics`` objects (each may be missing); anything else is a ConfigError naming the field."""
    path = _mapping(data, "path", source)
    if path:
        _array(path.get("configurations"), source, "path.configurations", 2)
    policy = _mapping(data, "policy", source)
    if policy is not None:
        check_policy(policy, source, "policy.")
    _mapping(data, "statistics", source)
    return data


def check_policy(data: dict, source: FilePath, prefix: str = "") -> dict:
    """A partial policy's JSON as the viewer reads it: ``nodes`` a list of objects, each node's ``particles`` a
    table and ``expected`` a list of finite numbers, ``parent`` a node index or null."""
    nodes = data.get("nodes")
    if nodes is not None and not isinstance(nodes, list):
        raise ConfigError("must be a list", source=str(source), field=f"{prefix}nodes", value=type(nodes).__name__)
    for i, node in enumerate(nodes or []):
        where = f"{prefix}nodes[{i}]"
        if not isinstance(node, dict):
            raise ConfigError("must be an object", source=str(source), field=where, value=type(node).__name__)
        if node.get("particles"):
            _array(node["particles"], source, f"{where}.particles", 2)
        if node.get("expected") is not None:
            _array(node["expected"], source, f"{where}.expected", 1)
        elif not node.get("particles"):
            raise ConfigError("needs its expected configuration or its particles", source=str(source), field=where)
        parent = node.get("parent")
        if parent is not None and (isinstance(parent, bool) or not isinstance(parent, int)):
            raise ConfigError("must be a node index or null", source=str(source), field=f"{where}.parent",
                              value=parent)
    return data


def check_execution(data: dict, source: FilePath) -> dict:
    """An execution's JSON (``execution.json``): ``times`` a list and ``configurations`` a table of finite numbers,
    one row per time (both may be missing)."""
    if data.get("configurations"):
        q = _array(data["configurations"], source, "configurations", 2)
        t = _array(data.get("times"), source, "times", 1)
        if len(t) != len(q):
            raise ConfigError(f"must hold one time per configuration ({len(q)})", source=str(source), field="times",
                              value=f"{len(t)} times")
    return data


def read_run(folder: FilePath) -> RunData:
    """Read a run folder written by ``pliant run`` (missing files are left out).  A file cut off, not JSON, or
    whose fields the viewer reads have the wrong form is one ConfigError naming the file and the field."""
    folder = FilePath(folder)
    data = RunData(folder)
    if (folder / "run.json").is_file():
        source = folder / "run.json"
        data.pipeline = _mapping(read_json(source), "pipeline", source) or {}
        scene = data.pipeline.get("scene")
        name = scene.get("name") if isinstance(scene, dict) else scene
        if scene is not None and not (isinstance(name, str) and name):
            raise ConfigError("must be a scene name or {name, variant}", source=str(source), field="pipeline.scene",
                              value=scene)
        robot = data.pipeline.get("robot")
        if robot is not None and not isinstance(robot, (str, dict)):
            raise ConfigError("must be a robot name or {name, options}", source=str(source), field="pipeline.robot",
                              value=robot)
    if (folder / "result.json").is_file():
        data.result = check_result(read_json(folder / "result.json"), folder / "result.json")
    if (folder / "execution.json").is_file():
        data.execution = check_execution(read_json(folder / "execution.json"), folder / "execution.json")
    return data


def check_dimension(run: RunData | None, policy: dict | None, dimension: int, source: str) -> None:
    """The run's path and execution, and the policy's nodes, hold configurations of ``dimension`` coordinates (the
    scene's robot's); else a ConfigError naming the file (``source``: the policy file) and the field."""
    folder = run.folder if run is not None and run.folder is not None else FilePath(".")
    tables = []
    if run is not None and run.path is not None:
        tables.append((folder / "result.json", "path.configurations", run.path))
    if run is not None and run.trajectory is not None:
        tables.append((folder / "execution.json", "configurations", run.trajectory[1]))
    nodes = (policy or {}).get("nodes") or []
    for i, node in enumerate(nodes[:1]):          # one node tells which space the policy was planned in
        if node.get("expected") is not None:
            tables.append((source, f"nodes[{i}].expected", np.atleast_2d(node["expected"])))
    for path, name, table in tables:
        if np.shape(table)[-1] != dimension:
            raise ConfigError(f"holds configurations of {np.shape(table)[-1]} coordinates; the scene's robot has "
                              f"{dimension} (another scene's run? name the scene with --scene)", source=str(path),
                              field=name, value=list(np.shape(table)))
