"""Every built-in component passes the conformance kit (later plugins are covered automatically)."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import registry
from pliant.errors import DimensionError
from pliant.interfaces import Learner, PathMetric
from pliant.registry import default_registry
from pliant.spaces import RealVectorSpace
from pliant.testing import CHECKED_KINDS, ConformanceFailure, check_component, check_space


def _builtins():
    return [(e.kind, e.name) for e in default_registry().entries()
            if e.distribution == "pliant" and e.kind in CHECKED_KINDS]


@pytest.mark.parametrize(("kind", "name"), _builtins(), ids=lambda v: str(v))
def test_builtin_component_conforms(kind, name):
    rules = check_component(kind, name)
    assert rules


def test_builtins_are_all_checked():
    kinds = {k for k, _ in _builtins()}
    assert {"robot", "planner"} <= kinds


def test_kit_detects_a_broken_space():
    class Broken(RealVectorSpace):
        def distance(self, a, b):  # not symmetric
            return super().distance(a, b) + (a[..., 0] > b[..., 0])

    with pytest.raises(ConformanceFailure, match="symmetric"):
        check_space(Broken([0, 0], [1, 1]))


def test_pytest_plugin_fixture(pliant_conformance, pliant_rng):
    assert pliant_conformance.check_space(RealVectorSpace([0.0], [1.0]))
    assert pliant_rng.random() == np.random.default_rng(0).random()     # the fixture is seeded with 0


# --- metrics, learners and drivers: the kit checks their contracts, not only that they were created -----------


class PathLength(PathMetric):
    """A correct metric: the path's length in the space's metric."""

    def evaluate(self, path, problem, rng):
        q = problem.space.check(path.configurations, field="path")
        return {"length": float(problem.space.path_length(q))}


class NoisyLength(PathLength):
    """Broken: ignores the seed it is given."""

    def evaluate(self, path, problem, rng):
        return {"length": super().evaluate(path, problem, rng)["length"] + np.random.default_rng().random()}


class CrashingLength(PathLength):
    """Would crash with a traceback on a path of the wrong size, but the core refuses such a path before evaluate runs
    (pliant.contracts.checked_evaluate), so it passes the kit."""

    def evaluate(self, path, problem, rng):
        return {"length": float(np.sum(np.diff(path.configurations, axis=0) @ np.ones(problem.space.dim)))}


class MeanLearner(Learner):
    """A correct learner: the mean of its samples."""

    example_data = staticmethod(lambda: [1.0, 2.0, 4.0])

    def fit(self, data, rng):
        if len(data) == 0:
            raise DimensionError("needs at least one sample", field="data", value=data)
        return {"mean": float(np.mean(data))}


class SilentLearner(MeanLearner):
    """Broken: returns garbage for empty data instead of an error."""

    def fit(self, data, rng):
        return {"mean": float(np.mean(data)) if len(data) else float("nan")}


@pytest.mark.parametrize(("cls", "broken"), [(PathLength, None), (NoisyLength, "same seed gives the same scores"),
                                             (CrashingLength, None)])
def test_the_kit_checks_a_metrics_evaluate(cls, broken):
    registry.register("metric", "kit-test", cls)
    try:
        if broken is None:
            assert check_component("metric", "kit-test") == ["named scores", "determinism", "bad input"]
        else:
            with pytest.raises(ConformanceFailure, match=broken):
                check_component("metric", "kit-test")
    finally:
        default_registry().unregister("metric", "kit-test")


@pytest.mark.parametrize(("cls", "broken"), [(MeanLearner, None), (SilentLearner, "empty data raises PliantError")])
def test_the_kit_checks_a_learners_fit(cls, broken):
    registry.register("learner", "kit-test", cls)
    try:
        if broken is None:
            assert check_component("learner", "kit-test") == ["parameters", "determinism", "empty data"]
        else:
            with pytest.raises(ConformanceFailure, match=broken):
                check_component("learner", "kit-test")
    finally:
        default_registry().unregister("learner", "kit-test")


def test_a_learner_without_example_data_is_told_to_declare_it():
    class Bare(Learner):
        def fit(self, data, rng):
            return {"x": 1.0}

    with pytest.raises(ConformanceFailure, match="example_data"):
        _check_bare(Bare)


def _check_bare(cls):
    registry.register("learner", "kit-bare", cls)
    try:
        check_component("learner", "kit-bare")
    finally:
        default_registry().unregister("learner", "kit-bare")


def test_build_context_creates_components_with_the_given_options():
    from pliant.testing.conformance import build_context

    ctx = build_context("tsrrt-table", options={"simulator": {"max_force": 50.0}}, simulator="pymunk")
    assert ctx.simulator.options.max_force == 50.0
    assert build_context("tsrrt-table", simulator="pymunk").simulator.options.max_force == 2000.0


def test_kit_detects_a_robot_that_reuses_its_points_buffer(scene_context):
    """Callers keep body_points' result (the kinematic simulator reuses a step's end points for the next step): a
    robot that writes every call into one buffer breaks them, and the kit says so."""
    from pliant.testing import check_robot

    robot = scene_context("triple-wall").robot

    class Reusing:
        def __init__(self, inner):
            self._inner, self._buffers = inner, {}             # one buffer per result shape

        def __getattr__(self, name):
            return getattr(self._inner, name)

        def body_points(self, q, indices=None):
            fresh = self._inner.body_points(q, indices)
            buffer = self._buffers.setdefault(fresh.shape, np.empty_like(fresh))
            buffer[...] = fresh
            return buffer

    assert "a new array per call" in check_robot(robot)
    with pytest.raises(ConformanceFailure, match="a new array each call"):
        check_robot(Reusing(robot))
