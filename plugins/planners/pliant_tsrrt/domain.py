"""The planning domain built from a scene (the options shared by the ``tsrrt`` planner and the ``push-models`` learner
are in :mod:`pliant_tsrrt.options`).

The scene supplies: the movable objects (a ``mass``; those named in ``objects``, default all), their footprints
(boxes, and cylinders or spheres as circles) and start poses; the *table*, a ``[[regions]]`` entry named by the
``table`` option (default ``"table"``; without it the scene's bounds); the fixed obstacles (static objects whose
centre lies on the table, and movable objects that are not planned); the paddle (the scene's SE(2) rigid robot: its
first part, a box whose x extent is the paddle's thickness and y extent its width).
"""

from __future__ import annotations

import numpy as np
from pliant.api import ConfigError, PlanningError

from pliant_tsrrt.cost import TaskCost
from pliant_tsrrt.geometry import CollisionChecker, Footprints
from pliant_tsrrt.models import footprints_from_scene, scene_pose
from pliant_tsrrt.options import PushOptions, PushSettings


def push_settings(options: PushOptions, scene) -> PushSettings:
    """The :class:`PushSettings` of ``options``: its ``push`` group with the paddle's size read from the scene's
    robot."""
    thickness, width = paddle_size(scene)
    return PushSettings.from_options(options.push, thickness=thickness, width=width)


def paddle_size(scene) -> tuple[float, float]:
    """The paddle's thickness and width (m): the x and y extents of the robot's first part, a box."""
    robot = scene.robot
    if robot.kind != "rigid" or robot.space != "se2" or not robot.parts or robot.parts[0].part.shape.kind != "box":
        raise ConfigError("TS-RRT pushes with an SE(2) rigid robot whose first part is a box (the paddle)",
                          source=scene.source, field="robot.parts", value=robot.space or robot.kind)
    size = robot.parts[0].part.shape.size
    return float(size[0]), float(size[1])


def movable_names(scene, objects: tuple[str, ...] | list[str]) -> list[str]:
    """The planned objects: ``objects`` (checked to be movable scene objects) or every movable object."""
    movable = [o.name for o in scene.objects if o.movable]
    if not objects:
        if not movable:
            raise ConfigError("the scene has no movable objects (objects with a mass) to arrange",
                              source=scene.source, field="objects", value=[])
        return movable
    for name in objects:
        if name not in movable:
            raise ConfigError(f"not a movable object of the scene (movable: {', '.join(movable) or 'none'})",
                              source=scene.source, field="objects", value=name)
    return list(objects)


def table_rect(scene, region: str) -> tuple[float, float, float, float]:
    """The table ``(x0, y0, x1, y1)`` (m): the named region, or the scene's bounds."""
    for r in scene.regions:
        if r.name == region:
            return (float(r.lower[0]), float(r.lower[1]), float(r.upper[0]), float(r.upper[1]))
    return (float(scene.lower[0]), float(scene.lower[1]), float(scene.upper[0]), float(scene.upper[1]))


def bounds_rect(scene) -> tuple[float, float, float, float]:
    """The scene's bounds in the plane, ``(x0, y0, x1, y1)`` (m)."""
    return (float(scene.lower[0]), float(scene.lower[1]), float(scene.upper[0]), float(scene.upper[1]))


def obstacles(scene, names: list[str], table, inflate: float = 0.0) -> tuple[Footprints, np.ndarray, list[str]]:
    """Fixed obstacles: static objects whose centre lies on the table (grown by ``inflate`` m on every side: a
    simulator built from the scene's voxels, pymunk, sees them up to one voxel larger) and movable objects not in
    ``names``."""
    x0, y0, x1, y1 = table
    picked = []
    for obj in scene.objects:
        if obj.name in names:
            continue
        p = obj.part.pose.position
        if obj.movable or (x0 <= p[0] <= x1 and y0 <= p[1] <= y1):
            picked.append(obj.name)
    if not picked:
        return Footprints(np.zeros(0, dtype=np.int64), np.zeros((0, 2))), np.zeros((0, 3)), []
    fp = footprints_from_scene(scene, picked)
    static = np.array([not scene.object(n).movable for n in picked])
    half = fp.half + np.where(static, inflate, 0.0)[:, None]
    return Footprints(fp.kind, half), np.array([scene_pose(scene, n) for n in picked]), picked


#: overlaps and excursions beyond the table up to this depth (m) count as touching, not as bad input
SCENE_TOLERANCE = 1e-6


def penetration(pa: np.ndarray, ka: int, ha: np.ndarray, pb: np.ndarray, kb: int, hb: np.ndarray) -> float:
    """How deep two footprints overlap (m; <= 0: they do not): the least translation that separates them.  Poses
    ``(3,)`` (x, y, theta), kinds :data:`~pliant_tsrrt.geometry.BOX` / ``CIRCLE``, half extents ``(2,)``.  Two boxes:
    the least overlap along their four face normals (the separating-axis theorem, exact for rectangles); a box and a
    circle: the circle's reach past the box's nearest point (or, centre inside, past its nearest face); two circles:
    the sum of the radii less the centres' distance."""
    from pliant_tsrrt.geometry import BOX, CIRCLE

    if ka == CIRCLE and kb == CIRCLE:
        return float(ha[0] + hb[0] - np.hypot(*(pa[:2] - pb[:2])))
    if ka == CIRCLE and kb == BOX:
        pa, ka, ha, pb, kb, hb = pb, kb, hb, pa, ka, ha
    if kb == CIRCLE:                                   # a box, b circle
        d = pb[:2] - pa[:2]
        c, s = np.cos(pa[2]), np.sin(pa[2])
        local = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
        if np.all(np.abs(local) <= ha):
            return float(hb[0] + np.min(ha - np.abs(local)))
        return float(hb[0] - np.linalg.norm(local - np.clip(local, -ha, ha)))
    depth = np.inf
    d = pb[:2] - pa[:2]
    for axis_pose in (pa, pb):
        c, s = np.cos(axis_pose[2]), np.sin(axis_pose[2])
        for n in (np.array([c, s]), np.array([-s, c])):
            reach = 0.0
            for pose, half in ((pa, ha), (pb, hb)):
                u = np.array([np.cos(pose[2]), np.sin(pose[2])])
                v = np.array([-np.sin(pose[2]), np.cos(pose[2])])
                reach += half[0] * abs(n @ u) + half[1] * abs(n @ v)
            depth = min(depth, reach - abs(n @ d))
    return float(depth)


def placing_simulator(world, *, required: bool = True):
    """``world`` if it can place objects (push models are learned by placing an object and pushing it: pymunk can,
    the kinematic simulator and pybullet cannot), else a :class:`PlanningError`; with ``required`` false (a component
    being bound to a context without a simulator yet) a missing world is let through as None."""
    if world is None and not required:
        return None
    if world is None or not getattr(world, "can_place_objects", False):
        raise PlanningError("learning push models needs a simulator that can place objects (pymunk)",
                            field="simulator", value=type(world).__name__ if world is not None else None)
    return world


def check_scene(scene, options: PushOptions) -> None:
    """Refuse a scene TS-RRT cannot read as a planar table, with a :class:`ConfigError` naming the object (field
    ``objects[i].orientation`` or ``objects[i].position``): an object on the table (every movable object, and every
    fixed one whose centre lies on the table) rotated out of the plane (a quaternion that is not a turn about z: its
    footprint would not be the box or circle TS-RRT plans with); a movable object that reaches off the table at its
    scene pose; two such objects that overlap at their scene poses (by more than :data:`SCENE_TOLERANCE`).  The
    simulator starts from the scene's poses (learning, execution), so such a start is bad input, not a planning
    failure; it is refused before any model is learned."""
    table = table_rect(scene, options.table)
    x0, y0, x1, y1 = table
    index = {obj.name: k for k, obj in enumerate(scene.objects)}
    movable = [o.name for o in scene.objects if o.movable]
    on_table = movable + [o.name for o in scene.objects if not o.movable
                          and x0 <= o.part.pose.position[0] <= x1 and y0 <= o.part.pose.position[1] <= y1]
    for name in on_table:
        q = scene.object(name).part.pose.orientation
        if abs(q[0]) > 1e-9 or abs(q[1]) > 1e-9:
            raise ConfigError(f"object '{name}' is rotated out of the table's plane: TS-RRT's objects turn about z "
                              "only (orientation [0, 0, sin(yaw/2), cos(yaw/2)])", source=scene.source,
                              field=f"objects[{index[name]}].orientation", value=[float(v) for v in q])
    fp = footprints_from_scene(scene, on_table)
    poses = np.array([scene_pose(scene, n) for n in on_table])
    from pliant_tsrrt.geometry import extents

    lo, hi = extents(poses, fp)
    for j, name in enumerate(movable):
        beyond = max(x0 - lo[j, 0], y0 - lo[j, 1], hi[j, 0] - x1, hi[j, 1] - y1)
        if beyond > SCENE_TOLERANCE:
            raise ConfigError(f"object '{name}' reaches {1000 * beyond:.1f} mm off the table ({x0:g}, {y0:g}) .. "
                              f"({x1:g}, {y1:g}) m at the start: its footprint spans x {lo[j, 0]:.4g} .. "
                              f"{hi[j, 0]:.4g}, y {lo[j, 1]:.4g} .. {hi[j, 1]:.4g} m", source=scene.source,
                              field=f"objects[{index[name]}].position",
                              value=[float(v) for v in scene.object(name).part.pose.position])
    for i in range(len(movable)):
        for j in range(i + 1, len(on_table)):
            depth = penetration(poses[i], int(fp.kind[i]), fp.half[i], poses[j], int(fp.kind[j]), fp.half[j])
            if depth > SCENE_TOLERANCE:
                a, b = on_table[i], on_table[j]
                what = "objects" if j < len(movable) else "object and fixed obstacle"
                raise ConfigError(f"{what} '{a}' and '{b}' overlap by {1000 * depth:.1f} mm at the start",
                                  source=scene.source, field=f"objects[{index[b]}].position",
                                  value=[float(v) for v in scene.object(b).part.pose.position])


def start_conflicts(check: CollisionChecker, state: np.ndarray, names: list[str],
                    obstacle_names: list[str] | None = None) -> str:
    """In words, why arrangement ``state`` ``(k, 3)`` of the objects ``names`` fails ``check`` (its margin
    included): the objects too close to the table's edge and the pairs too close (the fixed obstacles named by
    ``obstacle_names``, in the checker's order), by name."""
    state = np.asarray(state, dtype=np.float64)[None]
    out = [f"'{names[k]}' too close to the table's edge" for k in np.nonzero(check.off_table(state)[0])[0]]
    i, j = np.triu_indices(len(names), 1)
    out += [f"'{names[a]}' and '{names[b]}' too close" for a, b, hit in
            zip(i, j, check.object_pairs(state)[0]) if hit]
    oi, mi = check._obs_pairs
    out += [f"'{names[a]}' and '{obstacle_names[m]}' too close" if obstacle_names else
            f"'{names[a]}' too close to a fixed obstacle"
            for a, m, hit in zip(oi, mi, check.obstacle_pairs(state)[0]) if hit]
    return "; ".join(dict.fromkeys(out))


def parse_relations(relations: tuple[str, ...], names: list[str]) -> np.ndarray:
    """``"a b dx dy"`` strings (object a's centre at ``(dx, dy)`` m from object b's; b may be ``table``) as rows
    ``(index a, index b or -1, dx, dy)``; relations naming objects that are not planned are an error."""
    rows = []
    for k, text in enumerate(relations):
        parts = str(text).split()
        where = f"relations[{k}]"
        if len(parts) != 4:
            raise ConfigError("a relation is 'object reference dx dy' (reference: an object or 'table'; m)",
                              field=where, value=text)
        a, b = parts[0], parts[1]
        for who in (a,) + ((b,) if b != "table" else ()):
            if who not in names:
                raise ConfigError(f"names no planned object (planned: {', '.join(names)})", field=where, value=who)
        try:
            dx, dy = float(parts[2]), float(parts[3])
        except ValueError:
            raise ConfigError("the offset must be two numbers (m)", field=where, value=text) from None
        rows.append((names.index(a), -1 if b == "table" else names.index(b), dx, dy))
    return np.array(rows, dtype=np.float64).reshape(-1, 4)


def task_cost(fp: Footprints, table, weights, relations: np.ndarray, setting_scale: float) -> TaskCost:
    """The :class:`TaskCost` of arrangements of the objects ``fp`` on ``table`` (``weights``: ``(w_orth, w_area,
    w_edge, w_setting)``; ``relations``: rows of :func:`parse_relations`; ``setting_scale`` in m)."""
    return TaskCost(fp, table, tuple(weights), relations, setting_scale)


def checker(fp: Footprints, obs: Footprints, obs_poses: np.ndarray, table, margin: float) -> CollisionChecker:
    """The :class:`CollisionChecker` of the objects ``fp`` among the fixed obstacles ``obs`` at ``obs_poses`` on
    ``table``, with ``margin`` (m) of clearance."""
    return CollisionChecker(fp, obs, obs_poses, table, margin)
