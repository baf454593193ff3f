"""Clearance and collision queries (thesis 6.4.2) against a brute-force lookup of every surface point."""

import functools

import numba
import numpy as np
import pliant
from hypothesis import given, settings
from hypothesis import strategies as st
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


@numba.njit(cache=True)
def _every_point(rot, trans, local, sdf, occupied, shape, lower, resolution):
    """The rigid kernel before its broad phase (session 32), point by point: the reference, bit for bit."""
    n, m = rot.shape[0], local.shape[0]
    clearance, closest, colliding = np.empty(n), np.empty(n, dtype=np.int64), np.zeros(n, dtype=np.bool_)
    nx, ny, nz = shape[0], shape[1], shape[2]
    for i in range(n):
        best, arg, hit = np.inf, 0, False
        for j in range(m):
            p0 = rot[i, 0, 0] * local[j, 0] + rot[i, 0, 1] * local[j, 1] + rot[i, 0, 2] * local[j, 2] + trans[i, 0]
            p1 = rot[i, 1, 0] * local[j, 0] + rot[i, 1, 1] * local[j, 1] + rot[i, 1, 2] * local[j, 2] + trans[i, 1]
            p2 = rot[i, 2, 0] * local[j, 0] + rot[i, 2, 1] * local[j, 1] + rot[i, 2, 2] * local[j, 2] + trans[i, 2]
            a = int(np.floor((p0 - lower[0]) / resolution))
            b = int(np.floor((p1 - lower[1]) / resolution))
            c = int(np.floor((p2 - lower[2]) / resolution))
            if a < 0 or b < 0 or c < 0 or a >= nx or b >= ny or c >= nz:
                hit, best, arg = True, -np.inf, j
                break
            flat = (a * ny + b) * nz + c
            if occupied[flat]:
                hit = True
            if sdf[flat] < best:
                best, arg = sdf[flat], j
        clearance[i], closest[i], colliding[i] = best, arg, hit
    return clearance, closest, colliding


@functools.cache
def _peg_context():
    context = Context(scene=pliant.load_scene("se3-peg-tight"))
    context.robot = pliant.registry.create("robot", "rigid", context)
    return context


@settings(max_examples=12)
@given(st.integers(0, 2**32 - 1))
def test_the_broad_phase_changes_no_result_bit_for_bit(seed):
    """Configurations in, near, beside and off the obstacles of the passage and the tight peg-in-hole: the skipped
    segments change no clearance, closest point or collision."""
    from pliant.geometry.rotations import random_quaternions

    rng = np.random.default_rng(seed)
    passage_q = np.column_stack([rng.uniform(-0.05, 0.65, 400), rng.uniform(-0.05, 0.65, 400),
                                 rng.uniform(-4, 4, 400)])
    peg = _peg_context()
    lo, hi = np.asarray(peg.scene.lower), np.asarray(peg.scene.upper)
    goal = np.asarray(peg.scene.goal)
    near = goal[:3] + rng.normal(0.0, 0.01, (300, 3))                       # in and around the hole
    anywhere = rng.uniform(lo - 0.05, hi + 0.05, (100, 3))
    turns = np.where(rng.random((400, 1)) < 0.5, goal[3:], random_quaternions(rng, 400))
    peg_q = np.column_stack([np.vstack([near, anywhere]), turns])
    checked = 0
    for context, q in ((passage(), passage_q), (peg, peg_q)):
        clearance = Clearance(context.robot, VoxelGrid.from_scene(context.scene))
        rot, trans, _ = context.robot.rigid_placement(q)
        ours = clearance.query(q)
        reference = _every_point(np.ascontiguousarray(rot), np.ascontiguousarray(trans), clearance.local,
                                 clearance.sdf, clearance.occupied, clearance.shape, clearance.lower,
                                 float(clearance.grid.resolution))
        for a, b in zip(ours, reference):
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
        assert ours[2].any() and (~ours[2]).any()
        checked += len(clearance.segments[0]) - 1
    assert checked > 4                                                      # both bodies have several segments
