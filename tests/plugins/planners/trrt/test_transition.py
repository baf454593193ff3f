"""T-RRT's transition test follows the temperature rule (Jaillet et al. 2010, Algorithm 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pliant_trrt.transition import TransitionTest


def test_downhill_and_flat_transitions_are_always_accepted_without_changing_the_temperature():
    test = TransitionTest(temperature=1e-9, n_fail_max=0)
    rng = np.random.default_rng(0)
    assert all(test(5.0, c, 0.1, rng) for c in (5.0, 4.0, 0.0))
    assert test.temperature == 1e-9 and test.n_fail == 0


def test_uphill_acceptance_rate_matches_the_boltzmann_probability():
    test = TransitionTest(temperature=2.0, k=0.5, n_fail_max=10 ** 9, alpha=1.0 + 1e-12)
    p = test.probability(1.0, 1.5, 0.25)
    assert p == pytest.approx(math.exp(-(0.5 / 0.25) / (0.5 * 2.0)))
    rng = np.random.default_rng(1)
    accepted = np.mean([test(1.0, 1.5, 0.25, rng) for _ in range(20000)])
    assert accepted == pytest.approx(p, abs=0.01)


def test_an_acceptance_cools_and_n_fail_max_refusals_heat():
    test = TransitionTest(temperature=1.0, k=1.0, alpha=2.0, n_fail_max=3)
    rng = np.random.default_rng(0)
    # a hopeless climb: refused; the temperature doubles after the failure count passes n_fail_max
    for _ in range(3):
        assert not test(0.0, 1e6, 1.0, rng)
    assert test.temperature == 1.0 and test.n_fail == 3
    assert not test(0.0, 1e6, 1.0, rng)
    assert test.temperature == 2.0 and test.n_fail == 0
    # a certain climb at a huge temperature: accepted, and the temperature halves
    hot = TransitionTest(temperature=1e12, alpha=2.0)
    assert hot(0.0, 1.0, 1.0, rng) and hot.temperature == 5e11 and hot.accepted_uphill == 1


def test_states_above_the_cost_ceiling_are_refused_without_touching_the_temperature():
    test = TransitionTest(temperature=1e12, max_cost=2.0, n_fail_max=0)
    rng = np.random.default_rng(0)
    assert not test(0.0, 3.0, 1.0, rng) and not test(5.0, 2.5, 1.0, rng)     # even downhill, above the ceiling
    assert test.temperature == 1e12 and test.refused == 0


def test_cost_range_cooling_cools_more_after_a_bigger_climb():
    rng = np.random.default_rng(0)
    small, big = (TransitionTest(temperature=1e12, alpha=2.0, cost_range_cooling=True) for _ in range(2))
    for test in (small, big):
        assert test(0.0, 0.0, 1.0, rng) and test(10.0, 10.0, 1.0, rng)       # the cost range seen: [0, 10]
    assert small(0.0, 0.5, 1.0, rng) and big(0.0, 2.0, 1.0, rng)
    assert small.temperature == pytest.approx(1e12 / 2.0 ** (0.5 / 1.0))
    assert big.temperature == pytest.approx(1e12 / 2.0 ** (2.0 / 1.0))
