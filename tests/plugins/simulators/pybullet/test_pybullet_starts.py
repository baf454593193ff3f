"""pybullet refuses every start inside an obstacle, through every entry point (issue 31 item 3): reset, simulate
(one start, and a batch naming the index; no particle is simulated then), and a refused call leaves the robot where
it was (a reset that placed the peg in the block and then refused used to leave it there); a start in free space
or resting on the block still runs."""

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


def pose(x, y, z):
    return np.array([x, y, z, 0.0, 0.0, 0.0, 1.0])


@functools.cache
def peg():
    ctx = Context(scene=load_scene("se3-peg-in-hole"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


@functools.cache
def simulator():
    return registry.create("simulator", "pybullet", peg())


INSIDE = pose(7.0, 7.0, 2.0)             # the 1 m peg wholly inside the block (its top at z = 3 m)
RESTING = pose(7.0, 7.0, 3.5)            # standing on the block's top
RES = 0.0625


@functools.cache
def grid() -> VoxelGrid:
    return VoxelGrid.from_scene(peg().scene)


def independent_depth(q: np.ndarray) -> float:
    """The deepest surface point of the peg at ``q`` ``(7,)`` inside the block, by brute force: its distance to the
    nearest free voxel's (closed) box or to the space outside the grid (pybullet has no walls there), every free
    voxel within two voxels of the peg's points tried (a point nearer free space than a voxel has its nearest free
    voxel among them; deeper points come out a voxel deep or more, which is all that matters here)."""
    robot = peg().robot
    points = robot.body_points(np.asarray(q, dtype=np.float64)[None], robot.surface_indices())[0]
    g = grid()
    shape = np.array(g.shape)
    lo = np.clip(np.floor((points.min(axis=0) - g.lower) / RES).astype(int) - 2, 0, shape)
    hi = np.clip(np.floor((points.max(axis=0) - g.lower) / RES).astype(int) + 3, 0, shape)
    block = g.occupied[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    free = np.argwhere(~block) + lo
    outside = np.min(np.concatenate([points - g.lower, g.lower + shape * RES - points], axis=1), axis=1)
    depth = np.where(outside > 0, outside, 0.0)            # outside the grid: free
    # a point in a free voxel is in that voxel's closed box (depth 0): only the others need the search
    cell = np.floor((points - g.lower) / RES).astype(int)
    in_grid = np.all((cell >= 0) & (cell < shape), axis=1)
    occupied = np.zeros(len(points), dtype=bool)
    occupied[in_grid] = g.occupied[tuple(cell[in_grid].T)]
    depth = np.where(occupied, depth, 0.0)
    deep = points[occupied]
    if len(free) and len(deep):
        lower = g.lower + free * RES
        gap = np.maximum(np.maximum(lower[None] - deep[:, None], deep[:, None] - (lower + RES)[None]), 0)
        depth[occupied] = np.minimum(depth[occupied], np.sqrt(np.min(np.sum(gap ** 2, axis=2), axis=1)))
    return float(depth.max())


def test_a_refused_reset_leaves_the_peg_where_it_was():
    sim = simulator()
    sim.reset(RESTING)
    with pytest.raises(SimulationError, match=r"^reset: places the robot \S+ m inside object 'block'"):
        sim.reset(INSIDE)
    assert np.allclose(sim.configuration(), RESTING, atol=1e-9)
    q = sim.step(np.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.0]), 0.1, np.random.default_rng(0))
    assert q[0] > RESTING[0] + 0.01 and q[2] > 3.4


def test_simulate_refuses_a_start_inside_before_simulating_any_particle():
    sim = simulator()
    sim.reset(RESTING)
    with pytest.raises(SimulationError, match=r"^starts: places the robot .* inside object 'block'"):
        sim.simulate(INSIDE, RESTING, np.random.default_rng(0), 0.5)
    starts = np.array([pose(8, 8, 6), INSIDE, pose(6, 6, 6), INSIDE + [1.0, 0, 0, 0, 0, 0, 0]])
    with pytest.raises(SimulationError, match=r"^starts\[1\]: places the robot .* 2 of the 4 starts are inside: "
                                              r"indices 1, 3 \(got \[7\.0, 7\.0, 2\.0, 0\.0, 0\.0, 0\.0, 1\.0\]\)"):
        sim.simulate(starts, RESTING, np.random.default_rng(0), 0.5)
    assert np.allclose(sim.configuration(), RESTING, atol=1e-9)        # no particle was simulated


def test_free_starts_and_starts_in_contact_still_run():
    sim = simulator()
    pressed = RESTING - [0, 0, 0.2 * RES, 0, 0, 0, 0]                 # a fifth of a voxel into the block's top
    assert independent_depth(pressed) == pytest.approx(0.2 * RES)
    out = sim.simulate(np.array([pose(8, 8, 6), RESTING, pressed]), pose(7, 7, 5), np.random.default_rng(0), 1.0)
    assert out.final.shape == (3, 7) and np.all(out.final[:, 2] > 3.5)
    with pytest.raises(SimulationError, match=r"^reset: places the robot 0\.01875 m inside object 'block'"):
        sim.reset(RESTING - [0, 0, 0.3 * RES, 0, 0, 0, 0])


unit = st.floats(0.0, 1.0, allow_nan=False)
component = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=30)
@given(st.lists(st.tuples(unit, unit, st.floats(2.3, 4.2), st.tuples(component, component, component, component)),
                min_size=1, max_size=3))
def test_starts_are_refused_exactly_when_a_brute_force_check_finds_them_inside(raw):
    starts = []
    for x, y, z, quaternion in raw:
        quaternion = np.asarray(quaternion)
        assume(np.linalg.norm(quaternion) > 0.1)
        quaternion = quaternion / np.linalg.norm(quaternion)
        starts.append(np.concatenate([[0.5 + 9 * x, 0.5 + 9 * y, z], quaternion * np.sign(quaternion[3] or 1.0)]))
    starts = np.array(starts)
    tolerance = 0.25 * RES
    depths = np.array([independent_depth(q) for q in starts])
    assume(np.all(np.abs(depths - tolerance) > 1e-9))
    sim = simulator()
    for q, d in zip(starts, depths):
        if d > tolerance:
            with pytest.raises(SimulationError, match=r"^reset: places the robot"):
                sim.reset(q)
        else:
            sim.reset(q)
    inside = np.nonzero(depths > tolerance)[0]
    if len(inside):
        with pytest.raises(SimulationError, match=rf"^starts\[{inside[0]}\]: places the robot"):
            sim.simulate(starts, starts[0], np.random.default_rng(0), 0.1)
    else:
        assert sim.simulate(starts, starts[0], np.random.default_rng(0), 0.1).final.shape == starts.shape


def test_a_scene_whose_start_is_inside_an_object_is_refused_when_the_simulator_is_built():
    from pliant import Scene

    data = {"name": "ball", "start": [0.5, 0.5, 0.5], "goal": [0.5, 0.5, 0.9],
            "bounds": {"lower": [0, 0, 0], "upper": [1, 1, 1], "resolution": 0.05},
            "objects": [{"name": "ball", "shape": "sphere", "radius": 0.2, "position": [0.5, 0.5, 0.5],
                         "deformability": 0.0, "sensitivity": 1.0}],
            "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "box", "size": [0.1, 0.1, 0.1]}]}}
    ctx = Context(scene=Scene.from_dict(data))
    ctx.robot = registry.create("robot", "rigid", ctx)
    with pytest.raises(SimulationError, match=r"^reset: places the robot \S+ m inside object 'ball'"):
        registry.create("simulator", "pybullet", ctx)          # bind places the robot at the scene's start
