"""Clearance and collision queries (thesis 6.4.2) against a brute-force lookup of every surface point."""

import numpy as np
import pliant
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import Context
from pliant_reachability.clearance import Clearance
from reachability_helpers import passage


def brute_force(robot, grid, q):
    points = robot.body_points(q, robot.surface_indices())
    flat = grid.flat_index(points)
    outside = flat < 0
    occupied = grid.occupied.reshape(-1)[np.where(outside, 0, flat)]
    sdf = np.where(outside, -np.inf, grid.sdf.reshape(-1)[np.where(outside, 0, flat)])
    return sdf.min(axis=1), (outside | occupied).any(axis=1)


def test_the_rigid_kernel_matches_a_brute_force_lookup():
    context = passage()
    grid = VoxelGrid.from_scene(context.scene)
    clearance = Clearance(context.robot, grid)
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.uniform(0.05, 0.55, 300), rng.uniform(0.05, 0.55, 300), rng.uniform(-3, 3, 300)])
    distance, closest, colliding = clearance.query(q)
    expected_distance, expected_colliding = brute_force(context.robot, grid, q)
    assert np.array_equal(colliding, expected_colliding)
    assert np.allclose(distance, expected_distance)
    assert colliding.any() and (~colliding).any()
    # the closest point is one whose clearance is the minimum
    points = context.robot.body_points(q, clearance.surface)[np.arange(len(q)), closest]
    assert np.allclose(grid.sdf.reshape(-1)[grid.flat_index(points)][~colliding], distance[~colliding])


def test_the_articulated_path_agrees_with_the_rigid_kernel():
    context = passage()
    grid = VoxelGrid.from_scene(context.scene)
    rigid = Clearance(context.robot, grid)

    class NoPlacement:            # the same robot, seen through body_points only
        def __init__(self, robot):
            self.robot = robot

        def __getattr__(self, name):
            return getattr(self.robot, name)

        def rigid_placement(self, q):
            return None

    articulated = Clearance(NoPlacement(context.robot), grid)
    q = np.array([[0.2375, 0.12, 0.0], [0.2, 0.3, 0.0], [0.3, 0.42, 0.0], [0.59, 0.59, 0.0]])
    a, b = rigid.query(q), articulated.query(q)
    assert np.array_equal(a[2], b[2]) and np.allclose(a[0], b[0])
    assert list(a[2]) == [False, True, False, True]       # free; in the wall; free above; off the grid


def test_a_free_body_far_from_everything_is_free_and_far():
    context = Context(scene=pliant.load_scene("se3-peg-tight"))
    context.robot = pliant.registry.create("robot", "rigid", context)
    clearance = Clearance(context.robot, VoxelGrid.from_scene(context.scene))
    distance, _, colliding = clearance.query(np.array([[0.151, 0.151, 0.25, 0, 0, 0, 1.0]]))
    # the peg's bottom is 0.1 m above the block; the grid's ceiling is 0.4 - 0.3 = 0.1 m above its top
    assert not colliding[0] and distance[0] > 0.05
