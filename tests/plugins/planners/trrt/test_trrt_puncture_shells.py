"""Issue 31, item 2, for T-RRT and GradienT-RRT: with the puncture check on, no returned path -- shortcut or not
-- opens a hollow shell's void or cuts it when swept at 1/10 voxel; the whole path returned is checked once more
after post-processing, and a planner whose solutions all fail that check says so instead of returning one."""

from __future__ import annotations

import numpy as np
import pytest
from pliant.registry import create
from pliant.results import Status
from pliant.termination import Termination


def _plan(shells, name: str, thickness: int, seed: int, iterations: int = 4000, **options):
    problem = shells.problem(thickness, np.random.default_rng(1000 + seed))
    planner = create("planner", name, max_step=0.15, puncture_check=True, max_time=None, progress=False, **options)
    return problem, planner.plan(problem, np.random.default_rng(seed), Termination(max_iterations=iterations))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["trrt", "gradient-trrt"])
@pytest.mark.parametrize("thickness", [1, 2, 3])
def test_no_returned_path_opens_a_shell_when_swept_at_a_tenth_of_a_voxel(shells, name, thickness):
    for seed in range(5):
        problem, result = _plan(shells, name, thickness, seed, shortcut_iterations=50)
        assert result.statistics["final_check_refused"] == 0
        if result.status is Status.SOLVED:
            assert shells.damage(problem, result.path.configurations) == [], seed


def test_a_shortcut_path_is_checked_whole_after_shortcutting(shells):
    problem, result = _plan(shells, "trrt", 2, 0, shortcut_iterations=50)
    assert result.status is Status.SOLVED and result.statistics["final_check_refused"] == 0
    assert shells.damage(problem, result.path.configurations) == []


def test_a_post_processed_path_that_punctures_is_caught_and_the_tree_path_returned(shells, monkeypatch):
    """Post-processing that changes the path without checking it (here a stand-in shortcut that returns the
    path straight across the middle of the shell, through both walls): the final whole-path check refuses it and
    T-RRT returns its tree path, whose edges were checked."""
    import pliant_trrt.planner as trrt

    def straight_through(problem, path, rng, **_):
        across = [path[0], [0.07, 0.35, 0.35], [0.63, 0.35, 0.35], path[-1]]
        line = problem.densify(np.array(across), 0.05)
        return line, 0.0
    monkeypatch.setattr(trrt, "shortcut", straight_through)
    problem, result = _plan(shells, "trrt", 1, 0, shortcut_iterations=50)
    assert result.status is Status.SOLVED and result.statistics["final_check_refused"] >= 1
    assert result.cost == pytest.approx(result.statistics["tree_cost"])
    assert shells.damage(problem, result.path.configurations) == []
    assert shells.damage(problem, straight_through(problem, result.path.configurations, None)[0]) != []


def test_when_no_solution_passes_the_final_check_the_status_is_not_solved(shells, monkeypatch):
    from pliant.geometry.topology import PunctureChecker

    monkeypatch.setattr(PunctureChecker, "check", lambda self, q: (False, "puncture: refused for the test"))
    _, result = _plan(shells, "trrt", 1, 0)
    assert result.status is Status.TIMEOUT and result.path is None
    assert result.statistics["final_check_refused"] >= 1 and "final check" in result.message
