"""A run folder's view, kept beside it (``view-cache.npz``) so that the next ``pliant view out/<name>/`` draws at once.

For an articulated robot most of the time to a first frame is the robot model (pinocchio) and the first call of its
kinematics, which place the path, the trajectory and the policy's particles in 3-D.  The cache holds what they
produced: the voxel objects' meshes, every placed point, the policy tree's arrays and the robot's URDF description,
so a cached view needs no robot model at all (the page poses the URDF from joint values).  Rigid robots are cheap to
build and are not cached.

The file holds arrays and JSON only (read with ``allow_pickle=False``).  It is used when its key matches: the format,
the scene's name, variant and file, and the size and modification time of ``run.json``, ``result.json`` and
``execution.json``; otherwise the view is built again and the cache rewritten.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path

import numpy as np
from pliant.api import UrdfDescription

from pliant_viewer import content
from pliant_viewer.viewer import Timeline, ViewContent

log = logging.getLogger(__name__)

FORMAT = 2              # 2: voxel faces wound to face out
NAME = "view-cache.npz"


def key(folder: Path, scene, max_particles: int) -> str:
    """The cache key of the run ``folder`` (a JSON string): the format, the scene's name, variant and file, the size and
    modification time of the run's JSON files, and ``max_particles``."""
    files = {}
    for name in ("run.json", "result.json", "execution.json"):
        path = Path(folder) / name
        if path.is_file():
            st = path.stat()
            files[name] = [st.st_size, st.st_mtime_ns]
    source = Path(str(scene.source))
    scene_file = [str(source), source.stat().st_mtime_ns] if source.is_file() else [str(scene.source)]
    return json.dumps({"format": FORMAT, "scene": [scene.name, scene.variant, scene_file], "files": files,
                       "max_particles": max_particles}, sort_keys=True)


def save(view: ViewContent, folder: Path, max_particles: int = 50_000) -> Path | None:
    """Write the view's cache into ``folder``; ``None`` (logged) when it cannot be written."""
    arrays: dict[str, np.ndarray] = {"ends": view.ends}
    meta: dict = {"key": key(folder, view.scene, max_particles), "title": view.title, "notes": view.notes,
                  "articulated": view.articulated, "objects": [], "pareto": [], "urdf": None}
    for i, obj in enumerate(view.objects):
        meta["objects"].append({"name": obj.name, "total": obj.total, "deformability": obj.deformability,
                                "sensitivity": obj.sensitivity})
        for field in ("centres", "colours", "vertices", "faces", "vertex_colours"):
            arrays[f"object{i}_{field}"] = getattr(obj, field)
    for name in ("path", "path_xyz", "timeline_xyz"):
        if getattr(view, name) is not None:
            arrays[name] = getattr(view, name)
    if view.trajectory is not None:
        arrays["timeline_times"] = view.trajectory.times
        arrays["timeline_configurations"] = view.trajectory.configurations
        meta["timeline_label"] = view.trajectory.label
    if view.tree is not None:
        for field in ("nodes", "edges", "particles", "particle_node", "probability", "solution_nodes",
                      "action_targets"):
            arrays[f"tree_{field}"] = getattr(view.tree, field)
    for i, front in enumerate(view.pareto):
        arrays[f"pareto{i}"] = front["points"]
        meta["pareto"].append({k: v for k, v in front.items() if k != "points"})
    if view.urdf is not None:
        u = view.urdf
        meta["urdf"] = {"urdf": str(u.urdf), "package_dirs": [str(d) for d in u.package_dirs],
                        "joint_names": list(u.joint_names), "posture": dict(u.posture),
                        "velocity_limits": np.asarray(u.velocity_limits).tolist(),
                        "effort_limits": np.asarray(u.effort_limits).tolist()}
    arrays["meta"] = np.array(json.dumps(meta))
    path = Path(folder) / NAME
    tmp = path.with_name(f".{NAME}.{os.getpid()}.tmp.npz")
    try:
        np.savez(tmp, **arrays)
        os.replace(tmp, path)
    except OSError as exc:
        log.info("view cache not written to %s: %s", path, exc)
        tmp.unlink(missing_ok=True)
        return None
    return path


def load(folder: Path, scene, max_particles: int = 50_000) -> ViewContent | None:
    """The cached view of the run in ``folder`` drawn on ``scene``, or ``None`` when there is none or it is stale."""
    path = Path(folder) / NAME
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            a = {k: data[k] for k in data.files}
        meta = json.loads(str(a["meta"]))
    except (OSError, ValueError, KeyError) as exc:
        log.info("view cache %s unreadable: %s", path, exc)
        return None
    if meta.get("key") != key(folder, scene, max_particles):
        return None
    objects = [content.VoxelObject(m["name"], a[f"object{i}_centres"], a[f"object{i}_colours"], m["total"],
                                   m["deformability"], m["sensitivity"], a[f"object{i}_vertices"],
                                   a[f"object{i}_faces"], a[f"object{i}_vertex_colours"])
               for i, m in enumerate(meta["objects"])]
    view = ViewContent(scene, None, None, objects, title=meta["title"], notes=list(meta["notes"]),
                       ends=a["ends"], articulated=bool(meta["articulated"]))
    view.path = a.get("path")
    view.path_xyz = a.get("path_xyz")
    view.timeline_xyz = a.get("timeline_xyz")
    if "timeline_times" in a:
        view.trajectory = Timeline(a["timeline_times"], a["timeline_configurations"], meta["timeline_label"])
    if "tree_nodes" in a:
        view.tree = content.Tree(*(a[f"tree_{f}"] for f in ("nodes", "edges", "particles", "particle_node",
                                                             "probability", "solution_nodes", "action_targets")))
    view.pareto = [dict(m, points=a[f"pareto{i}"]) for i, m in enumerate(meta["pareto"])]
    u = meta.get("urdf")
    if u is not None:
        view.urdf = UrdfDescription(urdf=u["urdf"], package_dirs=tuple(u["package_dirs"]),
                                    joint_names=tuple(u["joint_names"]), posture=dict(u["posture"]),
                                    velocity_limits=np.asarray(u["velocity_limits"]),
                                    effort_limits=np.asarray(u["effort_limits"]))
    return view
