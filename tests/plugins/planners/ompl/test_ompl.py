"""The ompl planner plugin: OMPL's planners on pliant problems (small problems without a scene: seconds in all)."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import registry
from pliant.errors import ConfigError
from pliant.interfaces import CostModel, PlanningProblem
from pliant.results import Status
from pliant.spaces import RealVectorSpace, SE2Space, SE3Space
from pliant.termination import Budget

pytest.importorskip("ompl")


def wall(q: np.ndarray) -> np.ndarray:
    """Valid unless in the wall x in (0.45, 0.55), y < 0.7 (the first two coordinates)."""
    q = np.atleast_2d(q)
    return ~((q[:, 0] > 0.45) & (q[:, 0] < 0.55) & (q[:, 1] < 0.7))


class Band(CostModel):
    """Cost 5 in the band y > 0.85, 0 elsewhere: the cheapest path keeps below it."""

    def cost(self, q):
        return np.where(np.atleast_2d(q)[:, 1] > 0.85, 5.0, 0.0)


def r2_problem(iterations: int = 2000, cost=None, weights=None) -> PlanningProblem:
    return PlanningProblem(space=RealVectorSpace([0, 0], [1, 1], weights=weights), start=np.array([0.1, 0.1]),
                           goal=np.array([0.9, 0.1]), validity=wall, cost=cost,
                           budget=Budget(max_iterations=iterations))


def planner(**options):
    return registry.create("planner", "ompl", **options)


def check_solution(problem: PlanningProblem, result) -> np.ndarray:
    assert result.status is Status.SOLVED, result.message
    path = result.path.configurations
    assert np.array_equal(path[0], problem.start)
    assert problem.in_goal(path[-1:])[0]
    assert problem.path_is_valid(path)
    return path


@pytest.mark.parametrize("algorithm", ["RRTConnect", "KPIECE1", "RRT"])
def test_feasibility_planners_solve_r2_and_are_deterministic(algorithm):
    problem = r2_problem()
    a = planner(algorithm=algorithm).plan(problem, np.random.default_rng(4))
    path = check_solution(problem, a)
    assert np.all(wall(problem.densify(path, 0.005)))           # around the wall, not through it
    b = planner(algorithm=algorithm).plan(problem, np.random.default_rng(4))
    assert np.array_equal(a.path.configurations, b.path.configurations)
    assert a.statistics["seed"] == b.statistics["seed"]
    assert a.statistics["deterministic"] and a.statistics["algorithm"] == algorithm


def test_the_seed_comes_from_the_generator():
    problem = r2_problem()
    seeds = {planner().plan(problem, np.random.default_rng(s)).statistics["seed"] for s in range(4)}
    assert len(seeds) == 4


def test_weighted_joint_space_is_planned_in_pliant_coordinates():
    problem = r2_problem(weights=[2.0, 0.5])
    result = planner().plan(problem, np.random.default_rng(0))
    path = check_solution(problem, result)
    assert np.all(path >= 0.0) and np.all(path <= 1.0)


def test_optimising_planner_minimises_pliants_cost_within_the_work_budget():
    problem = r2_problem(iterations=100, cost=Band())
    result = planner(algorithm="RRTstar", length_weight=1.0, parameters={"range": 0.2}).plan(
        problem, np.random.default_rng(1))
    path = check_solution(problem, result)
    stats = result.statistics
    assert stats["optimizing"] and stats["budget"]["binding"] == "iterations"
    assert stats["iterations"] == 101                   # checks 0..99 continue, the 101st stops
    expected = problem.path_cost(path, stats["check_step"]) + problem.space.path_length(path)
    assert result.cost == pytest.approx(expected)
    assert stats["ompl_cost"] == pytest.approx(result.cost, rel=1e-6)      # OMPL summed pliant's objective
    assert stats["parameters"]["range"] == "0.2"
    again = planner(algorithm="RRTstar", length_weight=1.0, parameters={"range": 0.2}).plan(
        problem, np.random.default_rng(1))
    assert np.array_equal(again.path.configurations, path)


def test_stop_on_first_returns_the_first_solution():
    problem = r2_problem(iterations=5000)
    result = planner(algorithm="RRTstar", stop_on_first=True).plan(problem, np.random.default_rng(0))
    check_solution(problem, result)
    assert result.statistics["budget"]["binding"] == "solution"
    assert result.statistics["iterations"] < 5000


def test_se2_and_se3():
    se2 = PlanningProblem(space=SE2Space([0, 0], [1, 1]), start=np.array([0.1, 0.1, 0.0]),
                          goal=np.array([0.9, 0.1, 1.5]), validity=wall, budget=Budget(max_iterations=3000))
    check_solution(se2, planner().plan(se2, np.random.default_rng(0)))
    q = np.array([0.0, 0.0, np.sin(0.5), np.cos(0.5)])
    se3 = PlanningProblem(space=SE3Space([0, 0, 0], [1, 1, 1]), start=np.r_[0.1, 0.1, 0.5, 0, 0, 0, 1],
                          goal=np.r_[0.9, 0.1, 0.5, q], validity=wall, goal_tolerance=1e-6,
                          budget=Budget(max_iterations=3000))
    path = check_solution(se3, planner().plan(se3, np.random.default_rng(0)))
    assert np.allclose(np.linalg.norm(path[:, 3:], axis=1), 1.0)


def test_invalid_goal_and_no_solution_within_the_budget():
    space, start = RealVectorSpace([0, 0], [1, 1]), np.array([0.1, 0.1])
    bad_goal = PlanningProblem(space=space, start=start, goal=np.array([0.5, 0.1]), validity=wall)
    assert planner().plan(bad_goal, np.random.default_rng(0)).status is Status.INVALID_GOAL
    closed = PlanningProblem(space=space, start=start, goal=np.array([0.9, 0.9]),
                             validity=lambda q: np.abs(np.atleast_2d(q)[:, 0] - 0.5) > 0.05,
                             budget=Budget(max_iterations=50))
    result = planner().plan(closed, np.random.default_rng(0))
    assert result.statistics["budget"]["binding"] == "iterations"
    # RRTConnect reports its closest approach as an approximate solution: valid, short of the goal
    assert result.status is Status.APPROXIMATE
    assert closed.path_is_valid(result.path.configurations) and not closed.in_goal(result.path.configurations[-1:])[0]
    strict = planner(algorithm="RRT").plan(closed, np.random.default_rng(0))
    assert strict.status in (Status.APPROXIMATE, Status.TIMEOUT) and strict.status is not Status.SOLVED


def test_unknown_algorithm_names_the_available_ones():
    with pytest.raises(ConfigError, match="RRTConnect") as err:
        planner(algorithm="RRTConect")
    assert err.value.field == "planner.algorithm"


def test_parameters_are_checked_against_the_declared_ones():
    with pytest.raises(ConfigError, match="declares: intermediate_states, range") as err:
        planner(parameters={"rnage": 0.1})
    assert err.value.field == "planner.parameters.rnage"
    problem = r2_problem()
    with pytest.raises(ConfigError, match="number") as err:
        planner(parameters={"range": "far"}).plan(problem, np.random.default_rng(0))
    assert err.value.field == "planner.parameters.range" and err.value.value == "far"
    with pytest.raises(ConfigError, match="integer"):
        planner(algorithm="BITstar", parameters={"samples_per_batch": 2.5}).plan(problem, np.random.default_rng(0))
    result = planner(algorithm="BITstar", parameters={"samples_per_batch": 20, "use_k_nearest": False}).plan(
        r2_problem(iterations=200), np.random.default_rng(0))
    assert result.statistics["parameters"]["samples_per_batch"] == "20"
    assert result.statistics["parameters"]["use_k_nearest"] == "0"
    # from the command line: --set planner.parameters.range=0.05 (a dotted key, a string value)
    dotted = planner(**{"parameters.range": "0.05", "parameters.intermediate_states": "true"})
    assert dotted.options.parameters == {"range": "0.05", "intermediate_states": "true"}
    settings = dotted.plan(problem, np.random.default_rng(0)).statistics["parameters"]
    assert settings == {"range": "0.05", "intermediate_states": "1"}


def test_multithreaded_planners_need_consent():
    with pytest.raises(ConfigError, match="allow_nondeterministic") as err:
        planner(algorithm="PRM")
    assert err.value.field == "planner.algorithm"
    assert planner(algorithm="PRM", allow_nondeterministic=True).options.allow_nondeterministic


def test_specs_follow_the_algorithm():
    assert planner(algorithm="BITstar").specs.anytime
    assert not planner(algorithm="RRTConnect").specs.anytime
    assert set(planner().specs.spaces) == {"rn", "se2", "se3"}


def test_several_goal_states_any_of_them_is_the_goal():
    closed = PlanningProblem(space=RealVectorSpace([0, 0], [1, 1]), start=np.array([0.1, 0.1]),
                             goal=np.array([0.9, 0.1]), goal_states=np.array([[0.9, 0.1], [0.2, 0.9]]),
                             validity=lambda q: np.abs(np.atleast_2d(q)[:, 0] - 0.5) > 0.05,
                             budget=Budget(max_iterations=500))
    result = planner().plan(closed, np.random.default_rng(0))
    assert result.status is Status.SOLVED                    # the wall hides the first goal state, not the second
    assert np.array_equal(result.path.configurations[-1], [0.2, 0.9])
    assert closed.in_goal(result.path.configurations[-1:])[0]
