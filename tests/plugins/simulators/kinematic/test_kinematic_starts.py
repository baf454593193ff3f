"""The kinematic simulator refuses every start inside an obstacle, through every entry point (issue 31 item 3):
reset, simulate (one start, and a batch naming the index), and a first step from the state bind left; a refused
call changes nothing, and a start in free space (or in contact) still runs."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from pliant import load_scene, registry
from pliant.errors import SimulationError
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import Context


@functools.cache
def maze():
    ctx = Context(scene=load_scene("se2-maze"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


def simulator():
    return registry.create("simulator", "kinematic", maze())


#: the L-block's corner cell and its x arm inside the maze's bottom wall (y in [0, 0.5] m), half a metre deep
INSIDE = np.array([4.0, 0.25, 0.0])
#: in the left passage, its left face on the passage's wall (x = 0.5 m): touching, free
FREE = np.array([0.75, 4.0, 0.0])


def brute_depth(points: np.ndarray, grid: VoxelGrid) -> np.ndarray:
    """Depth (m) of points ``(m, 3)`` in the obstacles, by brute force: the distance to the nearest free voxel's
    (closed) box, every free voxel of the grid tried; outside the grid is solid (no free voxel there)."""
    free = np.argwhere(~grid.occupied)
    lower = grid.lower + free * grid.resolution
    upper = lower + grid.resolution
    # a point in a free voxel is in that voxel's closed box (depth 0): only the others need the search
    cell = np.floor((points - grid.lower) / grid.resolution).astype(int)
    in_grid = np.all((cell >= 0) & (cell < np.array(grid.shape)), axis=1)
    solid = ~in_grid
    solid[in_grid] = grid.occupied[tuple(cell[in_grid].T)]
    depth = np.zeros(len(points))
    deep = points[solid]
    gap = np.maximum(np.maximum(lower[None] - deep[:, None], deep[:, None] - upper[None]), 0.0)
    depth[solid] = np.sqrt(np.min(np.sum(gap ** 2, axis=2), axis=1)) if len(deep) else 0.0
    return depth


@functools.cache
def maze_grid() -> VoxelGrid:
    return VoxelGrid.from_scene(maze().scene)


def independent_depth(q: np.ndarray) -> float:
    """The deepest surface point of the L-block at ``q`` ``(3,)``, by brute force against the scene's voxels."""
    robot = maze().robot
    points = robot.body_points(np.asarray(q, dtype=np.float64)[None], robot.surface_indices())[0]
    return float(brute_depth(points, maze_grid()).max())


def test_the_fixtures_are_what_they_say():
    assert independent_depth(INSIDE) == pytest.approx(0.5) and independent_depth(FREE) == 0.0


def test_reset_inside_a_wall_is_refused_naming_the_object_and_changes_nothing():
    sim = simulator()
    sim.reset(FREE)
    with pytest.raises(SimulationError, match=r"reset: places the robot 0\.\d+ m inside object 'walls' "
                                              r"\(this simulator tolerates 0\.03125 m"):
        sim.reset(INSIDE)
    assert np.array_equal(sim.configuration(), FREE)
    # the next step starts where the robot was, not inside the wall
    q = sim.step(np.array([0.0, 0.5, 0.0]), 0.1, np.random.default_rng(0))
    assert np.allclose(q, FREE + [0.0, 0.05, 0.0]) and independent_depth(q) == 0.0


def test_simulate_refuses_one_start_inside_a_wall():
    sim = simulator()
    with pytest.raises(SimulationError, match=r"^starts: places the robot .* inside object 'walls'"):
        sim.simulate(INSIDE, FREE, np.random.default_rng(0), 1.0)
    with pytest.raises(SimulationError, match=r"^starts\[0\]: places the robot"):
        sim.simulate(INSIDE[None], FREE, np.random.default_rng(0), 1.0)


def test_a_batch_with_some_starts_inside_is_refused_naming_the_first_and_listing_the_others():
    sim = simulator()
    starts = np.array([FREE, FREE, INSIDE, FREE, INSIDE + [0.5, 0.0, 0.0]])
    with pytest.raises(SimulationError, match=r"^starts\[2\]: places the robot .* 2 of the 5 starts are inside: "
                                              r"indices 2, 4 \(got \[4\.0, 0\.25, 0\.0\]\)"):
        sim.simulate(starts, FREE, np.random.default_rng(0), 1.0)


def test_free_starts_and_starts_in_contact_still_run():
    sim = simulator()
    res = maze().scene.resolution
    pressed = FREE - [0.2 * res, 0.0, 0.0]             # a fifth of a voxel into the wall: contact, within tolerance
    deeper = FREE - [0.3 * res, 0.0, 0.0]              # three tenths: inside
    assert independent_depth(pressed) == pytest.approx(0.2 * res)
    assert independent_depth(deeper) == pytest.approx(0.3 * res)
    out = sim.simulate(np.array([FREE, pressed]), FREE + [0.0, 1.0, 0.0], np.random.default_rng(0), 1.0)
    assert np.all(out.reached) and independent_depth(out.final[1]) == 0.0    # the first steps pushed it out
    sim.reset(pressed)
    with pytest.raises(SimulationError, match=r"^reset: places the robot 0\.0375 m inside object 'walls'"):
        sim.reset(deeper)


def test_the_first_step_from_the_state_bind_left_is_checked():
    sim = simulator()
    sim._q = INSIDE[None].copy()              # as if the scene's start were inside a wall (bind does not reset)
    with pytest.raises(SimulationError, match=r"^step: places the robot .* inside object 'walls'"):
        sim.step(np.zeros(3), 0.1, np.random.default_rng(0))
    fresh = simulator()                       # the scene's start is free: stepping from it works
    assert fresh.step(np.zeros(3), 0.1, np.random.default_rng(0)).shape == (3,)


coordinate = st.floats(0.0, 1.0, allow_nan=False)


@settings(max_examples=60)
@given(st.lists(st.tuples(coordinate, coordinate, st.floats(-np.pi, np.pi)), min_size=1, max_size=4))
def test_starts_are_refused_exactly_when_a_brute_force_check_finds_them_inside(raw):
    ctx = maze()
    space = ctx.space
    starts = np.array([[space.lower[0] + x * (space.upper[0] - space.lower[0]),
                        space.lower[1] + y * (space.upper[1] - space.lower[1]), t] for x, y, t in raw])
    tolerance = 0.25 * ctx.scene.resolution
    depths = np.array([independent_depth(q) for q in starts])
    assume(np.all(np.abs(depths - tolerance) > 1e-9))
    inside = np.nonzero(depths > tolerance)[0]
    sim = simulator()
    for q, d in zip(starts, depths):
        if d > tolerance:
            with pytest.raises(SimulationError, match=r"^reset: places the robot"):
                sim.reset(q)
        else:
            sim.reset(q)
            assert float(space.distance(sim.configuration(), q)) < 1e-9
    if len(inside):
        field = "starts" if len(starts) == 1 else f"starts\\[{inside[0]}\\]"
        with pytest.raises(SimulationError, match=rf"^{field}: places the robot"):
            sim.simulate(starts[0] if len(starts) == 1 else starts, starts[0], np.random.default_rng(0), 0.1)
    else:
        assert sim.simulate(starts, starts[0], np.random.default_rng(0), 0.1).final.shape == starts.shape


def ball_scene():
    from pliant import Scene

    data = {"name": "ball", "start": [0.5, 0.5, 0.5], "goal": [0.5, 0.5, 0.9],
            "bounds": {"lower": [0, 0, 0], "upper": [1, 1, 1], "resolution": 0.05},
            "objects": [{"name": "ball", "shape": "sphere", "radius": 0.2, "position": [0.5, 0.5, 0.5],
                         "deformability": 0.0, "sensitivity": 1.0}],
            "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "box", "size": [0.1, 0.1, 0.1]}]}}
    ctx = Context(scene=Scene.from_dict(data))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


def test_a_scene_whose_start_is_inside_an_object_cannot_be_stepped_from_it():
    ctx = ball_scene()                                  # the robot's start is the ball's centre
    sim = registry.create("simulator", "kinematic", ctx)
    with pytest.raises(SimulationError, match=r"^step: places the robot \S+ m inside object 'ball'.*"
                                              r"\(got \[0\.5, 0\.5, 0\.5\]\)"):
        sim.step(np.array([0.0, 0.0, 1.0]), 0.1, np.random.default_rng(0))
    assert np.allclose(sim.configuration(), [0.5, 0.5, 0.5])
    sim.reset(np.array([0.5, 0.5, 0.9]))                # above the ball: free, and stepping works from there
    assert sim.step(np.array([0.0, 0.0, 0.5]), 0.1, np.random.default_rng(0))[2] == pytest.approx(0.9, abs=0.06)


def _numpy_penetration(sim, q: np.ndarray) -> np.ndarray:
    """The start check without the compiled first pass: every configuration's surface points placed by the robot's
    ``body_points``, looked up, and the deepest colliding one measured."""
    points = sim.robot.body_points(q, sim.surface)
    hit = sim.contact.colliding(points)
    depth = np.zeros(len(q))
    rows, cols = np.nonzero(hit)
    np.maximum.at(depth, rows, sim.starts.depth(points[rows, cols]))
    return depth


@pytest.mark.parametrize("scene", ["se2-maze", "se2-through-passage", "se3-peg-tight", "cube-wall"])
def test_the_compiled_start_check_gives_the_depths_of_the_placed_points(scene):
    """The compiled pass (``placed_points_hit``) only decides which configurations to measure: the depths equal the
    numpy path's, on configurations that are free, touching, deep inside and outside the grid (SE(2), SE(3), R^3)."""
    ctx = Context(scene=load_scene(scene))
    ctx.robot = registry.create("robot", "rigid", ctx)
    sim = registry.create("simulator", "kinematic", ctx)
    assert sim.placement_kind is not None
    space, rng = ctx.robot.space, np.random.default_rng(5)
    lower, upper = np.asarray(space.lower, dtype=float), np.asarray(space.upper, dtype=float)
    q = space.sample(rng, 300)
    q[:40, :3 if space.kind != "se2" else 2] = (lower + 1.2 * (upper - lower))[:3 if space.kind != "se2" else 2]
    q[40:60] = np.asarray(ctx.scene.start, dtype=float)
    depth = sim.start_penetration(q)
    expected = _numpy_penetration(sim, q)
    assert np.array_equal(depth, expected)
    assert (depth > 0).sum() >= 40 and (depth == 0).sum() >= 20          # both kinds were drawn
