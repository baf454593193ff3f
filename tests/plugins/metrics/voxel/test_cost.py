"""The voxel cost component on the bundled scenes: values by hand, NaN cases, batches, breakdown, gradient."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import Scene, registry
from pliant.errors import DimensionError
from pliant.interfaces import Context
from pliant.testing import check_cost

RES = 0.008


def cell(i, j, k):
    return (np.array([i, j, k]) + 0.5) * RES


def test_free_space_costs_nothing(scene_context):
    ctx = scene_context("triple-wall", "voxel")
    assert ctx.cost.cost(ctx.scene.start)[0] == 0.0
    assert ctx.cost.cost(ctx.scene.goal)[0] == 0.0


def test_puck_inside_wall_costs_its_points_times_eq31(scene_context):
    ctx = scene_context("triple-wall", "voxel")
    # reference at (5, 15, 20): the puck spans x 1..8, y 11..18, z 19..21 -> wall1 (y in [12, 18)) with
    # all x and z in its solid part; rigid robot (D=0) on soft wall (0.5, 0.5) costs 0.5 per point.
    q = cell(5, 15, 20)
    pts = ctx.robot.body_points(q)[0]
    idx = np.floor(pts / RES).astype(int)
    in_wall = np.sum((idx[:, 1] >= 12) & (idx[:, 1] < 18))
    assert ctx.cost.cost(q)[0] == pytest.approx(0.5 * in_wall)
    assert in_wall > 0


def test_outside_the_grid_is_nan(scene_context):
    ctx = scene_context("triple-wall", "voxel")
    q = cell(1, 30, 24)   # the puck's x rows reach x = -3 (x - 5 + 1)
    assert np.isnan(ctx.cost.cost(q)[0])


def test_rigid_on_rigid_is_nan(scene_context):
    ctx = scene_context("cube-wall", "voxel")
    centre = np.array([0.5, 0.5, 0.5, 0, 0, 0, 1.0])  # the rigid core inside the rigid wall
    assert np.isnan(ctx.cost.cost(centre)[0])
    through_blue_hole = np.array([0.71, 0.5, 0.51, 0, 0, 0, 1.0])
    assert np.isfinite(ctx.cost.cost(through_blue_hole)[0])


def test_cube_through_the_holes_costs_the_overlap(scene_context):
    ctx = scene_context("cube-wall", "voxel")
    # blue hole 9 x 9 voxels, wall 2 voxels thick, cube 10 x 10 points centred on the hole: soft points
    # (D=0.5, S=1) on the rigid wall cost 1 each: 2 layers * (100 - 81) = 38.
    assert ctx.cost.cost(np.array([0.71, 0.5, 0.51, 0, 0, 0, 1.0]))[0] == pytest.approx(38.0)


def test_batch_equals_single_and_conformance(scene_context):
    ctx = scene_context("cube-wall", "voxel")
    rng = np.random.default_rng(3)
    q = ctx.robot.space.sample(rng, 50)
    q[:, :3] = rng.uniform(0.1, 0.9, (50, 3))
    check_cost(ctx.cost, ctx.robot.space, configurations=q)


@functools.cache
def _cube_wall():
    from pliant import load_scene

    ctx = Context(scene=load_scene("cube-wall"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx.robot.space, registry.create("cost", "voxel", ctx)


@settings(max_examples=40)
@given(st.integers(0, 2**32 - 1))
def test_fused_rigid_kernel_equals_the_sum_of_point_costs(seed):
    """cost() (fused transform; branch-free inside the grid, checked near and beyond its faces) equals the
    brute-force sum of every body point's cost, NaN where a point leaves the grid or rigid meets rigid."""
    space, cost = _cube_wall()
    rng = np.random.default_rng(seed)
    q = space.sample(rng, 100)
    q[:50, :3] = rng.uniform(0.2, 0.8, (50, 3))          # the rotated bounding box inside: branch-free path
    q[50:, :3] = rng.uniform(-0.1, 1.1, (50, 3))         # near the grid's faces and beyond them
    fused, brute = cost.cost(q), cost.point_costs(q).sum(axis=1)
    assert np.array_equal(np.isnan(fused), np.isnan(brute))
    assert np.allclose(fused[~np.isnan(fused)], brute[~np.isnan(brute)], rtol=0, atol=1e-9)


def test_wrong_width_raises(scene_context):
    ctx = scene_context("cube-wall", "voxel")
    with pytest.raises(DimensionError):
        ctx.cost.cost(np.zeros((2, 3)))


def test_translation_costs_equal_cost(scene_context):
    ctx = scene_context("triple-wall", "voxel")
    s = ctx.scene
    field = ctx.cost.translation_costs(s.lower + RES / 2, RES, s.shape)
    rng = np.random.default_rng(0)
    idx = rng.integers(0, s.shape, (400, 3))
    direct = ctx.cost.cost(s.lower + (idx + 0.5) * RES)
    assert np.allclose(field[idx[:, 0], idx[:, 1], idx[:, 2]], direct, equal_nan=True)


def test_translation_costs_on_another_lattice_fall_back(scene_context):
    ctx = scene_context("triple-wall", "voxel")
    s = ctx.scene
    field = ctx.cost.translation_costs(s.lower + RES, 2 * RES, (5, 5, 5))
    axes = [s.lower[i] + RES + 2 * RES * np.arange(5) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    assert np.allclose(field.reshape(-1), ctx.cost.cost(grid), equal_nan=True)


@given(st.integers(0, 2**32 - 1))
def test_translation_costs_on_random_scenes(seed):
    rng = np.random.default_rng(seed)
    shape = rng.integers(4, 9, 3)
    objects = []
    for k in range(3):
        lo = rng.integers(0, shape - 1)
        hi = np.minimum(lo + rng.integers(1, 4, 3), shape)
        objects.append({"name": f"o{k}", "cells": [[int(a), int(b)] for a, b in zip(lo, hi)],
                        "deformability": float(rng.choice([0.0, 0.3, 1.0])), "sensitivity": float(rng.uniform(0, 2))})
    data = {"name": "random", "start": [0.5, 0.5, 0.5], "goal": [0.5, 0.5, 0.5],
            "bounds": {"lower": [0.0, 0.0, 0.0], "upper": [float(n) for n in shape], "resolution": 1.0},
            "objects": objects,
            "robot": {"kind": "rigid", "space": "r3", "deformability": float(rng.choice([0.0, 0.5])),
                      "sensitivity": 1.0, "reference_cell": [1, 0, 0],
                      "parts": [{"cells": [[0, 2], [0, 1], [0, 2]]}, {"cells": [[2, 3], [0, 2], [0, 1]],
                                                                      "deformability": 0.2}]}}
    ctx = Context(scene=Scene.from_dict(data))
    ctx.robot = registry.create("robot", "rigid", ctx)
    cost = registry.create("cost", "voxel", ctx)
    field = cost.translation_costs(np.full(3, 0.5), 1.0, tuple(int(n) for n in shape))
    axes = [0.5 + np.arange(n) for n in shape]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    assert np.allclose(field.reshape(-1), cost.cost(grid), equal_nan=True)


def test_breakdown_separates_objects_and_sums_to_cost(scene_context):
    ctx = scene_context("multi-cost", "voxel")
    names = ctx.cost.feature_names()
    assert names == ["wall1-low", "wall1-high", "wall2-high", "wall2-low"]
    s = ctx.scene
    idx = np.array([[8, 21, 2], [22, 21, 2], [15, 45, 2], [15, 21, 7]])
    q = s.lower + (idx + 0.5) * RES
    b = ctx.cost.breakdown(q)
    assert np.allclose(b.sum(axis=1), ctx.cost.cost(q))
    assert b[0, 0] > 0 and b[0, 1:].sum() == 0          # only the low half of wall 1
    assert b[1, 1] > 0 and b[1, [0, 2, 3]].sum() == 0   # only the high half of wall 1
    assert b[2, 2] > 0 and b[2, 3] > 0                  # straddles the two halves of wall 2
    assert b[3].sum() == 0                              # inside the opening


@pytest.mark.parametrize("name", ["multi-cost", "cube-wall", "hollow-cube"])
def test_the_rigid_breakdown_kernel_matches_a_per_point_reference(scene_context, name):
    ctx = scene_context(name, "voxel")
    q = ctx.space.sample(np.random.default_rng(3), 400)
    fast = ctx.cost.breakdown(q)
    # reference: every body point's cost from point_costs, added to the object of its voxel
    pts, costs = ctx.robot.body_points(q), ctx.cost.point_costs(q)
    flat = ctx.cost.grid.flat_index(pts)
    ids = np.where(flat >= 0, ctx.cost.grid.object_id.reshape(-1)[np.maximum(flat, 0)], -1)
    reference = np.zeros_like(fast)
    for a in range(len(q)):
        if not np.all(np.isfinite(costs[a])):
            reference[a] = np.nan
            continue
        for o in range(fast.shape[1]):
            reference[a, o] = costs[a][ids[a] == o].sum()
    assert np.allclose(fast, reference, equal_nan=True)
    finite = np.isfinite(fast).all(axis=1)
    assert finite.any() and (fast[finite] > 0).any()                   # the sample meets objects and free space
    assert np.allclose(fast[finite].sum(axis=1), ctx.cost.cost(q[finite]))


@pytest.mark.parametrize("name", ["multi-cost", "hollow-cube"])
def test_the_breakdowns_compressed_tables_give_every_voxels_cost_and_object_bit_for_bit(scene_context, name):
    cost = scene_context(name, "voxel").cost
    codes, lut, object_of_code = cost._breakdown_form()
    assert codes.dtype == np.uint8 and len(codes) == cost.table.shape[1]
    np.testing.assert_array_equal(lut[:, codes], cost.table)                    # NaN where the table has NaN
    np.testing.assert_array_equal(object_of_code[codes], cost._object_of_voxel)


@pytest.mark.parametrize("name", ["multi-cost", "hollow-cube"])
def test_the_rigid_breakdown_kernel_equals_the_per_point_formula_bit_for_bit(scene_context, name):
    """Each point in voxel floor(((R p) + t - lower) / res), summed into its object in the points' order: the same
    arithmetic in numpy, so the two-pass kernel (truncation inside the grid, floor outside) must agree exactly."""
    ctx = scene_context(name, "voxel")
    cost = ctx.cost
    q = ctx.space.sample(np.random.default_rng(11), 300)
    rot, pos, local = ctx.robot.rigid_placement(q)
    lx, ly, lz = local.T
    m = pos - cost._lower
    idx = [np.floor((rot[:, k, 0, None] * lx + rot[:, k, 1, None] * ly + rot[:, k, 2, None] * lz + m[:, k, None])
                    * cost._inv_res).astype(np.int64) for k in range(3)]
    shape = cost._shape
    inside = np.all([(0 <= i) & (i < n) for i, n in zip(idx, shape)], axis=0)
    flat = np.where(inside, (idx[0] * shape[1] + idx[1]) * shape[2] + idx[2], cost.table.shape[1] - 1)
    point_cost = cost.table[cost.classes[None, :], flat]
    objects = cost._object_of_voxel[flat]
    reference = np.zeros((len(q), len(cost.feature_names())))
    for a in range(len(q)):
        if not np.isfinite(point_cost[a]).all():
            reference[a] = np.nan
            continue
        hit = objects[a] >= 0
        np.add.at(reference[a], objects[a][hit], point_cost[a][hit])
    breakdown = cost.breakdown(q)
    np.testing.assert_array_equal(breakdown, reference)
    finite = np.isfinite(breakdown).all(axis=1)
    assert finite.any() and (~finite).any() and (breakdown[finite] > 0).any()    # both of the kernel's paths, objects


def _soft_maze() -> Context:
    import tomllib

    from pliant.scene import apply_patch, resolve_scene_path

    path = resolve_scene_path("se2-maze")
    data = apply_patch(tomllib.loads(path.read_text()), {"robot.deformability": 0.5}, str(path), "test")
    ctx = Context(scene=Scene.from_dict(data, source=str(path), base_dir=path.parent))
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.cost = registry.create("cost", "voxel", ctx)
    return ctx


@pytest.mark.parametrize("scene", ["triple-wall", "cube-wall", "se2-maze (soft robot)"])
def test_gradient_matches_finite_differences_of_the_surrogate(scene, scene_context):
    ctx = _soft_maze() if scene.startswith("se2") else scene_context(scene, "voxel")
    space = ctx.robot.space
    rng = np.random.default_rng(1)
    cost = ctx.cost
    checked = 0
    for _ in range(200):
        q = space.sample(rng, 1)[0]
        pts = ctx.robot.body_points(q)[0]
        point_costs = cost.point_costs(q)[0]
        depth = -cost.grid.sdf_at(pts)
        if not (np.all(np.isfinite(point_costs)) and np.any(depth > 0.25 * ctx.scene.resolution)):
            continue
        weights = np.where(depth > 0, point_costs, 0.0)

        def surrogate(x, weights=weights):
            return float(np.sum(weights * np.maximum(0.0, -cost.grid.sdf_at(ctx.robot.body_points(x)[0]))))

        assert cost.surrogate(q)[0] == pytest.approx(surrogate(q))
        eps = 1e-7
        fd = np.array([(surrogate(space.retract(q, eps * e)) - surrogate(space.retract(q, -eps * e))) / (2 * eps)
                       for e in np.eye(space.tangent_dim)])
        assert np.allclose(cost.gradient(q)[0], fd, rtol=1e-4, atol=1e-6 * max(1.0, np.abs(fd).max()))
        checked += 1
        if checked == 3:
            break
    assert checked >= 1


def test_gradient_is_zero_in_free_space(scene_context):
    ctx = scene_context("triple-wall", "voxel")
    assert np.all(ctx.cost.gradient(ctx.scene.start) == 0)


def test_padding_grows_objects(scene_context):
    ctx = scene_context("cube-wall")
    plain = registry.create("cost", "voxel", ctx)
    padded = registry.create("cost", "voxel", ctx, padding=0.04)
    assert padded.grid.occupied.sum() > plain.grid.occupied.sum()
    q = np.array([0.71, 0.5, 0.51, 0, 0, 0, 1.0])
    assert padded.cost(q)[0] > plain.cost(q)[0]


def test_the_fused_sdf_kernel_equals_the_grid_interpolation():
    import pliant
    from pliant.interfaces import Context

    ctx = Context(scene=pliant.load_scene("cube-wall"))
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    cost = pliant.registry.create("cost", "voxel", ctx)
    rng = np.random.default_rng(0)
    q = ctx.robot.space.sample(rng, 6)
    q[:3, :3] = [[0.7, 0.5, 0.5], [0.3, 0.48, 0.5], [-0.2, 1.3, 0.5]]      # in a hole, at the wall, outside
    points = ctx.robot.body_points(q)
    value, gradient = cost._sdf_with_gradient(points)
    assert np.allclose(value, cost.grid.sdf_at(points), atol=1e-12)
    assert np.allclose(gradient, cost.grid.sdf_gradient_at(points), atol=1e-12)
