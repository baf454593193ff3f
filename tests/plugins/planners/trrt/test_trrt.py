"""T-RRT and GradienT-RRT on the triple-wall scene: valid paths, the cost ceiling, gradient adjustment,
anytime termination (iterations, callback, Ctrl-C) and determinism."""

from __future__ import annotations

import itertools
import signal

import numpy as np
import pytest
from pliant import Pipeline
from pliant.errors import ConfigError
from pliant.interfaces import PlanningProblem
from pliant.results import Status
from pliant.termination import Termination


def problem_and_planner(name="trrt", **options):
    ctx = Pipeline("triple-wall", cost="voxel", planner={"name": name, **options}).build()
    return PlanningProblem.from_context(ctx), ctx.extras["planner"]


@pytest.mark.parametrize("name", ["trrt", "gradient-trrt"])
def test_a_solved_path_is_valid_and_its_cost_is_the_path_integral(name):
    problem, planner = problem_and_planner(name, max_step=0.03)
    result = planner.plan(problem, np.random.default_rng(0))
    assert result.status is Status.SOLVED
    path = result.path.configurations
    assert np.allclose(path[0], problem.start) and problem.in_goal(path[-1:])[0]
    dense = np.vstack([problem.space.discretize(a, b, problem.scene.resolution) for a, b in itertools.pairwise(path)])
    assert problem.is_valid(dense).all()
    assert result.cost == pytest.approx(problem.path_cost(path, problem.scene.resolution))
    assert result.statistics["nodes"] >= len(path) and result.statistics["time_to_first"] > 0
    again = planner.plan(problem, np.random.default_rng(0))
    assert np.array_equal(again.path.configurations, path)


def test_a_cost_ceiling_of_zero_keeps_every_state_of_the_path_free_of_deformation():
    problem, planner = problem_and_planner("trrt", max_step=0.03, max_cost=0.0)
    result = planner.plan(problem, np.random.default_rng(1))
    assert result.status is Status.SOLVED and result.cost == 0.0
    path = result.path.configurations
    dense = np.vstack([problem.space.discretize(a, b, problem.scene.resolution) for a, b in itertools.pairwise(path)])
    assert np.all(problem.cost.cost(dense) == 0.0)


def test_the_gradient_adjustment_lowers_the_cost_of_a_refused_extension():
    problem, planner = problem_and_planner("gradient-trrt", gradient_iterations=20)
    planner._check_step = problem.scene.resolution
    inside_wall = np.array([0.10, 0.12, 0.196])           # in wall 1 (y in [0.096, 0.144))
    cost = float(problem.cost.cost(inside_wall[None])[0])
    assert cost > 0
    adjusted, adjusted_cost = planner.adjust(problem, inside_wall, cost)
    assert adjusted_cost < cost
    assert adjusted_cost == pytest.approx(float(problem.cost.cost(adjusted[None])[0]))


def test_gradient_trrt_needs_a_gradient():
    problem, planner = problem_and_planner("gradient-trrt")
    problem.cost = None
    with pytest.raises(ConfigError, match="gradient"):
        planner.plan(problem, np.random.default_rng(0))


def test_an_iteration_budget_ends_the_run_with_the_statistics():
    problem, planner = problem_and_planner("trrt", max_step=0.001)
    result = planner.plan(problem, np.random.default_rng(0), Termination(max_iterations=50))
    assert result.status is Status.TIMEOUT and result.path is None
    assert result.statistics["iterations"] == 50 and "closest node" in result.message


def test_anytime_run_keeps_the_cheapest_solution_and_ctrl_c_returns_it():
    problem, planner = problem_and_planner("trrt", max_step=0.03, stop_on_first=False)
    seen = []

    def interrupt_later(iteration, best):           # Ctrl-C 200 iterations after the first solution
        seen.append(best)
        if len([b for b in seen if np.isfinite(b)]) == 200:
            signal.raise_signal(signal.SIGINT)
        return False

    result = planner.plan(problem, np.random.default_rng(2), Termination(callback=interrupt_later))
    assert result.status is Status.SOLVED and result.statistics["interrupted"]
    history = np.array(result.statistics["cost_history"])
    assert np.all(np.diff(history[:, 1]) < 0) and result.cost == history[-1, 1]
    finite = [b for b in seen if np.isfinite(b)]
    assert all(b1 >= b2 for b1, b2 in itertools.pairwise(finite))        # the best cost never rises


def test_restart_mode_grows_new_trees_and_keeps_the_cheapest_solution():
    problem, planner = problem_and_planner("trrt", max_step=0.03, stop_on_first=False, anytime="restart",
                                           shortcut_iterations=50)
    result = planner.plan(problem, np.random.default_rng(3), Termination(max_iterations=3000))
    stats = result.statistics
    # every solution but the last one's ended a tree
    assert result.status is Status.SOLVED and stats["trees"] >= 2 and stats["solutions"] in (stats["trees"] - 1,
                                                                                             stats["trees"])
    history = np.array(stats["cost_history"])
    assert result.cost == history[-1, 1] == history[:, 1].min()
    assert result.cost == pytest.approx(problem.path_cost(result.path.configurations, problem.scene.resolution))
    assert stats["tree_cost"] >= result.cost                  # shortcutting never makes a path costlier


@pytest.mark.parametrize("name", ["trrt", "gradient-trrt"])
@pytest.mark.parametrize("seed", [0, 1])
def test_the_reported_cost_is_the_cost_recomputed_on_the_returned_path(name, seed):
    import pliant
    from pliant.interfaces import PlanningProblem
    from pliant.termination import Termination

    context = pliant.Pipeline.from_file("cube-wall-trrt", overrides=[f"planner={name}"]).build()
    problem, planner = PlanningProblem.from_context(context), context.extras["planner"]
    result = planner.plan(problem, np.random.default_rng(seed), Termination(max_iterations=20000, stop_on_first=True))
    assert result.path is not None, result.status
    recomputed = problem.path_cost(result.path.configurations, planner._check_step)
    assert result.cost == pytest.approx(recomputed, rel=1e-9)
