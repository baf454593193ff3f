"""Property (issue 31): on random small scenes with obstacles, every planner of the registry that plans a path in the
scene's space returns, whenever it reports success, a path that an independent brute-force sweep finds
collision-free at every 1/10 voxel of body-point motion.

The sweep is written here, apart from :mod:`pliant.planning.validity`: it interpolates each segment of the returned
path so finely that no body point moves more than a tenth of a voxel between two checked states, asks the robot for
its body points (``body_points``, not the checker's rigid shortcut) and looks each one up in a fresh voxel grid
with the material rule of eq. 3.1 (a rigid point in a rigid voxel, any point in a forbidden object, or a point
outside the workspace collides).  A point within 1e-6 of a voxel face is not inside that voxel (touching is free).
Budgets are iteration counts, never time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st
from pliant import Pipeline, registry
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import PlanningProblem
from pliant.scene import Scene

RES = 0.1
#: every path planner of the registry with a small iteration budget (None: no budget option); each entry says
#: whether it needs a cost model (the others get the voxel cost or none, at random) and the robot spaces it plans in
PLANNERS = {
    "straight": ({"step": 0.05}, False, ("r3", "se2")),
    "waypoints": ({}, False, ("r3", "se2")),                      # its waypoints are drawn per example
    "rrtstar": ({"max_time": None, "max_iterations": 150, "max_step": 0.3}, False, ("r3", "se2")),
    "trrt": ({"max_time": None, "max_iterations": 150, "max_step": 0.3}, False, ("r3", "se2")),
    "gradient-trrt": ({"max_time": None, "max_iterations": 100, "max_step": 0.3}, True, ("r3", "se2")),
    "belief": ({"mode": "simple", "max_time": None, "max_iterations": 150, "max_step": 0.5}, False, ("r3", "se2")),
    "astar": ({}, True, ("r3",)),
    "astar-pareto": ({"values": 3}, True, ("r3",)),
    "ompl": ({"algorithm": "RRTConnect"}, False, ("r3", "se2")),   # budgeted by the request (REQUEST_BUDGETS)
}
#: planners budgeted by the request ([planning]) rather than by an option
REQUEST_BUDGETS = {"ompl": {"max_iterations": 300}}
#: planners that do not plan a robot path in the scene's space: TS-RRT plans pushes of objects (its path lists the
#: paddle's poses before each push, which the pushes and repositionings connect)
NOT_PATH_PLANNERS = {"tsrrt"}


def test_every_registered_planner_is_covered_or_named_as_not_a_path_planner():
    assert set(registry.available("planner")) == set(PLANNERS) | NOT_PATH_PLANNERS


@st.composite
def worlds(draw):
    """A scene dict: a 1 x 1 m world (planar for SE(2), 4 voxels high for R^3), 3-7 box obstacles of random material,
    a box robot of 1-3 points per axis."""
    space = draw(st.sampled_from(["r3", "se2"]))
    planar = space == "se2"
    nz = 1 if planar else 4
    obstacles = []
    for k in range(draw(st.integers(3, 7))):
        x0, y0 = draw(st.integers(0, 8)), draw(st.integers(0, 8))
        x1, y1 = x0 + draw(st.integers(1, 4)), y0 + draw(st.integers(1, 4))
        z0 = draw(st.integers(0, nz - 1))
        z1 = draw(st.integers(z0 + 1, nz))
        material = draw(st.sampled_from([(0.0, 1.0), (0.0, 1.0), (0.5, 0.5), (0.5, float("nan"))]))
        obstacles.append({"name": f"box{k}", "cells": [[x0, min(x1, 10)], [y0, min(y1, 10)], [z0, z1]],
                          "deformability": material[0], "sensitivity": material[1]})
    size = [draw(st.sampled_from([0.05, 0.2, 0.3])), draw(st.sampled_from([0.05, 0.2])), 0.05]
    robot_material = draw(st.sampled_from([(0.0, 1.0), (0.0, 1.0), (0.5, 0.5)]))
    placeholder = [0.5, 0.5, 0.0] if planar else [0.5, 0.5, 0.2]          # replaced by free configurations
    return {"name": "random-world", "planar": planar, "start": placeholder, "goal": placeholder,
        "bounds": {"lower": [0.0, 0.0, -0.05 if planar else 0.0], "upper": [1.0, 1.0, 0.05 if planar else 0.4],
                   "resolution": RES},
        "objects": obstacles,
        "robot": {"kind": "rigid", "space": space, "deformability": robot_material[0],
                  "sensitivity": robot_material[1], "parts": [{"shape": "box", "size": size}]}}


# --- the independent oracle ------------------------------------------------------------------------


def colliding_points(scene: Scene, grid: VoxelGrid, materials: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bool ``(n, m)``: a body point inside voxels it may not enter (outside the grid counts as such).  A point on a
    voxel face (within 1e-6 voxel) is in the voxels on both sides, and collides only if all of them are forbidden:
    touching is free."""
    shape = np.array(grid.shape)
    d_rob, s_rob = materials[:, 0], materials[:, 1]
    u = (points - grid.lower) / grid.resolution
    collides = np.ones(points.shape[:-1], dtype=bool)
    for signs in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3):
        cell = np.floor(u + signs * 1e-6).astype(int)
        inside = np.all((cell >= 0) & (cell < shape), axis=-1)
        i, j, k = np.moveaxis(np.where(inside[..., None], cell, 0), -1, 0)
        d_env, s_env = grid.deformability[i, j, k], grid.sensitivity[i, j, k]
        hard = (d_rob + d_env == 0.0) | np.isnan(s_env) | np.isnan(s_rob)
        forbidden = ~inside | (grid.occupied[i, j, k] & hard)
        collides &= forbidden
    return collides


def sweep_collisions(problem: PlanningProblem, path: np.ndarray) -> list[tuple[int, float]]:
    """``(segment, t)`` of every sampled instant where a body point collides (empty: the path is valid)."""
    robot, space, scene = problem.robot, problem.space, problem.scene
    grid = VoxelGrid.from_scene(scene, static_only=True)
    materials = np.asarray(robot.point_materials())
    local = robot.body_points(path[:1])[0] - (np.append(path[0, :2], 0.0) if space.kind == "se2" else path[0, :3])
    reach = float(np.max(np.linalg.norm(local, axis=1)))
    bad = []
    for i in range(len(path) - 1):
        a, b = path[i], path[i + 1]
        if space.kind == "se2":
            turn = abs(math.remainder(b[2] - a[2], 2 * math.pi))
            travel = float(np.linalg.norm(b[:2] - a[:2])) + reach * turn
        else:
            travel = float(np.linalg.norm(b[:3] - a[:3]))
        n = max(1, math.ceil(travel / (RES / 10)))
        t = np.linspace(0.0, 1.0, n + 1)
        states = space.interpolate(a[None], b[None], t[:, None])
        hits = colliding_points(scene, grid, materials, robot.body_points(states)).any(axis=1)
        bad.extend((i, float(tt)) for tt in t[hits])
    return bad


def free_configurations(problem: PlanningProblem, rng: np.random.Generator, count: int,
                        candidates: np.ndarray | None = None) -> np.ndarray:
    """Up to ``count`` (0: all) of ``candidates`` (default: 200 drawn uniformly) the oracle finds collision-free."""
    scene, robot = problem.scene, problem.robot
    grid = VoxelGrid.from_scene(scene, static_only=True)
    q = candidates
    if q is None:
        q = problem.space.sample(rng, 200)
        if problem.space.kind == "se2":
            q[:, 2] = rng.choice([0.0, math.pi / 2, rng.uniform(-math.pi, math.pi)], size=len(q))
    q = q[np.asarray(problem.space.is_valid(q), dtype=bool)]
    ok = ~colliding_points(scene, grid, np.asarray(robot.point_materials()), robot.body_points(q)).any(axis=1)
    return q[ok][:count] if count else q[ok]


# --- the property ----------------------------------------------------------------------------------


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(world=worlds(), seed=st.integers(0, 2**16))
def test_every_solved_path_passes_an_independent_fine_sweep(world, seed):
    rng = np.random.default_rng(seed)
    base = Pipeline(Scene.from_dict(world), planner="straight").build()
    probe = PlanningProblem(space=base.space, start=np.zeros(base.space.dim), goal=np.zeros(base.space.dim),
                            robot=base.robot, scene=base.scene)
    space = world["robot"]["space"]
    free = free_configurations(probe, rng, 8)
    if space == "r3":                                   # A* plans on the lattice of voxel centres
        free = free_configurations(probe, rng, 0, np.round((free - 0.05) / RES) * RES + 0.05)
    assume(len(free) >= 2)
    # start and goal: preferably two that do not see each other (the straight motion collides), so planners search
    pairs = [(i, j) for i in range(len(free)) for j in range(i + 1, len(free))]
    i, j = next(((i, j) for i, j in pairs if sweep_collisions(probe, free[[i, j]])), (0, 1))
    free = np.vstack([free[[i, j]], np.delete(free, [i, j], axis=0)])
    world = dict(world, start=free[0].tolist(), goal=free[1].tolist())
    for planner, (options, needs_cost, spaces) in sorted(PLANNERS.items()):
        if space not in spaces:
            continue
        options = dict(options)
        if planner == "waypoints":
            options["waypoints"] = [q.tolist() for q in free[2:]]
        cost = needs_cost or bool(rng.integers(2))     # with or without a cost model, where the planner allows
        context = Pipeline(Scene.from_dict(world), planner={"name": planner, **options},
                           **({"cost": "voxel"} if cost else {})).build()
        problem = PlanningProblem.from_context(context, budget=REQUEST_BUDGETS.get(planner))
        result = context.extras["planner"].plan(problem, np.random.default_rng(seed))
        event(f"{planner}: {result.status.value}")    # --hypothesis-show-statistics: how many were solved
        if result.solved:
            assert sweep_collisions(problem, result.path.configurations) == [], \
                f"{planner} returned a path that collides"


def test_the_sweep_sees_a_path_through_a_wall():
    # the oracle itself: a straight path through a rigid wall collides, one beside it does not
    world = {"name": "oracle", "planar": False, "start": [0.25, 0.5, 0.2], "goal": [0.85, 0.5, 0.2],
             "bounds": {"lower": [0.0, 0.0, 0.0], "upper": [1.0, 1.0, 0.4], "resolution": RES},
             "objects": [{"name": "wall", "cells": [[5, 6], [0, 8], [0, 4]], "deformability": 0.0,
                          "sensitivity": 1.0}],
             "robot": {"kind": "rigid", "space": "r3", "deformability": 0.0, "sensitivity": 1.0,
                       "parts": [{"shape": "box", "size": [0.05, 0.05, 0.05]}]}}
    context = Pipeline(Scene.from_dict(world), planner="straight").build()
    problem = PlanningProblem.from_context(context)
    through = np.array([[0.25, 0.5, 0.2], [0.85, 0.5, 0.2]])
    beside = np.array([[0.25, 0.5, 0.2], [0.25, 0.85, 0.2], [0.85, 0.85, 0.2]])
    assert sweep_collisions(problem, through) and sweep_collisions(problem, beside) == []
    assert not problem.path_is_valid(through) and problem.path_is_valid(beside)


@pytest.mark.parametrize("planner", ["rrtstar", "belief"])
def test_planners_solve_a_scene_with_a_wall_and_their_paths_pass_the_sweep(planner):
    # not only vacuous: with a wall between start and goal, the sampling planners do solve within their budget
    world = {"name": "wall", "planar": True, "start": [0.2, 0.2, 0.0], "goal": [0.8, 0.2, 0.0],
             "bounds": {"lower": [0.0, 0.0, -0.05], "upper": [1.0, 1.0, 0.05], "resolution": RES},
             "objects": [{"name": "wall", "cells": [[4, 6], [0, 7], [0, 1]], "deformability": 0.0,
                          "sensitivity": 1.0}],
             "robot": {"kind": "rigid", "space": "se2", "deformability": 0.0, "sensitivity": 1.0,
                       "parts": [{"shape": "box", "size": [0.3, 0.05, 0.05]}]}}
    options = dict(PLANNERS[planner][0], max_iterations=1500)
    context = Pipeline(Scene.from_dict(world), planner={"name": planner, **options}).build()
    problem = PlanningProblem.from_context(context)
    result = context.extras["planner"].plan(problem, np.random.default_rng(3))
    assert result.solved, result.message
    assert sweep_collisions(problem, result.path.configurations) == []
