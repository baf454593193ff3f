"""The improvement phase of TS-RRT (pliant_tsrrt.refine) on hand-made models: variants, the free descent, pushing
one object toward a target, and grow() with and without it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from pliant.termination import Termination
from pliant_tsrrt.cost import TaskCost
from pliant_tsrrt.geometry import BOX, CIRCLE, CollisionChecker, Footprints
from pliant_tsrrt.options import ImprovementOptions, TSRRTOptions
from pliant_tsrrt.pushing import PushSettings
from pliant_tsrrt.refine import (
    connect,
    final_beam,
    finishing_push,
    free_descent,
    improve,
    interchangeable,
    nearest_assignments,
    push_toward,
    random_free,
    reachable_targets,
    targets,
    turned_first,
    variants,
    yaw_lattice,
    yaw_snapper,
)
from pliant_tsrrt.search import ObjectSpace, grow, redundant_actions

TABLE = (0.0, 0.0, 1.0, 0.8)
BOUNDS = (-0.2, -0.2, 1.2, 1.0)
NO_OBSTACLES = (Footprints(np.zeros(0, dtype=int), np.zeros((0, 2))), np.zeros((0, 3)))


def _options(max_nodes: int = 5000, **improvement) -> TSRRTOptions:
    """TS-RRT's options with ``max_nodes`` and these ``improvement`` options (pushes are free unless ``push_cost``)."""
    return TSRRTOptions(max_nodes=max_nodes, improvement=ImprovementOptions(**{"push_cost": 0.0, **improvement}))
CAN_MODEL = [[0.05, 0, 0], [-0.05, 0, 0], [0, 0.05, 0], [0, -0.05, 0], [-0.01, 0.02, 0], [0.01, 0.02, 0]]
BOOK_MODEL = [[0.047, 0, 0], [-0.047, 0, 0], [0, 0.047, 0], [0, -0.046, 0], [0, 0.001, 0.19], [0, -0.001, -0.2]]


def _space(fp, means, weights, margin=0.01):
    checker = CollisionChecker(fp, NO_OBSTACLES[0], NO_OBSTACLES[1], TABLE, margin)
    return ObjectSpace(fp, np.asarray(means, dtype=float), checker, TaskCost(fp, TABLE, weights), PushSettings(),
                       BOUNDS)


def _three():
    fp = Footprints([BOX, BOX, CIRCLE], [[0.12, 0.08], [0.05, 0.05], [0.05, 0.05]])
    return _space(fp, [BOOK_MODEL, BOOK_MODEL, CAN_MODEL], (1.0, 1.0, 1.0, 0.0))


def test_variants_permute_places_and_turn_boxes():
    space = _three()
    s = np.array([[0.3, 0.3, 0.1], [0.6, 0.5, 0.0], [0.7, 0.2, 0.0]])
    v = variants(space, s)
    assert v.shape == (6 * 4, 3, 3)                   # 3! places x every subset of the two boxes turned
    assert np.array_equal(v[0], s)
    for t in v:                                       # the same places, each box turned by 0 or a quarter turn
        assert sorted(map(tuple, t[:, :2])) == sorted(map(tuple, s[:, :2]))
        assert np.all(np.isclose((t[:2, 2] - s[:2, 2]) % (0.5 * np.pi), 0.0) | np.isclose(t[:2, 2] - s[:2, 2],
                                                                                           0.5 * np.pi))
        assert t[2, 2] == s[2, 2]


def test_free_descent_keeps_members_collision_free_and_never_raises_their_cost():
    space = _three()
    s = np.array([[0.3, 0.3, 0.1], [0.6, 0.5, 0.0], [0.7, 0.2, 0.0]])
    starts = np.repeat(s[None], 8, axis=0)
    pop, cost = free_descent(space, starts, np.random.default_rng(0), rounds=200, slack=0.003)
    assert np.all(cost <= space.cost.cost(s[None])[0] + 1e-12)
    assert not replace(space.checker, margin=0.013).in_collision(pop).any()
    assert np.allclose(space.cost.cost(pop), cost)
    goals = targets(space, s, np.random.default_rng(1), count=2, rounds=200)
    assert 1 <= len(goals) <= 2 and not space.checker.in_collision(goals).any()


def test_push_toward_reaches_a_reachable_target_exactly():
    fp = Footprints([CIRCLE], [[0.05, 0.05]])
    space = _space(fp, [CAN_MODEL], (0.0, 0.0, 1.0, 0.0), margin=0.0)
    s = np.array([[0.2, 0.3, 0.0]])
    cost, actions, end = push_toward(space, s, 0, np.array([0.4, 0.4, 0.0]), depth=10, width=16)
    assert np.isclose(cost, 0.125) and len(actions) == 6                  # 4 x push+x, 2 x push+y in some order
    assert sorted(actions) == [0, 0, 0, 0, 2, 2]
    assert np.allclose(end, [[0.4, 0.4, 0.0]])
    states, ok = space.rollout(s, actions)
    assert ok and np.allclose(states[-1], end)


def test_improve_never_returns_a_worse_or_invalid_plan():
    space = _three()
    path = np.array([[[0.25, 0.25, 0.3], [0.75, 0.55, 0.2], [0.8, 0.2, 0.0]]])
    cost, keep, actions, stats = improve(space, path, np.random.default_rng(2), rounds=150, depth=12, width=16,
                                         passes=1, max_orders=2)
    assert keep == 0 and stats["refine_connects"] > 0
    states, ok = space.rollout(path[0], actions)
    assert ok and np.isclose(space.cost.cost(states[-1][None])[0], cost)
    assert cost < space.cost.cost(path[:1])[0]


def test_grow_with_the_improvement_phase_is_no_worse_and_has_no_redundant_actions():
    space = _three()
    s0 = np.array([[0.25, 0.25, 0.3], [0.75, 0.55, 0.2], [0.8, 0.2, 0.0]])
    base = _options(refine_width=16, refine_depth=12, refine_rounds=150, refine_passes=1, refine_branches=1)
    off = _options(refine=False, refine_width=16, refine_depth=12, refine_rounds=150, refine_passes=1,
                   refine_branches=1)
    plain = grow(space, s0, np.random.default_rng(3), off, Termination(max_iterations=150))
    better = grow(space, s0, np.random.default_rng(3), base, Termination(max_iterations=150))
    assert better.statistics["tree_best_cost"] == plain.statistics["tree_best_cost"]     # the same tree
    assert better.cost <= plain.cost + 1e-12
    states, ok = space.rollout(s0, better.actions)
    assert ok and np.isclose(space.cost.cost(states[-1][None])[0], better.cost)
    assert not space.checker.in_collision(states).any()
    assert redundant_actions(space, s0, better.actions) == 0


def _two_cans():
    fp = Footprints([CIRCLE, CIRCLE], [[0.05, 0.05], [0.05, 0.05]])
    return _space(fp, [CAN_MODEL, CAN_MODEL], (0.0, 1.0, 0.0, 0.0))         # compactness alone


def test_an_object_whose_way_first_raises_the_cost_is_still_brought_to_its_target():
    space = _two_cans()
    s = np.array([[0.2, 0.4, 0.0], [0.5, 0.4, 0.0]])
    target = np.array([[0.6, 0.4, 0.0], [0.5, 0.4, 0.0]])     # the other can's far side: around it, through a wider box
    _, actions, end = push_toward(space, s, 0, target[0], depth=20, width=32)
    assert end[0, 0] > 0.55 and np.linalg.norm(end[0, :2] - target[0, :2]) < 0.03     # past the other can
    cost, actions = connect(space, s, target, (0, 1), depth=20, width=32)
    states, ok = space.rollout(s, actions)
    assert ok and np.isclose(space.cost.cost(states[-1][None])[0], cost)
    assert cost < space.cost.cost(s[None])[0] and np.isclose(cost, space.cost.cost(states).min())   # cut there
    cache: dict = {}
    assert connect(space, s, target, (0, 1), depth=20, width=32, cache=cache) == (cost, actions)
    assert cache and connect(space, s, target, (0, 1), depth=20, width=32, cache=cache) == (cost, actions)


def test_random_free_arrangements_keep_the_clearance():
    space = _three()
    out = random_free(space, np.random.default_rng(4), 16, margin=0.013)
    assert out.shape == (16, 3, 3) and not replace(space.checker, margin=0.013).in_collision(out).any()
    s = np.array([[0.3, 0.3, 0.1], [0.6, 0.5, 0.0], [0.7, 0.2, 0.0]])
    goals = targets(space, s, np.random.default_rng(1), count=3, rounds=100, randoms=8)
    assert 1 <= len(goals) <= 3 and not space.checker.in_collision(goals).any()


def test_a_beam_with_a_yaw_quota_still_aligns_a_box_that_needs_pairs_of_turns():
    # turns of +0.19 and -0.20 rad: a yaw 0.05 rad off is closed by five pairs of turns (ten pushes), each pair
    # first 0.19 rad farther off; at most two poses per yaw bin, eight in the beam
    fp = Footprints([BOX], [[0.12, 0.08]])
    space = _space(fp, [BOOK_MODEL], (1.0, 0.0, 0.0, 0.0))
    s = np.array([[0.5, 0.4, 0.05]])
    _, actions, end = push_toward(space, s, 0, np.array([0.5, 0.4, 0.0]), depth=16, width=8, yaw_quota=2)
    assert space.rollout(s, actions)[1]
    assert abs(end[0, 2]) < 1e-6 and sorted(set(actions)) == [4, 5]


def test_the_final_beam_lowers_the_cost_through_valid_pushes_or_returns_nothing():
    space = _three()
    rng = np.random.default_rng(5)
    for s in random_free(space, rng, 6, 0.01):
        start = float(space.cost.cost(s[None])[0])
        cost, actions = final_beam(space, s, depth=3, width=32)
        assert cost <= start
        states, ok = space.rollout(s, actions)
        assert ok and np.isclose(float(space.cost.cost(states[-1][None])[0]), cost)
        assert (cost < start) == bool(actions)


def test_push_cost_cuts_a_connection_and_the_final_beam_where_a_push_gains_less():
    # the book at yaw 0.3 rad, orthogonality alone, turns of exactly -0.1 rad: the three turns to yaw 0 gain 0.167,
    # 0.112 and 0.0395 (sin^2(2 theta) = 0.3188, 0.1516, 0.0395, 0)
    fp = Footprints([BOX], [[0.12, 0.08]])
    turns = [[0.047, 0, 0], [-0.047, 0, 0], [0, 0.047, 0], [0, -0.046, 0], [0, 0, 0.1], [0, 0, -0.1]]
    space = _space(fp, [turns], (1.0, 0.0, 0.0, 0.0))
    s = np.array([[0.5, 0.4, 0.3]])
    target = np.array([[0.5, 0.4, 0.0]])
    assert connect(space, s, target, (0,), depth=6, width=16)[1] == [5, 5, 5]
    cost, actions = connect(space, s, target, (0,), depth=6, width=16, push_cost=0.05)
    assert actions == [5, 5] and np.isclose(cost, np.sin(0.2) ** 2)
    assert final_beam(space, s, depth=4, width=32)[1] == [5, 5, 5]
    cost, actions = final_beam(space, s, depth=4, width=32, push_cost=0.05)
    assert actions == [5, 5] and np.isclose(cost, np.sin(0.2) ** 2)
    assert final_beam(space, s, depth=4, width=32, push_cost=0.2) == (float(np.sin(0.6) ** 2), [])


def test_push_cost_prefers_the_shorter_of_two_connections_of_nearly_equal_cost():
    # the same book (turns only): improve() connects the path's end to the free descent's targets (at yaw 0 and at a
    # quarter turn; the way to the latter first raises the cost); with a push cost the connection is cut after two
    # turns, a score of 0.0395 + 2 x 0.05 against 0 + 3 x 0.05 for three turns
    fp = Footprints([BOX], [[0.12, 0.08]])
    turns = [[0.0, 0, 0], [0.0, 0, 0], [0, 0.0, 0], [0, 0.0, 0], [0, 0, 0.1], [0, 0, -0.1]]
    space = _space(fp, [turns], (1.0, 0.0, 0.0, 0.0))
    path = np.array([[[0.5, 0.4, 0.3]]])
    cost, keep, actions, _ = improve(space, path, np.random.default_rng(0), count=4, rounds=100, depth=8,
                                     width=16)
    assert keep == 0 and sorted(actions) == [5, 5, 5] and cost < 1e-9
    cost, keep, actions, _ = improve(space, path, np.random.default_rng(0), count=4, rounds=100, depth=8,
                                     width=16, push_cost=0.05)
    assert keep == 0 and actions == [5, 5] and np.isclose(cost, np.sin(0.2) ** 2)


def test_a_connection_with_enough_stops_where_it_first_reaches_it():
    fp = Footprints([BOX], [[0.12, 0.08]])
    turns = [[0.047, 0, 0], [-0.047, 0, 0], [0, 0.047, 0], [0, -0.046, 0], [0, 0, 0.1], [0, 0, -0.1]]
    space = _space(fp, [turns], (1.0, 0.0, 0.0, 0.0))
    s = np.array([[0.5, 0.4, 0.3]])
    cost, actions = connect(space, s, np.array([[0.5, 0.4, 0.0]]), (0,), depth=6, width=16, enough=0.2)
    assert actions == [5] and np.isclose(cost, np.sin(0.4) ** 2)           # 0.1516: the first state below 0.2
    assert final_beam(space, s, depth=4, width=32, enough=0.2)[1] == [5]


def test_the_finishing_push_takes_the_stroke_that_lowers_the_cost_most():
    # the book at yaw 0.07 rad, orthogonality alone, turns of exactly -0.2 rad: a whole turn overshoots to -0.13 rad
    # (sin^2(2 theta) 0.0663 against 0.0193 now); a third of one lands at 0.0033 rad, the best of the strokes offered
    fp = Footprints([BOX], [[0.12, 0.08]])
    turns = [[0.047, 0, 0], [-0.047, 0, 0], [0, 0.047, 0], [0, -0.046, 0], [0, 0, 0.2], [0, 0, -0.2]]
    space = _space(fp, [turns], (1.0, 0.0, 0.0, 0.0))
    s = np.array([[0.5, 0.4, 0.07]])
    assert finishing_push(space, s, (1.0,)) is None                        # no whole push lowers the cost
    cost, action, stroke, after = finishing_push(space, s, (1 / 3, 0.5, 1.0))
    assert action == 5 and stroke == 1 / 3
    np.testing.assert_allclose(after, [[0.5, 0.4, 0.07 - 0.2 / 3]], atol=1e-12)
    assert np.isclose(cost, np.sin(2 * (0.07 - 0.2 / 3)) ** 2)
    # at the optimum nothing is offered
    assert finishing_push(space, np.array([[0.5, 0.4, 0.0]]), (0.25, 0.5, 1.0)) is None


def _books_and_can(relations=None):
    fp = Footprints([BOX, CIRCLE, BOX, CIRCLE], [[0.12, 0.08], [0.05, 0.05], [0.12, 0.08], [0.04, 0.04]])
    cost = TaskCost(fp, TABLE, (1.0, 1.0, 1.0, 1.0 if relations is not None else 0.0),
                    relations if relations is not None else np.zeros((0, 4)))
    checker = CollisionChecker(fp, NO_OBSTACLES[0], NO_OBSTACLES[1], TABLE, 0.01)
    return ObjectSpace(fp, np.asarray([BOOK_MODEL, CAN_MODEL, BOOK_MODEL, CAN_MODEL], dtype=float), checker, cost,
                       PushSettings(), BOUNDS)


def test_identical_objects_are_interchangeable_unless_a_setting_names_them():
    assert interchangeable(_books_and_can()) == [[0, 2]]            # the two books; the cans differ in size
    assert interchangeable(_books_and_can(np.array([[2, -1, 0.3, 0.3]]))) == []


def test_the_nearest_assignment_swaps_identical_objects_into_the_nearer_places_at_the_same_cost():
    space = _books_and_can()
    target = np.array([[0.2, 0.2, 0.0], [0.5, 0.4, 0.0], [0.8, 0.6, 0.0], [0.5, 0.65, 0.0]])
    start = np.array([[0.75, 0.55, 0.3], [0.1, 0.7, 0.0], [0.25, 0.15, 1.0], [0.9, 0.2, 0.0]])   # books crossed
    out = nearest_assignments(space, target[None], start[None])
    assert len(out) == 2 and np.array_equal(out[0], target)           # the given target first, then the swap
    swapped = target.copy()
    swapped[[0, 2]] = target[[2, 0]]
    assert np.array_equal(out[1], swapped)
    assert space.cost.cost(out)[0] == space.cost.cost(out)[1]
    # already nearest: nothing new
    assert len(nearest_assignments(space, target[None], target[None])) == 1


def test_the_yaw_lattice_is_every_net_turn_within_the_count_and_none_for_a_circle():
    space = _three()                                  # books turn by +0.19 and -0.2 rad; the can is a circle
    lattice = yaw_lattice(space, 0, 2)
    by_hand = sorted({round(a * 0.19 - b * 0.2, 9) for a in range(3) for b in range(3) if a + b <= 2})
    assert np.allclose(lattice, by_hand)              # 0, +-one turn, two of a sense, one of each (-0.01)
    assert yaw_lattice(space, 2, 2) is None
    assert np.allclose(yaw_lattice(space, 0, 0), [0.0])


def test_a_lattice_of_irregular_turns_and_their_fractions_stays_complete_within_its_resolution():
    # learned turns of irregular sizes and their fractions of a stroke (planning.strokes): the exact set of net turns
    # grows with every turn; merged within YAW_RESOLUTION it stays small, still reaches the extremes, and is within
    # the merges' error of every exact net turn (brute force over every sequence of up to three turns)
    import itertools

    from pliant_tsrrt.refine import YAW_RESOLUTION

    model = np.array(BOOK_MODEL, dtype=float)
    model[4, 2], model[5, 2] = 0.1187, -0.1641
    fractions = (1.0, 0.5, 0.25, 0.125, 0.0625)
    means = np.concatenate([f * model for f in fractions])
    fp = Footprints([BOX], [[0.12, 0.08]])
    whole = _space(fp, [BOOK_MODEL], (1.0, 1.0, 1.0, 0.0))
    space = ObjectSpace(fp, means[None], whole.checker, whole.cost, PushSettings(), BOUNDS, strokes=fractions)
    steps = [d for d in means[:, 2] if abs(d) >= 0.01]
    exact = {0.0} | {sum(c) for n in (1, 2, 3) for c in itertools.product(steps, repeat=n)}
    exact = np.array(sorted(exact))
    lattice = yaw_lattice(space, 0, 3)
    assert len(lattice) < len(exact)
    assert np.max(np.min(np.abs(exact[:, None] - lattice[None]), axis=1)) <= 3 * YAW_RESOLUTION
    assert np.max(np.min(np.abs(lattice[:, None] - exact[None]), axis=1)) <= 3 * YAW_RESOLUTION
    ten = yaw_lattice(space, 0, 10)
    assert np.isclose(ten.max(), 10 * 0.1187) and np.isclose(ten.min(), -10 * 0.1641)    # not cut short
    assert len(ten) < 2 * (10 * (0.1187 + 0.1641)) / YAW_RESOLUTION


def test_the_snapper_moves_each_box_to_its_nearest_reachable_yaw_modulo_its_symmetry():
    space = _three()
    start = np.array([[0.3, 0.3, 0.1], [0.6, 0.5, 0.0], [0.7, 0.2, 1.0]])
    snap = yaw_snapper(space, start, 3)
    allowed0 = 0.1 + yaw_lattice(space, 0, 3)
    allowed1 = yaw_lattice(space, 1, 3)
    wanted = np.array([[0.5, 0.4, 0.0], [0.2, 0.2, 0.5 * np.pi + 0.05], [0.1, 0.1, 2.0]])
    got = snap(wanted[None])[0]
    assert np.array_equal(got[:, :2], wanted[:, :2]) and got[2, 2] == 2.0      # positions and the can unchanged
    def gap(a, to, period):
        return np.abs((a - to + period / 2) % period - period / 2)

    for o, allowed, period in ((0, allowed0, np.pi), (1, allowed1, 0.5 * np.pi)):     # box 1 is a square
        assert np.min(gap(allowed, got[o, 2], period)) < 1e-9            # a reachable yaw, modulo the symmetry,
        assert np.isclose(gap(got[o, 2], wanted[o, 2], period), np.min(gap(allowed, wanted[o, 2], period)))  # nearest


def test_reachable_targets_put_every_box_on_a_reachable_yaw_collision_free():
    space = _three()
    start = np.array([[0.2, 0.2, 0.1], [0.8, 0.6, 0.05], [0.8, 0.2, 0.0]])
    target = np.array([[0.45, 0.4, 0.0], [0.62, 0.4, 0.0], [0.5, 0.55, 0.0]])     # square: not reachable from start
    out = reachable_targets(space, target[None], start[None], np.random.default_rng(0), turns=10, rounds=200)
    assert len(out) == 1
    assert not space.checker.in_collision(out)[0]
    for o in (0, 1):
        assert np.any(np.isclose((out[0, o, 2] - start[o, 2]) % space.period[o],
                                 yaw_lattice(space, o, 10) % space.period[o]))
    already = yaw_snapper(space, start, 10)(target[None])      # a target whose yaws are reachable is not repeated
    assert len(reachable_targets(space, already, start[None], np.random.default_rng(0), turns=10, rounds=50)) == 0


def test_improve_adds_the_optimums_reachable_versions_as_targets_and_stays_valid():
    space = _three()
    start = np.array([[0.2, 0.2, 0.1], [0.8, 0.6, 0.05], [0.8, 0.2, 0.0]])
    optimum = np.array([[[0.45, 0.4, 0.0], [0.62, 0.4, 0.0], [0.5, 0.55, 0.0]]])   # square: the turns cannot make it
    runs = {}
    for turns in (0, 10):
        runs[turns] = improve(space, start[None], np.random.default_rng(2), rounds=100, depth=12, width=16, passes=1,
                              max_orders=2, optimum=optimum, optimum_orders=[], optimum_turns=turns)
    reachable = reachable_targets(space, optimum, start[None], np.random.default_rng(0), turns=10, rounds=100)
    # the optimum group gains one target per distinct reachable version (the start is the path's both ends here)
    assert len(runs[10][3]["refine_targets"]) == len(runs[0][3]["refine_targets"]) + len(reachable) == \
        len(runs[0][3]["refine_targets"]) + 1
    cost, _, actions, _ = runs[10]
    states, ok = space.rollout(start, actions)
    assert ok and np.isclose(space.cost.cost(states[-1][None])[0], cost)
    assert cost <= space.cost.cost(start[None])[0]


def test_a_knife_turned_where_it_is_first_slides_into_a_slot_the_direct_search_reaches_unturned():
    # a knife lying across (yaw -1.515) to the right of a slot between two parallel knives 12 cm apart (centres): the
    # direct search brings it to the slot's mouth unturned, with no room left to turn (9.9 cm of pose error); turned
    # where it lies first and then pushed, it ends within 1.2 cm of its place (connect's turn_first)
    from pliant_tsrrt.refine import _pose_error

    knife = [[0.045, 0, 0], [-0.045, 0, 0], [0, 0.045, 0], [0, -0.045, 0], [0, 0.002, 0.2], [0, -0.002, -0.2]]
    fp = Footprints([BOX, BOX, BOX], [[0.1, 0.012]] * 3)
    space = _space(fp, [knife] * 3, (1.0, 1.0, 1.0, 0.0))
    s = np.array([[0.78, 0.437, -1.515], [0.5, 0.326, 0.0], [0.5, 0.446, 0.0]])
    target = np.array([0.5, 0.386, 0.0])
    direct = push_toward(space, s, 0, target, 40, 32, None, "closest", 4)
    turned = turned_first(space, s, 0, target, direct, 40, 32, None, "closest", 4)
    assert _pose_error(space, 0, direct[2][0], target) > 0.09
    assert _pose_error(space, 0, turned[2][0], target) < 0.012
    states, ok = space.rollout(s, turned[1])
    assert ok and np.allclose(states[-1], turned[2]) and np.array_equal(turned[2][1:], s[1:])
    aligned = s.copy()
    aligned[0, 2] = 0.0                               # already at its target's yaw: the direct result stands
    direct = push_toward(space, aligned, 0, target, 40, 32, None, "closest", 4)
    assert turned_first(space, aligned, 0, target, direct, 40, 32, None, "closest", 4) is direct
