"""The fused kernel's broad phase only skips points that cannot collide, and the spatial order it walks the points in
changes no sum: simulations with both and with neither (every point, in the body's order) are bit-identical; the
free-voxel clearance it relies on (planar grids included) is a lower bound."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.interfaces import Context
from pliant_kinematic.contact import ContactModel

#: se2-through-passage and se3-peg-tight as the ch. 6 metric's tasks drive them (kp 1, 0.1 m/s, floor noise)
CASES = {
    "se2-through-passage": ((0.2375, 0.12, 0.0), (0.2375, 0.42, 0.0), 0.025),
    "se3-peg-tight": ((0.151, 0.151, 0.16, 0.08715574274765817, 0.0, 0.0, 0.9961946980917455),
                      (0.151, 0.151, 0.0625, 0.0, 0.0, 0.0, 1.0), 0.0025),
}


def _simulator(scene: str):
    ctx = Context(scene=load_scene(scene))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return registry.create("simulator", "kinematic", ctx, kp=1.0, velocity_limit=0.1, angular_velocity_limit=0.25,
                           effort_length=0.1, noise="floor", noise_linear=0.25, noise_angular=0.0625)


def _without_broad_phase(sim) -> None:
    """One segment of unbounded radius and zero clearance in every free voxel (occupied ones stay negative): every
    point is looked up every pass, in the body's own order (not the spatial order the broad phase walks)."""
    k = len(sim.surface_local)
    sim._walk = np.arange(k, dtype=np.int64)
    sim._walked_local, sim._walked_faces = sim.surface_local, sim._face_bits
    sim._segments = (np.array([0, k], dtype=np.int64), np.zeros((1, 3)), np.array([np.inf]))
    bound = np.minimum(sim.contact.free_clearance, 0)
    bound.flags.writeable = False           # read-only, as the model's own (one compiled signature for both)
    sim.contact.free_clearance = bound


@pytest.mark.parametrize("scene", list(CASES))
def test_simulation_is_bit_identical_without_the_broad_phase(scene):
    start, goal, spread = CASES[scene]
    starts = np.repeat(np.asarray(start, dtype=np.float64)[None], 24, axis=0)
    starts[:, :2] += np.random.default_rng(3).uniform(-spread, spread, (24, 2))
    fast = _simulator(scene)
    slow = _simulator(scene)
    _without_broad_phase(slow)
    starts = starts[fast.start_penetration(starts) <= fast.start_tolerance]     # the simulators refuse the rest
    assert len(starts) >= 12
    a = fast.simulate(starts, np.asarray(goal), np.random.default_rng(11), 2.0, record=True)
    b = slow.simulate(starts, np.asarray(goal), np.random.default_rng(11), 2.0, record=True)
    assert a.in_contact.any()                                   # the batch does meet the walls
    assert np.array_equal(a.trajectories, b.trajectories)
    assert np.array_equal(a.in_contact, b.in_contact) and a.steps == b.steps


def test_planar_free_clearance_is_a_lower_bound_and_not_zero():
    grid = _simulator("se2-through-passage").grid
    planar = ContactModel(grid, planar=True)
    assert planar.planar and not ContactModel(grid).planar
    free_voxels = ~grid.occupied.reshape(-1)
    assert not ContactModel(grid).free_clearance[free_voxels].any()   # with the z faces as walls the bound is zero
    assert np.all(planar.free_clearance[~free_voxels] < 0)             # occupied voxels are marked negative
    occupied = np.argwhere(grid.occupied[:, :, 0])
    res = grid.resolution
    rng = np.random.default_rng(0)
    free = np.argwhere(~grid.occupied[:, :, 0])
    picks = free[rng.choice(len(free), 400, replace=False)]
    bound = planar.free_clearance.reshape(grid.shape)[picks[:, 0], picks[:, 1], 0]
    assert bound.max() > 10 * res
    lower = grid.lower[:2]
    size = np.array(grid.shape[:2]) * res
    for (i, j), b in zip(picks, bound, strict=True):
        # any point of the voxel, against any point of an occupied voxel (squares) or the grid's x-y boundary
        point = lower + (np.array([i, j]) + rng.random(2)) * res
        gap = np.maximum(np.abs(lower + (occupied + 0.5) * res - point) - 0.5 * res, 0.0)
        nearest = min(np.min(np.linalg.norm(gap, axis=1)), np.min(point - lower), np.min(lower + size - point))
        assert b <= nearest + 1e-12


def test_the_simulators_segments_cover_its_walked_surface_and_bound_their_points():
    """The simulator's segments (``pliant.api.spatial_runs``) run over the surface in its walk order, a permutation of
    the surface, and every point of a segment lies within the segment's radius of its centre."""
    sim = _simulator("se3-peg-tight")
    local, walk = sim.surface_local, sim._walk
    segments, centres, radii = sim._segments
    assert np.array_equal(np.sort(walk), np.arange(len(local))) and np.array_equal(sim._walked_local, local[walk])
    assert segments[0] == 0 and segments[-1] == len(local) and np.all(np.diff(segments) >= 1)
    for s in range(len(radii)):
        run = sim._walked_local[segments[s]:segments[s + 1]]
        assert np.all(np.linalg.norm(run - centres[s], axis=1) <= radii[s] + 1e-15)
    assert len(local) / len(radii) > 10            # walked by cells, the peg's runs are long (3 points in its order)
