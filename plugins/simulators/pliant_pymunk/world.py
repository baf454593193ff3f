"""Building a pymunk space from a planar pliant scene.

Static geometry comes from the scene's voxel grid (one layer) of its static objects, merged into few
exact boxes (:meth:`pliant.geometry.voxelgrid.VoxelGrid.boxes`), so boxes, cut-outs, cylinders and meshes are all
represented, exactly at the scene's resolution.  Movable objects are bodies (:mod:`.objects`).  The
robot is a dynamic body made of its parts' boxes and circles.
"""

from __future__ import annotations

import numpy as np
from pliant.api import FREE_VOXEL as FREE
from pliant.api import Scene, SimulationError, VoxelGrid

_QUARTER_TURN_TOL = 1e-9


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
    """pymunk shapes of the robot (in the robot frame), attached to ``body``.

    A robot made of axis-aligned boxes (in its own frame) is one rectilinear polygon, split into convex
    pieces along diagonals between its own vertices (:func:`rectilinear_outline`, then pymunk's convex
    decomposition).  Its parts as separate boxes would be wrong: where two boxes meet along a face (the
    L-block's arms), each box's corner on that face is a *ghost corner* pymunk collides like a real one —
    the L-block jammed against a wall's end in se2-maze, its arm's ghost corner caught on the wall's top
    (contact normal (0, -1)) while the face it lies on should slide past.  Other robots (rotated boxes,
    circles) are their parts' shapes.
    """
    outline = rectilinear_outline(scene)
    if outline is not None:
        shapes = []
        from pymunk.autogeometry import convex_decomposition

        for piece in convex_decomposition(outline + [outline[0]], 0.0):
            shape = pymunk.Poly(body, [tuple(v) for v in piece[:-1]])
            shape.friction = friction
            shapes.append(shape)
        return shapes
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


def rectilinear_outline(scene: Scene) -> list[tuple[float, float]] | None:
    """The outline of the union of the robot's box parts, counter-clockwise without collinear vertices, when
    every part is a box aligned with the robot frame (rotations by multiples of 90 degrees about z) and the
    union is one polygon without holes; else ``None``.

    Exact: the parts' edges cut the plane into cells (coordinate compression), a cell is inside when its
    centre is inside a part, and the boundary is the cells' sides between inside and outside.
    """
    boxes = []
    for rp in scene.robot.parts:
        part = rp.part
        if part.shape.kind != "box" or part.cutouts:
            return None
        q = part.pose.orientation
        angle = 2 * np.arctan2(q[2], q[3])
        turns = angle / (np.pi / 2)
        if abs(q[0]) > 1e-9 or abs(q[1]) > 1e-9 or abs(turns - round(turns)) > _QUARTER_TURN_TOL:
            return None
        hx, hy = part.shape.size[0] / 2, part.shape.size[1] / 2
        if round(turns) % 2:
            hx, hy = hy, hx
        cx, cy = part.pose.position[0], part.pose.position[1]
        boxes.append((cx - hx, cy - hy, cx + hx, cy + hy))
    if not boxes:
        return None
    xs = np.unique(np.round([b[0] for b in boxes] + [b[2] for b in boxes], 12))
    ys = np.unique(np.round([b[1] for b in boxes] + [b[3] for b in boxes], 12))
    mx, my = (xs[:-1] + xs[1:]) / 2, (ys[:-1] + ys[1:]) / 2
    inside = np.zeros((len(mx), len(my)), dtype=bool)
    for x0, y0, x1, y1 in boxes:
        inside |= ((mx > x0) & (mx < x1))[:, None] & ((my > y0) & (my < y1))[None, :]
    padded = np.pad(inside, 1)
    edges = {}
    for i, j in zip(*np.nonzero(inside)):
        a, b = i + 1, j + 1                      # indices into padded
        # counter-clockwise sides of cell (i, j) whose neighbour is outside: start vertex -> end vertex
        if not padded[a, b - 1]:
            edges[(i, j)] = (i + 1, j)
        if not padded[a + 1, b]:
            edges[(i + 1, j)] = (i + 1, j + 1)
        if not padded[a, b + 1]:
            edges[(i + 1, j + 1)] = (i, j + 1)
        if not padded[a - 1, b]:
            edges[(i, j + 1)] = (i, j)
    if not edges:
        return None
    start = next(iter(edges))
    loop, v = [start], edges[start]
    while v != start:
        if v not in edges or len(loop) > len(edges):
            return None                           # touching corners: not a simple polygon
        loop.append(v)
        v = edges[v]
    if len(loop) != len(edges):
        return None                               # holes or several pieces
    points = [(float(xs[i]), float(ys[j])) for i, j in loop]
    keep = []
    for k, p in enumerate(points):
        prev, nxt = points[k - 1], points[(k + 1) % len(points)]
        cross = (p[0] - prev[0]) * (nxt[1] - p[1]) - (p[1] - prev[1]) * (nxt[0] - p[0])
        if abs(cross) > 1e-15:
            keep.append(p)
    return keep
