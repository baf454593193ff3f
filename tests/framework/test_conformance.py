"""Every built-in component passes the conformance kit (later plugins are covered automatically)."""

from __future__ import annotations

import numpy as np
import pytest
from pliant.registry import default_registry
from pliant.spaces import RealVectorSpace
from pliant.testing import ConformanceFailure, check_component, check_space

CHECKED_KINDS = ("robot", "cost", "planner", "simulator", "controller")


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
