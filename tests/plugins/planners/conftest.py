"""Shared by the planner tests: hollow shells (thesis 4.3.4) and an independent fine sweep of a returned path."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import Context, PlanningProblem
from pliant.registry import create
from pliant.scene import Scene
from scipy import ndimage

SHELL_RES = 0.05


def shell_problem(thickness: int, rng: np.random.Generator, space: str = "r3",
                  goal_inside: bool = False) -> PlanningProblem:
    """A soft, barely sensitive hollow cube with walls ``thickness`` voxels thick, placed and sized off the grid
    (offsets drawn from ``rng``), between a start and a goal diagonally past it: straight through is the cheapest
    path with a length weight, and it opens the void.  The robot: a 4 cm cube (``r3``: one body point) or a
    14 cm bar (``se3``: three body points along it, so it sweeps arcs when it turns).  ``goal_inside``: the goal
    is the middle of the void instead, which no path reaches without opening it."""
    centre = 0.35 + rng.uniform(-0.5, 0.5) * SHELL_RES
    outer = 0.15 + 2 * thickness * SHELL_RES + rng.uniform(-0.5, 0.5) * SHELL_RES
    inner = outer - 2 * thickness * SHELL_RES + rng.uniform(-0.3, 0.3) * SHELL_RES
    start, goal = [0.07, 0.07, 0.35], ([centre] * 3 if goal_inside else [0.63, 0.63, 0.35])
    robot = {"kind": "rigid", "space": space, "parts": [{"shape": "box", "size": [0.04, 0.04, 0.04]}]}
    if space == "se3":
        robot["parts"] = [{"shape": "box", "size": [0.14, 0.03, 0.03]}]
        start, goal = start + [0.0, 0.0, 0.0, 1.0], goal + [0.0, 0.0, 0.0, 1.0]
    scene = Scene.from_dict({
        "name": f"shell-{thickness}", "start": start, "goal": goal, "goal_tolerance": 0.06,
        "bounds": {"lower": [0, 0, 0], "upper": [0.7, 0.7, 0.7], "resolution": SHELL_RES},
        "objects": [{"name": "shell", "shape": "box", "size": [outer] * 3, "position": [centre] * 3,
                     "deformability": 0.5, "sensitivity": 0.001,
                     "cutouts": [{"shape": "box", "size": [inner] * 3, "position": [centre] * 3}]}],
        "robot": robot,
    })
    ctx = Context(scene=scene)
    ctx.robot = create("robot", "rigid", ctx)
    ctx.cost = create("cost", "voxel", ctx)
    return PlanningProblem.from_context(ctx)


def fine_sweep_damage(problem: PlanningProblem, path: np.ndarray, fraction: float = 0.1) -> list[str]:
    """What the path does to the scene's objects when swept finely, independently of ``PunctureChecker``.

    Every segment of ``path`` is interpolated (the space's own interpolation) until no body point moves more than
    ``fraction`` of a voxel between samples; the voxels holding a sample of a body point are removed from every
    object; then, with scipy's labelling alone (26-connected object, 6-connected background), each of an object's
    voids must still be closed and distinct, and no piece of it may fall apart.  Returns one line per damage."""
    grid = VoxelGrid.from_scene(problem.scene)
    space, robot, res = problem.space, problem.robot, grid.resolution
    touched = []
    for a, b in itertools.pairwise(np.atleast_2d(path)):
        n = 8
        while True:
            t = np.linspace(0.0, 1.0, n + 1)[:, None]
            pts = robot.body_points(space.interpolate(np.repeat(a[None], n + 1, 0), np.repeat(b[None], n + 1, 0), t))
            if np.max(np.linalg.norm(np.diff(pts, axis=0), axis=-1), initial=0.0) <= fraction * res:
                break
            n *= 2
        touched.append(np.floor((pts.reshape(-1, 3) - grid.lower) / res).astype(np.int64))
    cells = np.unique(np.concatenate(touched), axis=0)
    cells = cells[np.all((cells >= 0) & (cells < np.array(grid.shape)), axis=1)]
    damage = []
    for k, name in enumerate(grid.object_names):
        before = np.pad(grid.object_id == k, 1)
        after = before.copy()
        after[tuple((cells + 1).T)] = False
        background, _ = ndimage.label(~before)
        voids = [v for v in np.unique(background) if v not in (0, background[0, 0, 0])]
        now, _ = ndimage.label(~after)
        labels = [set(np.unique(now[background == v]).tolist()) for v in voids]
        if any(now[0, 0, 0] in s for s in labels):
            damage.append(f"{name}: a void opened")
        elif len(set().union(*labels)) < len(voids) if labels else False:
            damage.append(f"{name}: two voids joined")
        pieces, n_pieces = ndimage.label(before, structure=np.ones((3, 3, 3)))
        remaining, _ = ndimage.label(after, structure=np.ones((3, 3, 3)))
        for p in range(1, n_pieces + 1):
            if len(np.unique(remaining[(pieces == p) & after])) > 1:
                damage.append(f"{name}: cut")
                break
    return damage


@pytest.fixture
def shells():
    """The helpers above: ``shells.problem(thickness, rng, space)``, ``shells.damage(problem, path)``."""
    class Shells:
        problem = staticmethod(shell_problem)
        damage = staticmethod(fine_sweep_damage)
    return Shells
