"""The reference optimiser (pliant_tsrrt.reference.reference_optimum), the denominator of TS-RRT's benchmark ratios:
on small cases it matches or beats an exhaustive search over a grid of poses."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from pliant_tsrrt.cost import TaskCost
from pliant_tsrrt.geometry import BOX, CIRCLE, CollisionChecker, Footprints
from pliant_tsrrt.pushing import PushSettings
from pliant_tsrrt.reference import optimise, patterns, reference_optimum
from pliant_tsrrt.search import ObjectSpace

TABLE = (0.1, -0.05, 0.6, 0.35)           # 0.5 x 0.4 m, off the origin
BOUNDS = (-0.1, -0.25, 0.8, 0.55)
NO_OBSTACLES = (Footprints(np.zeros(0, dtype=int), np.zeros((0, 2))), np.zeros((0, 3)))


def _space(fp: Footprints, margin: float = 0.01) -> ObjectSpace:
    checker = CollisionChecker(fp, NO_OBSTACLES[0], NO_OBSTACLES[1], TABLE, margin)
    means = np.zeros((len(fp), 6, 3))
    return ObjectSpace(fp, means, checker, TaskCost(fp, TABLE, (1.0, 1.0, 1.0, 0.0)), PushSettings(), BOUNDS)


def _exhaustive(space: ObjectSpace, step: float = 0.02) -> float:
    """The cheapest collision-free arrangement of two objects over every pair of grid poses: centres on a ``step``
    m grid over the table, every yaw a multiple of 45 degrees (boxes; circles at yaw 0)."""
    x0, y0, x1, y1 = TABLE
    xs, ys = np.arange(x0, x1 + 1e-9, step), np.arange(y0, y1 + 1e-9, step)
    grid = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    per = []
    for o in range(2):
        yaws = np.arange(4) * (np.pi / 4) if space.fp.kind[o] == BOX else np.zeros(1)
        poses = np.concatenate([np.repeat(grid, len(yaws), 0), np.tile(yaws, len(grid))[:, None]], 1)
        alone = np.zeros((len(poses), 2, 3))
        alone[:, o] = poses
        alone[:, 1 - o] = (-10.0, -10.0, 0.0)        # the other object far away: only this one's table check
        keep = ~space.checker.off_table(alone)[:, o]
        per.append(poses[keep])
    best = np.inf
    a, b = per
    for chunk in np.array_split(np.arange(len(a)), max(1, len(a) // 100)):
        states = np.empty((len(chunk) * len(b), 2, 3))
        states[:, 0] = np.repeat(a[chunk], len(b), 0)
        states[:, 1] = np.tile(b, (len(chunk), 1))
        cost = space.cost.cost(states)
        cost[space.checker.in_collision(states)] = np.inf
        best = min(best, float(cost.min()))
    return best


@pytest.mark.parametrize("kinds, halves", [
    ((BOX, BOX), ((0.12, 0.08), (0.05, 0.05))),          # a book and a block
    ((BOX, CIRCLE), ((0.13, 0.04), (0.05, 0.05))),       # a slab and a can
])
def test_the_reference_matches_or_beats_an_exhaustive_search_on_two_objects(kinds, halves):
    space = _space(Footprints(np.array(kinds), np.array(halves)))
    space.warm_up()
    exhaustive = _exhaustive(space)
    pose, cost = reference_optimum(space, np.random.default_rng(0), rounds=600, population=32, pattern_count=128)
    assert not space.checker.in_collision(pose[None])[0]
    assert cost == pytest.approx(float(space.cost.cost(pose[None])[0]))
    assert cost <= exhaustive + 1e-9


def test_the_reference_is_never_worse_than_the_single_start_optimiser_it_replaces():
    space = _space(Footprints(np.array([BOX, BOX, CIRCLE]), np.array([[0.1, 0.04], [0.06, 0.06], [0.04, 0.04]])))
    space.warm_up()
    _, single = optimise(space, np.random.default_rng(0), rounds=600, population=32)
    _, multi = reference_optimum(space, np.random.default_rng(0), rounds=600, population=32, pattern_count=128)
    assert multi <= single + 1e-9


def test_patterns_are_collision_free_table_aligned_and_on_the_table():
    space = _space(Footprints(np.array([BOX, BOX, CIRCLE, BOX]),
                              np.array([[0.1, 0.04], [0.05, 0.05], [0.04, 0.04], [0.08, 0.03]])))
    pats = patterns(space, np.random.default_rng(3), 64)
    assert len(pats) > 0
    assert not space.checker.in_collision(pats).any()
    quarter = np.pi / 2
    assert np.allclose((pats[..., 2] + 1e-12) % quarter, 0.0, atol=1e-9)


def test_packed_targets_of_the_improvement_phase_keep_the_clearance():
    from dataclasses import replace

    from pliant_tsrrt.refine import targets

    space = _space(Footprints(np.array([BOX, BOX, CIRCLE]), np.array([[0.1, 0.04], [0.06, 0.06], [0.04, 0.04]])))
    s = np.array([[0.2, 0.0, 0.3], [0.45, 0.2, 0.0], [0.3, 0.25, 0.0]])
    found = targets(space, s, np.random.default_rng(0), count=4, rounds=100, slack=0.003, packed=16)
    assert len(found) >= 1
    wider = replace(space.checker, margin=space.checker.margin + 0.003)
    assert not wider.in_collision(found).any()


def test_mirror_images_across_the_table_cost_the_same_and_are_the_same_footprints_mirrored():
    """Without obstacles or a table setting the task cost is symmetric across the table's centre lines; each mirror
    image's box corners are the original's corners mirrored (so the yaw map is right), and the original comes first."""
    from pliant_tsrrt.geometry import box_corners
    from pliant_tsrrt.refine import table_mirrors

    fp = Footprints(np.array([BOX, BOX, CIRCLE]), np.array([(0.12, 0.04), (0.05, 0.03), (0.04, 0.04)]))
    space = _space(fp)
    s = np.array([[0.3, 0.1, 0.3], [0.45, 0.22, -1.1], [0.5, 0.03, 2.0]])
    assert not space.checker.in_collision(s[None])[0]
    images = table_mirrors(space, s)
    assert len(images) == 4 and np.array_equal(images[0], s)
    assert space.cost.cost(images) == pytest.approx(np.full(4, space.cost.cost(s[None])[0]), rel=1e-12)
    x0, y0, x1, y1 = TABLE
    for image, (fx, fy) in zip(images[1:], ((True, False), (False, True), (True, True))):
        for o in range(2):
            corners = box_corners(s[o], fp.half[o])
            mirrored = corners.copy()
            if fx:
                mirrored[:, 0] = x0 + x1 - mirrored[:, 0]
            if fy:
                mirrored[:, 1] = y0 + y1 - mirrored[:, 1]
            got = box_corners(image[o], fp.half[o])
            # the same set of corners (their order may differ)
            assert np.allclose(np.sort(np.round(got, 9), axis=0), np.sort(np.round(mirrored, 9), axis=0))


def test_a_mirror_image_that_collides_with_an_obstacle_is_left_out():
    from pliant_tsrrt.refine import table_mirrors

    fp = Footprints(np.array([CIRCLE]), np.array([(0.04, 0.04)]))
    obstacle = Footprints(np.array([CIRCLE]), np.array([(0.05, 0.05)]))
    x0, _, x1, _ = TABLE
    s = np.array([[0.2, 0.05, 0.0]])
    # an obstacle where the x-mirror of the object lands
    checker = CollisionChecker(fp, obstacle, np.array([[x0 + x1 - 0.2, 0.05, 0.0]]), TABLE, 0.01)
    space = ObjectSpace(fp, np.zeros((1, 6, 3)), checker, TaskCost(fp, TABLE, (1.0, 1.0, 1.0, 0.0)), PushSettings(),
                        BOUNDS)
    images = table_mirrors(space, s)
    assert len(images) == 3
    assert not any(np.allclose(image[0, :2], (x0 + x1 - 0.2, 0.05)) for image in images)


def test_the_optimum_targets_are_the_reference_optimum_and_its_images_with_every_order_or_a_sample():
    from pliant_tsrrt.refine import optimum_targets

    fp = Footprints(np.array([BOX, CIRCLE, CIRCLE]), np.array([(0.06, 0.03), (0.04, 0.04), (0.03, 0.03)]))
    space = _space(fp)
    space.warm_up()
    targets, orders = optimum_targets(space, np.random.default_rng(0), rounds=200, orders=120)
    _, best = reference_optimum(space, np.random.default_rng(0), rounds=200)
    assert 1 <= len(targets) <= 4 and space.cost.cost(targets[:1])[0] == pytest.approx(best)
    assert not space.checker.in_collision(targets).any()
    assert sorted(orders) == sorted(itertools.permutations(range(3)))      # 3! <= 120: all of them
    _, sampled = optimum_targets(space, np.random.default_rng(0), rounds=200, orders=4)
    assert len(sampled) == 4 and all(sorted(o) == [0, 1, 2] for o in sampled)           # 3! > 4: a sample
    _, none = optimum_targets(space, np.random.default_rng(0), rounds=200, orders=0)
    assert none == []


def test_a_deadline_cuts_the_optimums_descents_short_without_losing_the_starts():
    # a time budget gives the optimum's descents a deadline (TS-RRT's improvement phase: half of its time left); one
    # already past stops them before their first round, so the answer is the cheapest collision-free start
    import time

    fp = Footprints(np.array([BOX, CIRCLE, CIRCLE]), np.array([(0.06, 0.03), (0.04, 0.04), (0.03, 0.03)]))
    space = _space(fp)
    space.warm_up()
    past = time.perf_counter() - 1.0
    pose, cut = reference_optimum(space, np.random.default_rng(0), rounds=200, deadline=past)
    _, full = reference_optimum(space, np.random.default_rng(0), rounds=200)
    assert not space.checker.in_collision(pose[None])[0] and full < cut < np.inf
    pose_again, again = reference_optimum(space, np.random.default_rng(0), rounds=200, deadline=past)
    assert again == cut and np.array_equal(pose, pose_again)


def test_the_basins_are_the_reference_optimum_then_cheaper_minima_apart_from_every_one_kept():
    from pliant_tsrrt.refine import BASIN_DISTANCE, _arrangement_distance, optimum_basins

    fp = Footprints(np.array([BOX, CIRCLE, CIRCLE]), np.array([(0.06, 0.03), (0.04, 0.04), (0.03, 0.03)]))
    space = _space(fp)
    space.warm_up()
    minima, costs = optimum_basins(space, np.random.default_rng(0), 4, rounds=200)
    best, best_cost = reference_optimum(space, np.random.default_rng(0), rounds=200)
    assert np.array_equal(minima[0], best) and costs[0] == best_cost          # the first is the reference's answer
    assert 2 <= len(minima) <= 4 and np.all(np.diff(costs) >= 0)
    assert np.allclose(space.cost.cost(minima), costs) and not space.checker.in_collision(minima).any()
    box, reach = space.scale > 0, np.where(space.scale > 0, space.scale, 0.0)
    for i in range(len(minima)):
        for j in range(i):
            assert _arrangement_distance(minima[i], minima[j], box, reach) > BASIN_DISTANCE


def test_the_distance_between_arrangements_counts_a_box_turned_a_half_turn_as_unmoved():
    from pliant_tsrrt.refine import _arrangement_distance

    box, reach = np.array([True, False]), np.array([0.1, 0.0])
    a = np.array([[0.3, 0.2, 0.1], [0.5, 0.5, 0.0]])
    b = a.copy()
    b[0, 2] += np.pi                                  # a box is symmetric under a half turn
    b[1, 2] += 1.0                                    # a circle's yaw does not matter
    assert _arrangement_distance(a, b, box, reach) < 1e-12
    b[0, 2] += 0.3                                    # its corner moves 0.3 rad x 0.1 m
    b[1, :2] += (0.03, 0.04)                          # 5 cm
    assert np.isclose(_arrangement_distance(a, b, box, reach), 0.05)
    b[1, :2] -= (0.03, 0.04)
    assert np.isclose(_arrangement_distance(a, b, box, reach), 0.03)


def test_more_basins_give_each_minimum_and_its_images_as_targets():
    from pliant_tsrrt.refine import optimum_basins, optimum_targets, table_mirrors

    fp = Footprints(np.array([BOX, CIRCLE, CIRCLE]), np.array([(0.06, 0.03), (0.04, 0.04), (0.03, 0.03)]))
    space = _space(fp)
    space.warm_up()
    targets, _ = optimum_targets(space, np.random.default_rng(0), rounds=200, basins=3)
    minima, _ = optimum_basins(space, np.random.default_rng(0), 3, rounds=200)
    expected = np.concatenate([table_mirrors(space, m) for m in minima])
    assert len(minima) >= 2 and np.array_equal(targets, expected)
    one, _ = optimum_targets(space, np.random.default_rng(0), rounds=200, basins=1)
    assert np.array_equal(one, table_mirrors(space, minima[0]))
