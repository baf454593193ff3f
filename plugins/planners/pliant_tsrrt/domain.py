"""Options shared by the ``tsrrt`` planner and the ``push-models`` learner, and the planning domain built from a scene.

The scene supplies: the movable objects (a ``mass``; those named in ``objects``, default all), their footprints
(boxes, and cylinders or spheres as circles) and start poses; the *table*, a ``[[regions]]`` entry named by the
``table`` option (default ``"table"``; without it the scene's bounds); the fixed obstacles (static objects whose
centre lies on the table, and movable objects that are not planned); the paddle (the scene's SE(2) rigid robot: its
first part, a box whose x extent is the paddle's thickness and y extent its width).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.errors import ConfigError
from pliant.options import option

from pliant_tsrrt.cost import TaskCost
from pliant_tsrrt.geometry import CollisionChecker, Footprints
from pliant_tsrrt.models import footprints_from_scene, scene_pose
from pliant_tsrrt.pushing import PushSettings


@dataclass(frozen=True)
class PushOptions:
    """Options of the objects, the table and the pushes (shared by the planner and the learner)."""

    objects: tuple[str, ...] = option((), "the movable objects to plan for / learn from, by scene name (default all)")
    table: str = option("table", "the scene region (by name) that is the table top; without it the scene's bounds")
    push_gap: float = option(0.02, "paddle's distance behind the contact point before a push (m)", minimum=0.0)
    push_depth: float = option(0.05, "how far the paddle travels beyond the contact point (m)", minimum=1e-3)
    turn_depth: float = option(0.015, "how far the paddle travels beyond the contact point in a turning push (m)",
                               minimum=1e-3)
    push_speed: float = option(0.1, "paddle speed during a push (m/s)", minimum=1e-3)
    retreat: float = option(0.02, "paddle's back-off after a push (m)", minimum=0.0)
    settle: float = option(0.2, "time at rest after a push before the objects are observed (s)", minimum=0.0)
    turn_offset: float = option(1.0, "where turning pushes press, as a fraction of the half side from the middle",
                                minimum=0.0, maximum=1.0)
    placement_noise: float = option(0.0, "standard deviation of the paddle's placement error, along and across the "
                                    "push (m): execution noise besides the simulator's actuation noise", minimum=0.0)
    control_period: float = option(0.05, "period of the paddle's velocity commands (s)", minimum=1e-3)
    guard_step: float = option(0.001, "guarded approach: the paddle advances in steps of this length (m) until the "
                               "object moves, then pushes the depth from there; 0 for a blind push of gap + depth",
                               minimum=0.0, maximum=0.01)

    def push_settings(self, scene) -> PushSettings:
        """The :class:`PushSettings` with the paddle's size read from the scene's robot."""
        thickness, width = paddle_size(scene)
        return PushSettings(thickness=thickness, width=width, gap=self.push_gap, depth=self.push_depth,
                            turn_depth=self.turn_depth, speed=self.push_speed, retreat=self.retreat, settle=self.settle,
                            turn_offset=self.turn_offset, dt=self.control_period,
                            placement_noise=self.placement_noise, guard=self.guard_step)


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
    return TaskCost(fp, table, tuple(weights), relations, setting_scale)


def checker(fp: Footprints, obs: Footprints, obs_poses: np.ndarray, table, margin: float) -> CollisionChecker:
    return CollisionChecker(fp, obs, obs_poses, table, margin)
