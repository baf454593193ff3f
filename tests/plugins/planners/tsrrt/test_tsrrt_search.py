"""TASK_SPACE_RRT (poster ICHR 2010) on hand-made models: plans that must reach a known optimum, the shortcut, and
the batched validity of actions."""

from __future__ import annotations

import numpy as np
from pliant.termination import Termination
from pliant_tsrrt.cost import TaskCost
from pliant_tsrrt.geometry import BOX, CIRCLE, CollisionChecker, Footprints
from pliant_tsrrt.options import ImprovementOptions, TSRRTOptions
from pliant_tsrrt.pushing import PushSettings
from pliant_tsrrt.search import ObjectSpace, descend, grow, redundant_actions, shortcut

TABLE = (0.0, 0.0, 1.0, 0.8)
BOUNDS = (-0.2, -0.2, 1.2, 1.0)
NO_OBSTACLES = (Footprints(np.zeros(0, dtype=int), np.zeros((0, 2))), np.zeros((0, 3)))


def _options(max_nodes: int = 5000, **improvement) -> TSRRTOptions:
    """TS-RRT's options with ``max_nodes`` and these ``improvement`` options (pushes are free unless ``push_cost``)."""
    return TSRRTOptions(max_nodes=max_nodes, improvement=ImprovementOptions(**{"push_cost": 0.0, **improvement}))


def _space(fp, means, weights, margin=0.0, obstacles=NO_OBSTACLES):
    checker = CollisionChecker(fp, obstacles[0], obstacles[1], TABLE, margin)
    return ObjectSpace(fp, np.asarray(means, dtype=float), checker, TaskCost(fp, TABLE, weights), PushSettings(),
                       BOUNDS)


CAN_MODEL = [[0.05, 0, 0], [-0.05, 0, 0], [0, 0.05, 0], [0, -0.05, 0], [-0.01, 0.02, 0], [0.01, 0.02, 0]]
BOOK_MODEL = [[0.05, 0, 0], [-0.05, 0, 0], [0, 0.05, 0], [0, -0.05, 0], [0, 0, 0.1], [0, 0, -0.1]]


def test_one_object_reaches_the_centre_line_in_four_pushes():
    fp = Footprints([CIRCLE], [[0.05, 0.05]])
    space = _space(fp, [CAN_MODEL], (0.0, 0.0, 1.0, 0.0))
    s0 = np.array([[0.2, 0.4, 0.0]])
    found = grow(space, s0, np.random.default_rng(0), _options(max_nodes=3000),
                 Termination(max_iterations=3000))
    # the best a 5 cm radius can do on a 1.0 x 0.8 table: 0.35 m from every edge, cost 1 - 0.35 / 0.4
    assert np.isclose(found.cost, 0.125, atol=1e-9)
    assert len(found.actions) == 4 and set(found.actions) == {0}          # four times push+x
    assert redundant_actions(space, s0, found.actions) == 0


def test_one_box_is_turned_square_to_the_table():
    fp = Footprints([BOX], [[0.12, 0.08]])
    space = _space(fp, [BOOK_MODEL], (1.0, 0.0, 0.0, 0.0))
    s0 = np.array([[0.5, 0.4, 0.3]])
    found = grow(space, s0, np.random.default_rng(1), _options(max_nodes=2000),
                 Termination(max_iterations=2000))
    assert found.cost < 1e-20
    assert found.actions == [5, 5, 5]                                       # three turns of -0.1 rad
    assert np.allclose(found.states[-1], [[0.5, 0.4, 0.0]], atol=1e-12)


def test_plans_avoid_obstacles_and_each_other():
    fp = Footprints([CIRCLE, CIRCLE], [[0.05, 0.05], [0.05, 0.05]])
    obstacles = (Footprints([BOX], [[0.05, 0.3]]), np.array([[0.5, 0.4, 0.0]]))
    space = _space(fp, [CAN_MODEL, CAN_MODEL], (0.0, 1.0, 1.0, 0.0), margin=0.005, obstacles=obstacles)
    s0 = np.array([[0.15, 0.2, 0.0], [0.85, 0.6, 0.0]])
    found = grow(space, s0, np.random.default_rng(2), _options(), Termination(max_iterations=1500))
    assert found.cost < space.cost.cost(s0[None])[0]
    assert not space.checker.in_collision(found.states).any()
    _, ok = space.rollout(s0, found.actions)
    assert ok


def test_shortcut_drops_back_and_forth_and_useless_pushes():
    fp = Footprints([CIRCLE], [[0.05, 0.05]])
    space = _space(fp, [CAN_MODEL], (0.0, 0.0, 1.0, 0.0))
    s0 = np.array([[0.2, 0.4, 0.0]])
    plan = [0, 2, 0, 1, 3, 0, 0, 0, 0]       # +x, +y, +x, -x, -y, +x, +x, +x, +x: two pushes past the optimum
    short, _, cost = shortcut(space, s0, plan)
    assert np.isclose(cost, 0.125) and len(short) == 4
    assert redundant_actions(space, s0, short) == 0
    # with no trial budget left (a long plan): the pairs are not tried, but no single redundant action is left
    short, _, cost = shortcut(space, s0, plan, budget=0)
    assert np.isclose(cost, 0.125) and redundant_actions(space, s0, short) == 0


def test_valid_steps_match_one_at_a_time():
    fp = Footprints([BOX, CIRCLE], [[0.12, 0.08], [0.05, 0.05]])
    space = _space(fp, [BOOK_MODEL, CAN_MODEL], (1.0, 1.0, 1.0, 0.0), margin=0.01)
    rng = np.random.default_rng(3)
    for _ in range(20):
        s = space.random_config(rng)
        out = space.outcomes(s)
        batch = space.valid_actions(s, out)
        single = [space.valid_actions(s, out[a:a + 1], np.array([a]))[0] for a in range(len(out))]
        assert batch.tolist() == single


def test_a_seed_plan_starts_the_tree_so_replanning_is_never_worse():
    fp = Footprints([CIRCLE], [[0.05, 0.05]])
    space = _space(fp, [CAN_MODEL], (0.0, 0.0, 1.0, 0.0))
    s0 = np.array([[0.2, 0.4, 0.0]])
    found = grow(space, s0, np.random.default_rng(0), _options(), Termination(max_iterations=1),
                 seed_plan=[0, 0, 0, 0, 1])
    assert np.isclose(found.cost, 0.125) and found.actions == [0, 0, 0, 0]


def test_terminating_from_outside_returns_the_best_plan_so_far():
    fp = Footprints([CIRCLE], [[0.05, 0.05]])
    space = _space(fp, [CAN_MODEL], (0.0, 0.0, 1.0, 0.0))
    s0 = np.array([[0.2, 0.4, 0.0]])
    stop = Termination()

    def interrupt(iteration, best):           # what Ctrl-C does inside Termination.watch()
        if iteration >= 3:
            stop.terminate()
        return False

    stop.callback = interrupt
    found = grow(space, s0, np.random.default_rng(0), _options(), stop)
    assert found.statistics["interrupted"] and found.statistics["iterations"] <= 4
    assert found.cost <= space.cost.cost(s0[None])[0]
    _, ok = space.rollout(s0, found.actions)
    assert ok


# the book at yaw 0.3 rad under orthogonality alone, turned by -0.1 rad per push: the costs sin^2(2 theta) after 0-3
# turns are 0.3188, 0.1516, 0.0395 and 0, so the three turns gain 0.167, 0.112 and 0.0395
def _book_at(yaw):
    fp = Footprints([BOX], [[0.12, 0.08]])
    return _space(fp, [BOOK_MODEL], (1.0, 0.0, 0.0, 0.0)), np.array([[0.5, 0.4, yaw]])


def test_push_cost_makes_the_shortcut_drop_a_push_that_gains_less():
    space, s0 = _book_at(0.3)
    assert shortcut(space, s0, [5, 5, 5])[0] == [5, 5, 5]                          # every turn lowers the cost
    assert shortcut(space, s0, [5, 5, 5], push_cost=0.03)[0] == [5, 5, 5]          # 0.0395 > 0.03: kept
    short, states, cost = shortcut(space, s0, [5, 5, 5], push_cost=0.05)            # 0.0395 < 0.05: dropped
    assert short == [5, 5] and np.isclose(cost, np.sin(0.2) ** 2) and np.isclose(states[-1, 0, 2], 0.1)
    assert shortcut(space, s0, [5, 5, 5], push_cost=0.12)[0] == [5]                 # 0.112 < 0.12 too
    # what is left is still free of redundant actions (no push can be dropped without raising the cost)
    assert redundant_actions(space, s0, short) == 0


def test_push_cost_stops_the_final_descent_at_the_first_push_that_gains_less():
    space, s0 = _book_at(0.3)
    assert descend(space, s0, [])[0] == [5, 5, 5]
    assert descend(space, s0, [], push_cost=0.05) == ([5, 5], 2)
    assert descend(space, s0, [], push_cost=0.12) == ([5], 1)
    assert descend(space, s0, [], push_cost=0.2) == ([], 0)


def test_grow_with_a_push_cost_returns_the_plan_of_lowest_cost_plus_push_cost_per_push():
    space, s0 = _book_at(0.3)
    found = grow(space, s0, np.random.default_rng(1), _options(max_nodes=2000),
                 Termination(max_iterations=2000))
    assert found.actions == [5, 5, 5] and found.cost < 1e-20
    found = grow(space, s0, np.random.default_rng(1), _options(max_nodes=2000, push_cost=0.05),
                 Termination(max_iterations=2000))
    assert found.actions == [5, 5] and np.isclose(found.cost, np.sin(0.2) ** 2)    # 0.0395 + 2 x 0.05 < 0 + 3 x 0.05


def test_enough_counts_every_cost_below_it_as_equal_so_the_shorter_plan_wins():
    # replanning during execution (replan_shortest): a cost below the first plan's is no better than reaching it
    space, s0 = _book_at(0.3)
    assert shortcut(space, s0, [5, 5, 5], enough=0.05)[0] == [5, 5]       # 0.0395 counts as 0.05, as does 0
    short, _, cost = shortcut(space, s0, [5, 5, 5], enough=0.2)            # 0.1516 counts as 0.2 too
    assert short == [5] and np.isclose(cost, np.sin(0.4) ** 2)
    assert descend(space, s0, [], enough=0.1) == ([5, 5], 2)                # stops once at or below 0.1
    found = grow(space, s0, np.random.default_rng(1), _options(max_nodes=2000),
                 Termination(max_iterations=2000), enough=0.2)
    assert found.actions == [5] and np.isclose(found.cost, np.sin(0.4) ** 2)


def _three_objects():
    fp = Footprints([BOX, CIRCLE, CIRCLE], [[0.06, 0.03], [0.05, 0.05], [0.04, 0.04]])
    space = _space(fp, [BOOK_MODEL, CAN_MODEL, CAN_MODEL], (1.0, 1.0, 1.0, 0.0), margin=0.005)
    s0 = np.array([[0.2, 0.2, 0.4], [0.8, 0.6, 0.0], [0.3, 0.65, 0.0]])
    return space, s0


def test_restarts_run_the_improvement_phase_again_from_its_own_plan_with_a_new_optimum():
    space, s0 = _three_objects()
    runs = {}
    for restarts in (1, 3):
        options = _options(max_nodes=400, refine_restarts=restarts, refine_optimum=200, refine_passes=1,
                           refine_randoms=0)
        runs[restarts] = grow(space, s0, np.random.default_rng(4), options, Termination(max_iterations=150))
    once, thrice = runs[1].statistics, runs[3].statistics
    assert once["refine_runs"] == 1 and thrice["refine_runs"] == 3 and len(thrice["refine_run_gains"]) == 3
    assert thrice["refine_run_gains"][0] == once["refine_run_gains"][0]       # the first run is the same
    assert all(g >= 0.0 for g in thrice["refine_run_gains"])                  # a run never makes the plan worse
    _, ok = space.rollout(s0, runs[3].actions)
    assert ok and not space.checker.in_collision(runs[3].states).any()
    # without an optimum to draw again, or when replanning toward a goal, one run is all there is
    options = _options(max_nodes=400, refine_restarts=3, refine_optimum=0, refine_passes=1, refine_randoms=0)
    assert grow(space, s0, np.random.default_rng(4), options,
                Termination(max_iterations=150)).statistics["refine_runs"] == 1
    options = _options(max_nodes=400, refine_restarts=3, refine_optimum=200, refine_passes=1, refine_randoms=0)
    assert grow(space, s0, np.random.default_rng(4), options, Termination(max_iterations=150),
                goal=runs[1].states[-1]).statistics["refine_runs"] == 1


class _Clock:
    """A stand-in for the ``time`` module whose clock advances 1 ms per reading: a time budget without wall time."""

    def __init__(self):
        self.now = 0.0

    def perf_counter(self):
        self.now += 1e-3
        return self.now


def test_under_a_time_budget_alone_the_improvement_phase_runs_until_its_deadline(monkeypatch):
    import pliant_tsrrt.refine as refine
    import pliant_tsrrt.search as search

    space, s0 = _three_objects()
    options = _options(max_nodes=400, refine_restarts=1, refine_optimum=200, refine_passes=1, refine_randoms=0)
    plan = grow(space, s0, np.random.default_rng(4), options, Termination(max_iterations=100)).actions
    clock = _Clock()
    monkeypatch.setattr(search, "time", clock)
    monkeypatch.setattr(refine, "time", clock)
    def phase(deadline, anytime):
        clock.now, stats = 0.0, {}
        search._improvement_phase(space, s0, list(plan), np.random.default_rng(5), options.improvement, stats,
                                  goal=None, deadline=deadline, anytime=anytime, floor=-np.inf)
        return stats["refine_runs"], clock.now

    runs, one_run = phase(1e9, False)           # a work budget: refine_restarts runs, the deadline only a cap
    assert runs == 1
    runs, end = phase(3 * one_run, True)        # a time budget alone: runs until the clock passes the deadline
    assert runs >= 2 and end >= 3 * one_run
    assert phase(0.0, True)[0] == 1             # a deadline already passed: the one run, cut short
