"""Algorithm 2 with a perfect demonstrator: every comparable pair ordered, never a pair twice, few demonstrations."""

import numpy as np
import pytest
from pliant_piirl.active import PreferenceGraph, collect_demonstrations

NAMES = ["L1", "L2", "M1", "M2", "H1", "H2"]
OPPOSITE = {"L1": "L2", "L2": "L1", "M1": "M2", "M2": "M1", "H1": "H2", "H2": "H1"}
CUBE = {a: {b for b in NAMES if b not in (a, OPPOSITE[a])} for a in NAMES}
TRUTH = {"L": 0.2, "M": 0.4, "H": 0.8}


def oracle(asked):
    def collect(a, b):
        asked.append((a, b))
        less = a if TRUTH[a[0]] < TRUTH[b[0]] else b
        return {less: 1.0}
    return collect


@pytest.mark.parametrize("seed", range(15))
def test_the_cube_is_ranked_with_at_most_ten_of_its_twelve_pairs(seed):
    asked = []
    result = collect_demonstrations(CUBE, oracle(asked), np.random.default_rng(seed))
    assert result.asked == asked and len(asked) <= 10
    assert len({frozenset(p) for p in asked}) == len(asked)                         # never a pair twice
    g = result.graph
    assert g.nodes == set(NAMES)
    for a in NAMES:
        for b in NAMES:
            if TRUTH[a[0]] < TRUTH[b[0]]:
                assert g.reaches(a, b), (a, b)                                      # every comparable pair ordered
    ranking = g.ranking()
    assert [n[0] for n in ranking] == ["L", "L", "M", "M", "H", "H"]


def test_a_chain_needs_one_demonstration_per_link():
    chain = {"a": {"b"}, "b": {"a", "c"}, "c": {"b", "d"}, "d": {"c"}}
    order = {"a": 0, "b": 1, "c": 2, "d": 3}
    result = collect_demonstrations(chain, lambda x, y: {min(x, y, key=order.get): 1.0}, np.random.default_rng(0))
    assert len(result.asked) == 3 and result.graph.ranking() == ["a", "b", "c", "d"]


def test_an_inconsistent_or_indifferent_demonstrator_ends():
    flip = iter(range(100))
    result = collect_demonstrations(CUBE, lambda a, b: {a: float(next(flip) % 2), b: 0.5}, np.random.default_rng(1))
    assert len(result.asked) <= 12
    result = collect_demonstrations(CUBE, lambda a, b: {}, np.random.default_rng(1))
    assert all(p is None for p in result.preferences) and len(result.asked) <= 12


def test_depth_is_the_longest_path_ending_at_a_node():
    g = PreferenceGraph({"a", "b", "c", "d"}, {("a", "b"), ("b", "c"), ("a", "c"), ("c", "d")})
    assert [g.depth(n) for n in "abcd"] == [0, 1, 2, 3]
    assert g.reaches("a", "d") and not g.reaches("d", "a")
