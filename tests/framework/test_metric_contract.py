"""The core's check in front of every metric's ``evaluate`` (pliant.contracts.checked_evaluate, issue 31): a metric --
built-in or third-party -- is never handed a missing problem, a seed for a Generator, a malformed path, or waypoints
out of the workspace or inside an obstacle; each is one PliantError naming ``problem``, ``rng`` or ``path[i]``, and
the metric's own code does not run.  Waypoints valid in the problem reach it unchanged."""

from __future__ import annotations

import functools

import numpy as np
import pliant
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import registry
from pliant.contracts import WRAPPED
from pliant.errors import DimensionError, PlanningError
from pliant.interfaces import Context, PathMetric, PlanningProblem
from pliant.results import Path


class CountingMetric(PathMetric):
    """A third-party metric that scores any path by its waypoint count, counting its calls."""

    calls = 0

    def evaluate(self, path, problem, rng):
        CountingMetric.calls += 1
        return {"waypoints": float(len(path.configurations))}


class SubMetric(CountingMetric):
    """A subclass that does not override evaluate: the wrapped method is inherited, not wrapped twice."""


@functools.cache
def _passage():
    context = Context(scene=pliant.load_scene("se2-through-passage"))
    context.robot = registry.create("robot", "rigid", context)
    metric = CountingMetric()
    metric.bind(context)
    return metric, PlanningProblem.from_context(context)


@pytest.fixture
def passage():
    """se2-through-passage: the rigid L-block, a rigid wall at y 0.275 .. 0.325 m with a passage at x 0.21 .. 0.39."""
    return _passage()


FREE = [[0.2375, 0.12, 0.0], [0.2375, 0.42, 0.0]]     # the scene's start and goal: a valid path
RNG = np.random.default_rng(0)


def _refused(metric, *args):
    before = CountingMetric.calls
    with pytest.raises((PlanningError, DimensionError)) as info:
        metric.evaluate(*args)
    assert CountingMetric.calls == before, "the metric's code ran on refused input"
    assert "\n" not in str(info.value)
    return info.value


def test_every_metric_class_is_wrapped_once():
    assert getattr(CountingMetric.evaluate, WRAPPED, False)
    assert SubMetric.evaluate is CountingMetric.evaluate


def test_a_valid_path_reaches_the_metric(passage):
    metric, problem = passage
    assert metric.evaluate(Path(np.array(FREE)), problem, RNG) == {"waypoints": 2.0}


def test_no_problem_is_an_error_naming_problem(passage):
    metric, _ = passage
    error = _refused(metric, Path(np.array(FREE)), None, RNG)
    assert error.field == "problem" and "PlanningProblem" in str(error)


def test_a_seed_where_a_generator_goes_is_an_error_naming_rng(passage):
    metric, problem = passage
    assert _refused(metric, Path(np.array(FREE)), problem, 7).field == "rng"


@pytest.mark.parametrize("path, field", [
    (np.array(FREE), "path"),                                         # an array, not a Path
    (Path(np.zeros((2, 4))), "path"),                                 # the wrong dimension
    (Path(np.array([[0.2375, 0.12, 0.0], [np.nan, 0.3, 0.0]])), "path[1]"),
])
def test_malformed_paths_are_errors_naming_the_path(passage, path, field):
    metric, problem = passage
    assert _refused(metric, path, problem, RNG).field == field


def test_a_waypoint_outside_the_workspace_is_refused_naming_it_and_the_bounds(passage):
    metric, problem = passage
    error = _refused(metric, Path(np.array([FREE[0], [1e6, 0.42, 0.0]])), problem, RNG)
    assert error.field == "path[1]" and error.value == [1e6, 0.42, 0.0]
    assert "waypoint 1 is not valid" in str(error) and "[0.0, 0.0] .. [0.6, 0.6]" in str(error)


def test_a_path_starting_inside_the_wall_is_refused_naming_the_wall(passage):
    metric, problem = passage
    # the L's corner at (0.1, 0.3): its arms lie in the wall beside the passage
    error = _refused(metric, Path(np.array([[0.1, 0.3, 0.0], FREE[1]])), problem, RNG)
    assert error.field == "path[0]" and "'wall'" in str(error)


def test_a_body_outside_the_workspace_is_refused_though_its_reference_point_is_inside(passage):
    metric, problem = passage
    # the reference point (the L's corner) 1 cm inside the lower-left corner: its arms' thickness pokes out
    error = _refused(metric, Path(np.array([FREE[0], [0.01, 0.01, 0.0]])), problem, RNG)
    assert error.field == "path[1]"


XY = st.floats(-0.1, 0.7, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(XY, XY, st.floats(-np.pi, np.pi)), min_size=1, max_size=5))
def test_refused_iff_a_waypoint_is_invalid_in_the_problem_naming_the_first(waypoints):
    metric, problem = _passage()
    q = np.array(waypoints)
    valid = problem.is_valid(q)
    if valid.all():
        assert metric.evaluate(Path(q), problem, RNG) == {"waypoints": float(len(q))}
        return
    first = int(np.argmin(valid))
    assert _refused(metric, Path(q), problem, RNG).field == f"path[{first}]"
