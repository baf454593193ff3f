"""The four ch. 6 metrics end to end: known answers on a free and a blocked motion, the contract, bad input."""

import numpy as np
import pliant
import pytest
from pliant.errors import ConfigError, DimensionError, PlanningError, PliantError
from pliant.interfaces import Context, PlanningProblem
from pliant.results import Path
from reachability_helpers import metric, noisy_passage, passage

METHODS = ("reachable-volume", "sampling-driven", "simulation", "simulation-scaled")


def scores(name, path, **options):
    context = noisy_passage()
    m = metric(context, name, epsilon_reached=0.125, simulations=300, largest_volume_samples=200, **options)
    return m.evaluate(Path(np.asarray(path)), PlanningProblem.from_context(context), np.random.default_rng(0))


@pytest.mark.parametrize("name", METHODS)
def test_a_motion_far_from_every_obstacle_always_succeeds(name):
    s = scores(name, [[0.1, 0.06, 0.0], [0.3, 0.06, 0.0]])
    assert s["p_exec"] == 1.0
    assert s["contacts"] == 0
    assert s["volumes"] > 1


@pytest.mark.parametrize("name", METHODS)
def test_a_motion_into_the_wall_beside_the_passage_always_fails(name):
    # straight up at x = 0.1: the L's 0.175 m arm meets the wall 11 cm left of the 0.18 m passage.  The second
    # waypoint lies in the wall, so evaluate refuses the path (the core's check, issue 31); the estimate itself,
    # called past that check, still knows the motion fails
    path = [[0.1, 0.08, 0.0], [0.1, 0.2, 0.0]]
    with pytest.raises(PlanningError, match=r"path\[1\]: waypoint 1 is not valid .* collides with object .wall."):
        scores(name, path)
    context = noisy_passage()
    m = metric(context, name, epsilon_reached=0.125, simulations=300, largest_volume_samples=200)
    s = type(m).evaluate.__wrapped__(m, Path(np.asarray(path)), PlanningProblem.from_context(context),
                                     np.random.default_rng(0))
    assert s["p_exec"] == pytest.approx(0.0, abs=0.02)
    if name != "simulation-scaled" and name != "simulation":
        assert s["contacts"] > 0


def test_a_path_multiplies_its_pairs():
    """eq. 6.13: P_exec of a path is the product over its waypoint pairs."""
    a, b, c = [0.1, 0.06, 0.0], [0.3, 0.06, 0.0], [0.3, 0.2, 0.0]
    whole = scores("simulation", [a, b, c])
    first, second = scores("simulation", [a, b]), scores("simulation", [b, c])
    assert whole["volumes"] == first["volumes"] + second["volumes"]
    assert 0.0 <= whole["p_exec"] <= 1.0


def test_bad_paths_and_simulators_are_clear_errors():
    context = noisy_passage()
    m = metric(context, simulations=10)
    problem = PlanningProblem.from_context(context)
    rng = np.random.default_rng(0)
    with pytest.raises(DimensionError, match="path"):
        m.evaluate(Path(np.zeros((2, 7))), problem, rng)
    with pytest.raises(ConfigError, match="two waypoints"):
        m.evaluate(Path(np.array([[0.1, 0.06, 0.0]])), problem, rng)
    with pytest.raises(DimensionError, match=r"path\[0\]: must be finite"):
        m.evaluate(Path(np.array([[0.1, 0.06, np.nan], [0.3, 0.06, 0.0]])), problem, rng)
    in_wall = Path(np.array([[0.05, 0.3, 0.0], [0.05, 0.5, 0.0]]))       # the start lies in the wall
    with pytest.raises(PlanningError, match=r"path\[0\]: waypoint 0 is not valid .* object .wall."):
        metric(context, "simulation", simulations=10).evaluate(in_wall, problem, rng)
    with pytest.raises(PliantError, match="epsilon_reached"):
        metric(context, epsilon_reached=-1.0)
    ctx = Context(scene=context.scene)
    ctx.robot = context.robot
    ctx.simulator = pliant.registry.create("simulator", "pymunk", ctx)
    with pytest.raises(PliantError, match="control law"):
        metric(ctx)


def test_skipping_checks_by_clearance_bounds_changes_nothing():
    """The propagated estimate skips collision checks of particles whose clearance bound shows they cannot have hit
    anything; without the skip (no rigid reach), the same seed gives the same answer."""
    context = noisy_passage()
    path = Path(np.array([[0.2375, 0.12, 0.0], [0.2375, 0.42, 0.0]]))
    problem = PlanningProblem.from_context(context)
    m = metric(context, particles=300, labelled=40)
    fast = m.evaluate(path, problem, np.random.default_rng(3))
    m.clearance.reach = None                        # every particle checked every step
    slow = m.evaluate(path, problem, np.random.default_rng(3))
    assert fast["p_exec"] == slow["p_exec"] and fast["contacts"] == slow["contacts"]
    assert 0.0 < fast["p_exec"] < 1.0


def test_metrics_bound_to_one_scene_share_its_voxel_grid():
    from pliant_reachability.metrics import scene_grid

    context = passage()
    a, b = metric(context), metric(context, "simulation")
    assert a.clearance.grid is b.clearance.grid is scene_grid(context.scene)
    other = pliant.load_scene("se2-through-passage")                   # another scene object: its own grid
    fresh = scene_grid(other)
    assert fresh is not a.clearance.grid and np.array_equal(fresh.occupied, a.clearance.grid.occupied)
