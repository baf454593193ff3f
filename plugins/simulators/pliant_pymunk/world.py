"""Building a pymunk space from a planar pliant scene.

Static geometry comes from the scene's voxel grid (one layer) of its static objects, merged into few
exact boxes (:meth:`pliant.voxelgrid.VoxelGrid.boxes`), so boxes, cut-outs, cylinders and meshes are all
represented, exactly at the scene's resolution.  Movable objects are bodies (:mod:`.objects`).  The
robot is a dynamic body made of its parts' boxes and circles.
"""

from __future__ import annotations

import numpy as np
from pliant.errors import SimulationError
from pliant.scene import Scene
from pliant.voxelgrid import FREE, VoxelGrid


def check_planar(scene: Scene) -> None:
    """Raise :class:`SimulationError` unless the scene and its robot are planar (a 2-D backend)."""
    if not scene.planar or scene.shape[2] != 1:
        raise SimulationError("pymunk is a 2-D backend: the scene must be planar (planar = true, one voxel layer)",
                              source=scene.source, field="planar", value=scene.planar)
    if scene.robot.kind != "rigid" or scene.robot.space != "se2":
        raise SimulationError("pymunk simulates SE(2) rigid robots only", source=scene.source, field="robot.space",
                              value=scene.robot.space or scene.robot.kind)


def static_rectangles(grid: VoxelGrid) -> list[tuple[float, float, float, float]]:
    """The occupied voxels of the single layer as ``(x0, y0, x1, y1)`` rectangles (exact, few)."""
    return [(lo[0], lo[1], hi[0], hi[1]) for lo, hi in grid.boxes()]


#: thickness of the walls that close the scene's bounds (m)
BOUNDARY_THICKNESS = 1.0


def boundary_rectangles(grid: VoxelGrid) -> list[tuple[float, float, float, float]]:
    """Four rectangles just outside the grid's ``(x, y)`` bounds, overlapping at the corners.

    The voxel cost and the kinematic simulator treat everything outside the grid as solid; without these
    a body could leave the scene where free space reaches its edge (se2-maze's corridors span the full
    width) and the dynamic world would differ from the planner's.
    """
    x0, y0 = grid.lower[0], grid.lower[1]
    x1, y1 = x0 + grid.shape[0] * grid.resolution, y0 + grid.shape[1] * grid.resolution
    t = BOUNDARY_THICKNESS
    return [(x0 - t, y0 - t, x1 + t, y0), (x0 - t, y1, x1 + t, y1 + t),
            (x0 - t, y0, x0, y1), (x1, y0, x1 + t, y1)]


def static_walls(scene: Scene, default_friction: float) -> list[tuple[float, tuple[float, float, float, float]]]:
    """The static objects' voxels as ``(friction, (x0, y0, x1, y1))`` rectangles, and walls closing the
    scene's bounds (:func:`boundary_rectangles`, with ``default_friction``).

    Movable objects are left out (they are bodies).  Objects with the same friction (their own, else
    ``default_friction``) are merged together, so a scene without per-object friction gives the same few
    boxes as its whole voxel layer.
    """
    grid = VoxelGrid.from_scene(scene, static_only=True)
    friction = np.array([default_friction if o.friction is None else o.friction for o in scene.objects])
    walls = []
    for mu in sorted(set(friction[[not o.movable for o in scene.objects]].tolist())):
        ids = np.nonzero(friction == mu)[0]
        mask = np.isin(grid.object_id, ids)
        sub = VoxelGrid(grid.lower, grid.resolution, grid.deformability, grid.sensitivity,
                        np.where(mask, grid.object_id, FREE).astype(np.int32), grid.object_names)
        walls.extend((mu, r) for r in static_rectangles(sub))
    walls.extend((float(default_friction), r) for r in boundary_rectangles(grid))
    return walls


def robot_shapes(scene: Scene, pymunk, body, friction: float):
    """pymunk shapes of the robot's parts (boxes and circles, in the robot frame), attached to ``body``."""
    shapes = []
    for k, rp in enumerate(scene.robot.parts):
        part = rp.part
        if part.cutouts:
            raise SimulationError("robot parts with cut-outs cannot be represented in pymunk", source=scene.source,
                                  field=f"robot.parts[{k}].cutouts")
        q = part.pose.orientation
        if abs(q[0]) > 1e-9 or abs(q[1]) > 1e-9:
            raise SimulationError("a planar robot's parts may only rotate about z", source=scene.source,
                                  field=f"robot.parts[{k}].orientation", value=q.tolist())
        angle = 2 * np.arctan2(q[2], q[3])
        centre = tuple(part.pose.position[:2])
        kind = part.shape.kind
        if kind == "box":
            hx, hy = part.shape.size[0] / 2, part.shape.size[1] / 2
            c, s = np.cos(angle), np.sin(angle)
            corners = [(centre[0] + c * x - s * y, centre[1] + s * x + c * y)
                       for x, y in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))]
            shape = pymunk.Poly(body, corners)
        elif kind in ("sphere", "cylinder"):
            shape = pymunk.Circle(body, part.shape.radius, centre)
        else:
            raise SimulationError(f"robot part shape '{kind}' cannot be represented in pymunk", source=scene.source,
                                  field=f"robot.parts[{k}].shape", value=kind)
        shape.friction = friction
        shapes.append(shape)
    return shapes
