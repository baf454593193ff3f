"""Hostile input to the ch. 6 metrics (issue 31): ``evaluate(path, None)`` was an AttributeError, and a path whose
waypoints leave the workspace or start inside an obstacle scored 0.0 (1.0 with ``distribution = "uniform"``).  Each is
now one PliantError naming ``problem`` or ``path[i]`` (the core's check, pliant.contracts.checked_evaluate)."""

import numpy as np
import pytest
from pliant.errors import PlanningError
from pliant.interfaces import PlanningProblem
from pliant.results import Path
from reachability_helpers import START, metric, passage

METHODS = ("reachable-volume", "sampling-driven", "simulation", "simulation-scaled")
SMALL = {"simulations": 10, "largest_volume_samples": 20, "particles": 20, "labelled": 5}


@pytest.mark.parametrize("name", METHODS)
def test_no_problem_is_an_error_naming_it(name):
    m = metric(passage(), name, **SMALL)
    with pytest.raises(PlanningError, match=r"^problem: .*PlanningProblem") as info:
        m.evaluate(Path(np.array([START, START + [0.1, 0.0, 0.0]])), None, np.random.default_rng(0))
    assert info.value.value is None


@pytest.mark.parametrize("distribution", ["propagated", "uniform"])
@pytest.mark.parametrize("path, index, words", [
    ([START, [0.2375, 5.0, 0.0]], 1, "outside the space's bounds [0.0, 0.0] .. [0.6, 0.6]"),   # leaves the workspace
    ([[0.1, 0.3, 0.0], [0.1, 0.5, 0.0]], 0, "collides with object 'wall'"),                  # starts in the wall
    ([START, [0.59, 0.12, 0.0]], 1, "leaves the workspace"),             # reference point in, the L's arm out
])
def test_reachable_volume_refuses_waypoints_out_of_the_workspace_or_in_an_obstacle(distribution, path, index, words):
    context = passage()
    m = metric(context, "reachable-volume", distribution=distribution, **SMALL)
    with pytest.raises(PlanningError) as info:
        m.evaluate(Path(np.array(path, dtype=float)), PlanningProblem.from_context(context), np.random.default_rng(0))
    assert info.value.field == f"path[{index}]" and words in str(info.value), str(info.value)
