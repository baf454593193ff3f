"""Cost-aware shortcutting: never costlier, always valid, vetoes respected, zig-zags straightened."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import Pipeline
from pliant.errors import DimensionError
from pliant.interfaces import PlanningProblem
from pliant.planning.shortcut import perturb, shortcut


@pytest.fixture(scope="module")
def problem():
    return PlanningProblem.from_context(Pipeline("triple-wall", cost="voxel", planner="straight").build())


def zigzag(problem, n=9):
    """A valid but wasteful path: the straight line through the walls with every other state moved sideways."""
    start, goal = problem.start, problem.goal
    t = np.linspace(0, 1, n)[:, None]
    path = start + t * (goal - start)
    path[1:-1:2, 2] -= 0.03
    assert problem.is_valid(problem.densify(path, problem.scene.resolution)).all()
    return path


def test_a_zigzag_through_the_walls_gets_cheaper_and_stays_valid(problem):
    path = zigzag(problem)
    step = problem.scene.resolution
    before = problem.path_cost(path, step)
    dense, cost = shortcut(problem, path, np.random.default_rng(0), step=step, iterations=300)
    assert cost <= before and cost == pytest.approx(problem.path_cost(dense, step))
    assert problem.is_valid(dense).all()
    assert np.allclose(dense[0], path[0]) and np.allclose(dense[-1], path[-1])


def test_with_a_length_weight_a_free_zigzag_straightens(problem):
    space = problem.space
    path = zigzag(problem)
    step = problem.scene.resolution
    dense, _ = shortcut(problem, path, np.random.default_rng(1), step=step, iterations=500, length_weight=1e6)
    assert space.path_length(dense) < space.path_length(problem.densify(path, step))


def test_a_veto_keeps_the_original_path(problem):
    path = zigzag(problem)
    step = problem.scene.resolution
    dense, cost = shortcut(problem, path, np.random.default_rng(0), step=step, iterations=100, check=lambda p: False)
    assert np.array_equal(dense, problem.densify(path, step))
    assert cost == pytest.approx(problem.path_cost(path, step))


def test_bad_arguments_name_the_field(problem):
    with pytest.raises(DimensionError, match="step"):
        shortcut(problem, zigzag(problem), np.random.default_rng(0), step=0.0)
    with pytest.raises(DimensionError, match="iterations"):
        shortcut(problem, zigzag(problem), np.random.default_rng(0), step=0.01, iterations=-1)


@pytest.fixture(scope="module")
def cube_wall():
    return PlanningProblem.from_context(Pipeline("cube-wall", cost="voxel", planner="straight").build())


def off_centre_passage(problem):
    """The cube straight through the blue hole (centre x 0.71, z 0.51) but 4 cm off its centre in x."""
    q = lambda x, y, z: np.array([x, y, z, 0.0, 0.0, 0.0, 1.0])  # noqa: E731
    return np.array([q(0.5, 0.2, 0.5), q(0.75, 0.35, 0.51), q(0.75, 0.65, 0.51), q(0.5, 0.8, 0.5)])


def test_perturbation_moves_an_off_centre_passage_to_the_hole_centre(cube_wall):
    """Shortcutting cannot re-centre the passage (every shortcut still crosses the wall off-centre); the
    perturbation can: the cost falls well below shortcutting's and the crossing moves toward x = 0.71."""
    path, step = off_centre_passage(cube_wall), cube_wall.scene.resolution
    before = cube_wall.path_cost(path, step)
    _, short = shortcut(cube_wall, path, np.random.default_rng(0), step=step, iterations=300)
    dense, cost = perturb(cube_wall, path, np.random.default_rng(0), step=step, spacing=0.05, sigma=0.02,
                          iterations=300)
    assert cost == pytest.approx(cube_wall.path_cost(dense, step)) and cube_wall.is_valid(dense).all()
    assert cost < 0.8 * min(before, short)
    assert np.allclose(dense[0], path[0]) and np.allclose(dense[-1], path[-1])
    crossing = dense[np.argmin(np.abs(dense[:, 1] - 0.5))]
    assert abs(crossing[0] - 0.71) < abs(0.75 - 0.71)


def test_perturbation_never_raises_the_cost_and_a_veto_keeps_the_path(cube_wall):
    path, step = off_centre_passage(cube_wall), cube_wall.scene.resolution
    dense, cost = perturb(cube_wall, path, np.random.default_rng(2), step=step, spacing=0.05, sigma=0.02,
                          iterations=50, check=lambda p: False)
    assert cost == pytest.approx(cube_wall.path_cost(dense, step))
    assert cost == pytest.approx(cube_wall.path_cost(path, step), rel=1e-9)
    with pytest.raises(DimensionError, match="sigma"):
        perturb(cube_wall, path, np.random.default_rng(0), step=step, spacing=0.05, sigma=0.0)


def test_motions_are_checked_only_for_cheaper_bridges_and_the_path_is_that_of_checking_them_first(problem, monkeypatch):
    """The straight motion of a shortcut (the expensive check) is checked only once its bridge is found cheaper: the
    same path, bit for bit, as checking every motion first (the loop as it was), with motions barred by their
    midpoint alone so that the motion check decides some shortcuts."""
    import dataclasses

    from pliant.planning.shortcut import _segment_costs

    checked = []

    def barred(a, b):
        checked.append(1)
        return bool(np.floor((a[0] + b[0]) / 0.013) % 3 != 0)

    barred_problem = dataclasses.replace(problem)
    monkeypatch.setattr(barred_problem, "motion_is_valid", barred)
    path, step = zigzag(problem, 15), problem.scene.resolution
    dense, cost = shortcut(barred_problem, path, np.random.default_rng(4), step=step, iterations=300, length_weight=1.0)
    lazy_checks, checked[:] = len(checked), []

    rng = np.random.default_rng(4)                  # the loop as it was: every motion checked before the cost
    ref = problem.densify(path, step)
    segments = _segment_costs(problem, ref, 1.0)
    rejected_by_motion = 0
    for _ in range(300):
        i, j = np.sort(rng.choice(len(ref), size=2, replace=False))
        if j - i < 2:
            continue
        bridge = problem.space.discretize(ref[i], ref[j], step)
        if not problem.is_valid(bridge[1:-1]).all():
            continue
        if not barred(ref[i], ref[j]):
            rejected_by_motion += 1
            continue
        bridge_segments = _segment_costs(problem, bridge, 1.0)
        if not np.sum(bridge_segments) < np.sum(segments[i:j]) - 1e-12:
            continue
        ref = np.vstack([ref[: i + 1], bridge[1:-1], ref[j:]])
        segments = np.concatenate([segments[:i], bridge_segments, segments[j:]])
    assert np.array_equal(dense, ref) and cost == float(np.sum(segments))
    assert rejected_by_motion > 0 and lazy_checks < len(checked)
