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
            assert float(space.distance(sim.configuration(), q)) < 1e-9
    inside = np.nonzero(depths > tolerance)[0]
    if len(inside):
        with pytest.raises(SimulationError, match=rf"^starts\[{inside[0]}\]: places the robot"):
            sim.simulate(starts, starts[0], np.random.default_rng(0), 0.1)
    else:
        assert sim.simulate(starts, starts[0], np.random.default_rng(0), 0.1).final.shape == starts.shape


@functools.cache
def push():
    ctx = Context(scene=load_scene("se2-push"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx, registry.create("simulator", "pymunk", ctx)


@pytest.mark.parametrize(("x", "y", "depth"), [
    (0.09, 0.5, 0.03),                                      # the crate's left face 3 cm into the rim (x < 0.04)
    (0.8, 0.93, None),                                      # its top face through the rim (y > 0.96), 1 cm beyond
])
def test_placing_an_object_into_a_wall_is_refused_and_moves_nothing(x, y, depth):
    _, sim = push()
    sim.reset(np.array([0.3, 0.5, 0.0]))
    sim.set_object_poses({"crate": np.array([0.6, 0.5, 0.0])})
    with pytest.raises(SimulationError, match=r"^set_object_poses\.crate: places object 'crate' (\S+) m inside "
                                              r"object 'rim'") as error:
        sim.set_object_poses({"crate": np.array([x, y, 0.0])})
    measured = float(error.value.args[0].split(" m inside")[0].rsplit(" ", 1)[1])
    # a voxel or more deep (and beyond the bounds): at least a voxel, as the starts' measure says
    assert measured >= 0.02 if depth is None else measured == pytest.approx(depth, abs=1e-3)
    assert np.allclose(sim.object_poses()["crate"], [0.6, 0.5, 0.0])


@pytest.mark.parametrize(("x", "theta", "depth"), [
    (0.35, 0.0, 0.05),                                      # the paddle (x 0.28-0.32) inside the crate's left half
    (0.375, 0.0, 0.025),                                    # 25 mm: deeper than placed_tolerance, the 2 cm voxel
    (0.32 + 0.08 * 2 ** 0.5 - 0.03, np.pi / 4, None),       # a turned crate's corner 3 cm into the paddle
])
def test_a_step_with_an_object_placed_on_the_robot_is_refused_until_a_reset_moves_it(x, theta, depth):
    _, sim = push()
    sim.reset(np.array([0.3, 0.5, 0.0]))
    sim.set_object_poses({"crate": np.array([x, 0.5, theta])})     # placing is fine: a reset may move the paddle
    with pytest.raises(SimulationError, match=r"^step: the robot starts (\S+) m inside movable object 'crate'") as e:
        sim.step(np.array([0.05, 0.0, 0.0]), 0.1, np.random.default_rng(0))
    measured = float(e.value.args[0].split(" m inside")[0].rsplit(" ", 1)[1])
    assert measured > 0.02 if depth is None else measured == pytest.approx(depth, abs=1e-3)
    assert np.allclose(sim.configuration(), [0.3, 0.5, 0.0])
    assert np.allclose(sim.object_poses()["crate"], [x, 0.5, theta])
    sim.reset(np.array([0.1, 0.5, 0.0]))                   # puts the crate back at its scene pose (x 0.6) ...
    sim.set_object_poses({"crate": np.array([x, 0.5, theta])})     # ... and here again, the paddle now clear
    assert sim.step(np.zeros(3), 0.1, np.random.default_rng(0))[0] == pytest.approx(0.1, abs=1e-3)


@pytest.mark.parametrize(("x", "theta"), [(0.4, 0.0), (0.32 + 0.08 * 2 ** 0.5 + 0.001, np.pi / 4), (0.4 - 0.004, 0.0),
                                          (0.4 - 0.015, 0.0), (0.32 + 0.08 * 2 ** 0.5 - 0.015, np.pi / 4)])
def test_an_object_placed_against_the_robot_is_accepted(x, theta):
    _, sim = push()
    sim.reset(np.array([0.3, 0.5, 0.0]))
    sim.set_object_poses({"crate": np.array([x, 0.5, theta])})   # touching, or up to 15 mm in: pushed out
    assert np.allclose(sim.object_poses()["crate"], [x, 0.5, theta])
    q = sim.step(np.array([0.05, 0.0, 0.0]), 0.1, np.random.default_rng(0))
    assert q[0] > 0.3


def test_placing_a_movable_object_onto_another_is_refused():
    ctx = Context(scene=load_scene("tsrrt-table"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    sim = registry.create("simulator", "pymunk", ctx)
    before = sim.object_poses()
    block = before["block-1"]                                  # a 0.1 m square, turned; the can's radius 0.05 m
    along = np.array([np.cos(block[2]), np.sin(block[2]), 0.0])
    with pytest.raises(SimulationError, match=r"^set_object_poses\.can-1: places object 'can-1' 0\.04 m inside "
                                              r"movable object 'block-1'"):
        sim.set_object_poses({"can-1": block + 0.06 * along})
    assert all(np.allclose(sim.object_poses()[n], p) for n, p in before.items())
    sim.set_object_poses({"can-1": block + 0.101 * along})     # beside it: accepted
