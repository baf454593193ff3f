"""Plan repair (pliant_tsrrt.repair) on the scripted models of the execution tests: pushes of 4.5 cm along the
object's axes and turns of 0.2 rad (with 2 mm of drift)."""

from __future__ import annotations

import numpy as np
from pliant_tsrrt.models import scene_pose
from pliant_tsrrt.repair import _displaced, _exact_yaw, restore, retarget, toward_goal
from test_tsrrt_execution import NAMES, _result, _setup


def _plan():
    scene, *_, space = _setup(repair=True)
    s0 = np.array([scene_pose(scene, n) for n in NAMES])
    return space, _result(space, s0, [15, 15, 15])          # the can pushed -y three times


def test_a_turned_box_is_turned_back_and_the_rest_of_the_plan_follows():
    space, first = _plan()
    observed = first.states[1].copy()
    observed[0, 2] += 0.4                                     # the book turned by two turns' worth
    fix = restore(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15)
    assert fix is not None and fix.objects == [0]
    assert fix.actions[fix.pushes:] == first.actions[1:]      # the plan goes on after the repair
    assert sorted(a % 6 for a in fix.actions[:fix.pushes]) == [5, 5]    # two turns back (turn-)
    back = fix.states[fix.pushes]
    assert abs(back[0, 2] - first.states[1][0, 2]) < 0.075 and np.hypot(*(back[0, :2] - first.states[1][0, :2])) < 0.01


def test_a_push_back_is_refused_when_the_rest_of_the_plan_would_end_above_the_bound():
    space, first = _plan()
    observed = first.states[1].copy()
    observed[0, 2] += 0.4
    fix = restore(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15)
    end_cost = float(space.cost.cost(fix.states[-1][None])[0])
    assert restore(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15,
                   at_most=end_cost) is not None
    assert restore(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15,
                   at_most=end_cost - 1e-9) is None


def test_a_box_turned_by_its_symmetry_counts_as_displaced_for_a_repair():
    space, first = _plan()
    observed = first.states[1].copy()
    observed[0, 2] += np.pi                                   # the same footprint, but its pushes would go backwards
    assert _displaced(space, observed, first.states[1], 0.01, 0.075) == []
    assert _displaced(_exact_yaw(space), observed, first.states[1], 0.01, 0.075) == [0]


def test_nothing_displaced_means_nothing_to_repair():
    space, first = _plan()
    fix = restore(space, first.states[1], first.states[1], first.actions[1:], threshold=0.02, angle=0.15)
    assert fix is not None and fix.pushes == 0 and fix.actions == first.actions[1:]
    assert toward_goal(space, first.states[-1], first.states[-1]) is None


def test_a_repair_toward_the_goal_is_refused_when_it_would_end_above_the_bound():
    space, first = _plan()
    goal = first.states[-1]
    observed = goal.copy()
    observed[2, 1] += 0.06                                   # the can 6 cm short of its place, toward the table's edge
    fix = toward_goal(space, observed, goal)
    assert fix is not None and fix.objects == [2]
    end_cost = float(space.cost.cost(fix.states[-1][None])[0])
    assert end_cost < float(space.cost.cost(observed[None])[0])
    assert np.isclose(fix.states[-1][2, 1], goal[2, 1] + 0.015)          # one push back: 1.5 cm short
    assert toward_goal(space, observed, goal, at_most=end_cost - 1e-9) is None


def test_retarget_replans_the_displaced_objects_part_of_the_plan_instead_of_pushing_it_back():
    space, first = _plan()
    observed = first.states[1].copy()
    observed[2, 1] -= 0.045                                  # the can pushed a push too far, -y: where step 2 has it
    back = restore(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15)
    assert back is not None and back.actions == [14, 15, 15]          # one push +y back, then the plan's two
    fix = retarget(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15)
    assert fix is not None and fix.objects == [2] and fix.actions == [15]      # one push to the plan's end
    assert np.allclose(fix.states[-1], first.states[-1], atol=1e-9)
    # and refused when that end would cost more than allowed
    bound = float(space.cost.cost(first.states[-1][None])[0])
    assert retarget(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15,
                    at_most=bound - 1e-6) is None


def test_retarget_leaves_a_box_turned_by_its_symmetry_when_no_push_of_the_plan_follows():
    space, first = _plan()
    observed = first.states[1].copy()
    observed[0, 2] += np.pi                                  # the book turned over: the same footprint
    # pushing it back would take 16 turns of 0.2 rad (more than the repair's 12); the book has no push left
    assert restore(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15) is None
    fix = retarget(space, observed, first.states[1], first.actions[1:], threshold=0.02, angle=0.15)
    assert fix is not None and fix.objects == [0] and fix.pushes == 0 and fix.actions == first.actions[1:]
