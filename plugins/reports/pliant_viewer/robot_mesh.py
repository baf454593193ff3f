"""A URDF robot as a few merged meshes and its own forward kinematics, converted once and kept on disk.

Drawing a URDF through yourdfpy and viser's ``ViserUrdf`` costs, on every view: importing yourdfpy and trimesh
(1.3-1.6 s on this machine under load), parsing the meshes, one scene node per joint frame and per mesh (Baxter: 56
frames and 37 meshes, sent as GLB files the page parses) and, for every pose, every joint frame's transform through
yourdfpy.  Here
the robot is converted once, with yourdfpy, into:

- groups: the base (everything that never moves: the joints that are not planned stay at the robot model's fixed
  posture) and one group per planned joint (the links it moves, up to the next planned joint);
- per group, its meshes merged into one array of vertices and faces per colour, in the group's frame (Baxter's
  collision meshes: 8 groups, 18,955 triangles; spheres are re-made with 320 faces instead of 1,280);
- per planned joint, its type, axis and the constant transform from its parent group's frame to its own at zero.

The result is a ``.npz`` of arrays and JSON (no pickles) in the user's cache directory
(``$XDG_CACHE_HOME/pliant/viewer``, else ``~/.cache/pliant/viewer``), keyed by a hash of the URDF file's bytes, the
size and time of every mesh file it names, the mesh kind, the planned joints and the posture.  A cached robot is
drawn with numpy alone: no yourdfpy, trimesh or robot model.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

FORMAT = 1
COLLISION_COLOUR = (191, 56, 51)


@dataclass
class RobotMeshes:
    """The robot as drawn: ``parent[g]`` (-1 for the base, group 0), ``slot[g]`` the joint's index in the planned
    configuration (-1 for the base), ``kind[g]`` ``"revolute"`` or ``"prismatic"``, ``axis[g]`` ``(3,)``,
    ``origin[g]`` ``(4, 4)`` (the parent group's frame to this joint's frame at zero), ``names[g]``, and ``meshes``:
    ``(group, vertices (n, 3) float32 in the group's frame, faces (m, 3) uint32, colour (3,) uint8)``."""

    names: list[str]
    parent: np.ndarray
    slot: np.ndarray
    kind: list[str]
    axis: np.ndarray
    origin: np.ndarray
    meshes: list[tuple[int, np.ndarray, np.ndarray, tuple[int, int, int]]]

    @property
    def triangles(self) -> int:
        return int(sum(len(f) for _, _, f, _ in self.meshes))

    def poses(self, q: np.ndarray) -> np.ndarray:
        """``(groups, 4, 4)`` world transforms of every group for the planned configuration ``q``."""
        q = np.asarray(q, dtype=np.float64)
        out = np.empty((len(self.names), 4, 4))
        out[0] = np.eye(4)
        for g in range(1, len(self.names)):          # groups are stored parents first
            T = out[self.parent[g]] @ self.origin[g]
            out[g] = T @ _joint_motion(self.kind[g], self.axis[g], float(q[self.slot[g]]))
        return out


def _joint_motion(kind: str, axis: np.ndarray, value: float) -> np.ndarray:
    M = np.eye(4)
    if kind == "prismatic":
        M[:3, 3] = axis * value
        return M
    x, y, z = axis / (np.linalg.norm(axis) or 1.0)
    c, s = np.cos(value), np.sin(value)
    C = 1.0 - c
    M[:3, :3] = [[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                 [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                 [z * x * C - y * s, z * y * C + x * s, c + z * z * C]]
    return M


def cache_dir() -> Path:
    """Where converted robots are kept: ``$XDG_CACHE_HOME/pliant/viewer``, else ``~/.cache/pliant/viewer``."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "pliant" / "viewer"


def resolve_file(fname: str, urdf: Path, package_dirs) -> Path | None:
    """Where a URDF's ``filename`` (``package://...``, ``file://...`` or relative) is on disk, or ``None``."""
    if fname.startswith("package://"):
        rest = fname[len("package://"):]
        for d in package_dirs:
            for candidate in (Path(d) / rest, Path(d).parent / rest):
                if candidate.exists():
                    return candidate
        return None
    if fname.startswith("file://"):
        fname = fname[len("file://"):]
    path = Path(fname) if Path(fname).is_absolute() else Path(urdf).parent / fname
    return path if path.exists() else None


def key(description, meshes: str) -> str:
    """A hash of what the conversion depends on (see the module's docstring)."""
    urdf = Path(description.urdf)
    data = urdf.read_bytes()
    h = hashlib.sha256(data)
    for fname in sorted(set(re.findall(rb'filename\s*=\s*"([^"]+)"', data))):
        path = resolve_file(fname.decode(), urdf, description.package_dirs)
        st = path.stat() if path is not None else None
        h.update(f"{fname.decode()}:{st.st_size if st else -1}:{st.st_mtime_ns if st else -1}".encode())
    h.update(json.dumps({"format": FORMAT, "meshes": meshes, "joints": list(description.joint_names),
                         "posture": {k: float(v) for k, v in sorted(description.posture.items())}}).encode())
    return h.hexdigest()[:32]


def load_or_convert(description, meshes: str = "collision", use_cache: bool = True) -> RobotMeshes:
    """The robot of a ``UrdfDescription``: from the disk cache when it is there, else converted (and cached)."""
    path = cache_dir() / f"robot-{key(description, meshes)}.npz" if use_cache else None
    if path is not None and path.is_file():
        try:
            return _read(path)
        except (OSError, ValueError, KeyError) as exc:
            log.info("robot mesh cache %s unreadable: %s", path, exc)
    robot = convert(description, meshes)
    if path is not None:
        _write(robot, path)
    return robot


def ensure_cached(description, meshes: str = "collision") -> Path:
    """Convert the robot's meshes into the disk cache unless they are there already; returns the cache file."""
    path = cache_dir() / f"robot-{key(description, meshes)}.npz"
    if not path.is_file():
        _write(convert(description, meshes), path)
    return path


def _read(path: Path) -> RobotMeshes:
    with np.load(path, allow_pickle=False) as data:
        a = {k: data[k] for k in data.files}
    meta = json.loads(str(a["meta"]))
    meshes = [(int(m["group"]), a[f"v{i}"], a[f"f{i}"], tuple(m["colour"])) for i, m in enumerate(meta["meshes"])]
    return RobotMeshes(meta["names"], a["parent"], a["slot"], meta["kind"], a["axis"], a["origin"], meshes)


def _write(robot: RobotMeshes, path: Path) -> None:
    arrays = {"parent": robot.parent, "slot": robot.slot, "axis": robot.axis, "origin": robot.origin}
    meta = {"names": robot.names, "kind": robot.kind, "meshes": []}
    for i, (g, v, f, colour) in enumerate(robot.meshes):
        arrays[f"v{i}"], arrays[f"f{i}"] = v, f
        meta["meshes"].append({"group": g, "colour": [int(c) for c in colour]})
    arrays["meta"] = np.array(json.dumps(meta))
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.npz")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(tmp, **arrays)
        os.replace(tmp, path)
    except OSError as exc:
        log.info("robot mesh cache not written to %s: %s", path, exc)
        tmp.unlink(missing_ok=True)


def _vertex_colours(mesh) -> np.ndarray:
    """``(n, 3)`` uint8 colours of a trimesh's vertices (a texture's main colour; grey when it has none)."""
    try:
        look = mesh.visual.to_color() if hasattr(mesh.visual, "to_color") else mesh.visual
        colours = np.asarray(look.vertex_colors)
        if colours.ndim == 2 and len(colours) == len(mesh.vertices) and colours.shape[1] >= 3:
            return colours[:, :3].astype(np.uint8)
    except (AttributeError, ValueError):
        pass
    return np.full((len(mesh.vertices), 3), 170, dtype=np.uint8)


def convert(description, meshes: str = "collision") -> RobotMeshes:
    """Load the URDF with yourdfpy at the robot's fixed posture (planned joints at zero) and group its meshes."""
    import trimesh
    import yourdfpy

    urdf_path = Path(description.urdf)

    def handler(fname: str) -> str:
        found = resolve_file(fname, urdf_path, description.package_dirs)
        return str(found) if found is not None else yourdfpy.filename_handler_magic(fname, dir=urdf_path.parent)

    visual = meshes == "visual"
    urdf = yourdfpy.URDF.load(str(urdf_path), build_scene_graph=visual, load_meshes=visual,
                              build_collision_scene_graph=not visual, load_collision_meshes=not visual,
                              filename_handler=handler)
    cfg = np.array([0.0 if n in description.joint_names else float(description.posture.get(n, 0.0))
                    for n in urdf.actuated_joint_names])
    urdf.update_cfg(cfg)
    scene = urdf.scene if visual else urdf.collision_scene
    base = scene.graph.base_frame

    def world(frame: str) -> np.ndarray:
        return np.asarray(urdf.get_transform(frame, base, collision_geometry=not visual), dtype=np.float64)

    # groups: the base, then every planned joint in the order of a walk from the root (parents first)
    planned = {name: i for i, name in enumerate(description.joint_names)}
    joint_of_child = {j.child: j for j in urdf.joint_map.values()}
    names, parent, slot, kind, axis, origin, child_link = ["base"], [-1], [-1], ["fixed"], [np.zeros(3)], \
        [np.eye(4)], [base]

    def group_of(link: str) -> int:
        chain = []
        while link in joint_of_child:
            j = joint_of_child[link]
            if j.name in planned:
                chain.append(j)
            link = j.parent
        g = 0
        for j in reversed(chain):                 # root first
            if j.name not in names:
                T = np.linalg.inv(world(child_link[g])) @ world(j.child)
                names.append(j.name)
                parent.append(g)
                slot.append(planned[j.name])
                kind.append("prismatic" if j.type == "prismatic" else "revolute")
                axis.append(np.asarray(j.axis if j.axis is not None else [1.0, 0.0, 0.0], dtype=np.float64))
                origin.append(T)
                child_link.append(j.child)
            g = names.index(j.name)
        return g

    parts: dict[tuple[int, tuple], list[tuple[np.ndarray, np.ndarray]]] = {}
    for node in scene.graph.nodes_geometry:
        T, geometry = scene.graph[node]
        mesh = scene.geometry[geometry]
        if type(mesh).__name__ == "Sphere":            # 1,280 faces each; 320 look the same at this size
            mesh = trimesh.creation.icosphere(subdivisions=2, radius=float(mesh.primitive.radius)) \
                .apply_transform(mesh.primitive.transform)
        link = scene.graph.transforms.parents.get(node, base)
        g = group_of(link)
        local = np.linalg.inv(world(child_link[g])) @ np.asarray(T, dtype=np.float64)
        v = np.asarray(mesh.vertices, dtype=np.float64) @ local[:3, :3].T + local[:3, 3]
        f = np.asarray(mesh.faces, dtype=np.uint32)
        if visual:
            colours = _vertex_colours(mesh)
            face_colour = colours[f[:, 0]]
            for c in np.unique(face_colour, axis=0):
                sel = np.all(face_colour == c, axis=1)
                parts.setdefault((g, tuple(int(x) for x in c)), []).append((v, f[sel]))
        else:
            parts.setdefault((g, COLLISION_COLOUR), []).append((v, f))
    out = []
    for (g, colour), pieces in sorted(parts.items()):
        vs, fs, n = [], [], 0
        for v, f in pieces:
            used, inverse = np.unique(f, return_inverse=True)         # drop vertices of other colours
            vs.append(v[used])
            fs.append(inverse.reshape(-1, 3).astype(np.uint32) + n)
            n += len(used)
        out.append((g, np.concatenate(vs).astype(np.float32), np.concatenate(fs), colour))
    return RobotMeshes(names, np.array(parent), np.array(slot), kind, np.array(axis), np.array(origin), out)
