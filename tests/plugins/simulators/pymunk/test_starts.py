"""pymunk refuses every start inside a static wall, through every entry point (issue 31 item 3): reset,
simulate (one start, and a batch naming the index; no particle is simulated then), and a refused call leaves the
robot where it was (a reset that placed the L-block in the wall and then refused used to leave it there, and the
next step started inside); a start in free space or in contact still runs."""

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


@functools.cache
def simulator():
    return registry.create("simulator", "pymunk", maze())


#: the L-block's corner cell and its x arm inside the maze's bottom wall (y in [0, 0.5] m), half a metre deep
INSIDE = np.array([4.0, 0.25, 0.0])
#: in the left passage, its left face on the passage's wall (x = 0.5 m): touching, free
FREE = np.array([0.75, 4.0, 0.0])


@functools.cache
def walls() -> VoxelGrid:
    return VoxelGrid.from_scene(maze().scene, static_only=True)


def independent_depth(q: np.ndarray) -> float:
    """The deepest surface point of the L-block at ``q`` ``(3,)`` inside the static walls, by brute force: its
    distance to the nearest free voxel's (closed) box, every free voxel tried (outside the grid is a wall)."""
    robot = maze().robot
    points = robot.body_points(np.asarray(q, dtype=np.float64)[None], robot.surface_indices())[0]
    grid = walls()
    free = np.argwhere(~grid.occupied)
    lower = grid.lower + free * grid.resolution
    gap = np.maximum(np.maximum(lower[None] - points[:, None], points[:, None] - (lower + grid.resolution)[None]), 0)
    return float(np.sqrt(np.min(np.sum(gap ** 2, axis=2), axis=1)).max())


def test_a_refused_reset_leaves_the_robot_where_it_was_and_the_next_step_starts_there():
    sim = simulator()
    sim.reset(FREE)
    with pytest.raises(SimulationError, match=r"^reset: places the robot 0\.\d+ m inside object 'walls'"):
        sim.reset(INSIDE)
    assert np.allclose(sim.configuration(), FREE)
    q = sim.step(np.array([0.5, 0.0, 0.0]), 0.1, np.random.default_rng(0))
    assert q[0] > FREE[0] + 0.02 and independent_depth(q) == 0.0


def test_simulate_refuses_a_start_inside_before_simulating_any_particle():
    sim = simulator()
    sim.reset(FREE)
    with pytest.raises(SimulationError, match=r"^starts: places the robot .* inside object 'walls'"):
        sim.simulate(INSIDE, FREE, np.random.default_rng(0), 0.5)
    starts = np.array([FREE, FREE + [0.5, 0.0, 0.0], INSIDE])
    with pytest.raises(SimulationError, match=r"^starts\[2\]: places the robot .*\(got \[4\.0, 0\.25, 0\.0\]\)"):
        sim.simulate(starts, FREE + [0.0, 1.0, 0.0], np.random.default_rng(0), 0.5)
    assert np.allclose(sim.configuration(), FREE)          # particles 0 and 1 were not simulated either


def test_free_starts_and_starts_in_contact_still_run():
    sim = simulator()
    res = maze().scene.resolution
    pressed = FREE - [0.2 * res, 0.0, 0.0]                  # a fifth of a voxel into the wall: contact
    assert independent_depth(pressed) == pytest.approx(0.2 * res)
    out = sim.simulate(np.array([FREE, pressed]), FREE + [0.0, 1.0, 0.0], np.random.default_rng(0), 1.0)
    assert out.final.shape == (2, 3) and np.all(out.final[:, 1] > FREE[1] + 0.4)
    with pytest.raises(SimulationError, match=r"^reset: places the robot 0\.0375 m inside"):
        sim.reset(FREE - [0.3 * res, 0.0, 0.0])


coordinate = st.floats(0.0, 1.0, allow_nan=False)


@settings(max_examples=40)
@given(st.lists(st.tuples(coordinate, coordinate, st.floats(-np.pi, np.pi)), min_size=1, max_size=3))
def test_starts_are_refused_exactly_when_a_brute_force_check_finds_them_inside(raw):
    ctx = maze()
    space = ctx.space
    starts = np.array([[space.lower[0] + x * (space.upper[0] - space.lower[0]),
                        space.lower[1] + y * (space.upper[1] - space.lower[1]), t] for x, y, t in raw])
    tolerance = 0.25 * ctx.scene.resolution
    depths = np.array([independent_depth(q) for q in starts])
    assume(np.all(np.abs(depths - tolerance) > 1e-9))
    sim = simulator()
    for q, d in zip(starts, depths):
        if d > tolerance:
            with pytest.raises(SimulationError, match=r"^reset: places the robot"):
                sim.reset(q)
        else:
            sim.reset(q)
            assert np.allclose(sim.configuration(), q)
    inside = np.nonzero(depths > tolerance)[0]
    if len(inside):
        with pytest.raises(SimulationError, match=rf"^starts\[{inside[0]}\]: places the robot"):
            sim.simulate(starts, starts[0], np.random.default_rng(0), 0.1)
    else:
        assert sim.simulate(starts, starts[0], np.random.default_rng(0), 0.1).final.shape == starts.shape
