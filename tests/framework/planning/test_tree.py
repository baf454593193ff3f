"""The planners' tree: growth, nearest neighbours against brute force, branches, exclusion."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import DimensionError
from pliant.planning.tree import Tree
from pliant.spaces import RealVectorSpace, SE3Space


def test_nodes_grow_past_the_initial_capacity_and_keep_their_data():
    tree = Tree(RealVectorSpace([0, 0], [1, 1]), capacity=2)
    for k in range(10):
        tree.add(np.array([k / 10, 0.0]), parent=k - 1, state_cost=k, path_cost=2 * k)
    assert len(tree) == 10
    assert np.allclose(tree.configurations[:, 0], np.arange(10) / 10)
    assert np.array_equal(tree.parents, np.arange(-1, 9))
    assert np.allclose(tree.path_costs, 2 * np.arange(10))
    assert np.array_equal(tree.branch(9), np.arange(10))
    assert np.array_equal(tree.descendants(6), [7, 8, 9])


@settings(max_examples=30, derandomize=True)
@given(st.integers(min_value=1, max_value=60), st.integers(min_value=0, max_value=10_000))
def test_nearest_and_near_equal_brute_force_in_se3(n, seed):
    space = SE3Space([0, 0, 0], [1, 1, 1])
    rng = np.random.default_rng(seed)
    tree = Tree(space, capacity=4)
    points = space.sample(rng, n)
    for q in points:
        tree.add(q)
    query = space.sample(rng, 1)[0]
    brute = [float(space.distance(q, query)) for q in points]
    assert tree.nearest(query) == int(np.argmin(brute))
    radius = float(np.median(brute))
    assert sorted(tree.near(query, radius).tolist()) == [i for i, d in enumerate(brute) if d <= radius]


def test_deactivated_nodes_are_never_nearest():
    tree = Tree(RealVectorSpace([0.0], [10.0]))
    for x in (0.0, 5.0, 9.0):
        tree.add(np.array([x]))
    assert tree.nearest(np.array([4.0])) == 1
    tree.deactivate([1])
    assert tree.nearest(np.array([4.0])) == 0
    assert 1 not in tree.near(np.array([5.0]), 10.0)
    tree.deactivate([0, 2])
    assert tree.nearest(np.array([4.0])) == -1


def test_rewiring_changes_the_branch_and_bad_parents_are_refused():
    tree = Tree(RealVectorSpace([0.0], [10.0]))
    for x in (0.0, 1.0, 2.0):
        tree.add(np.array([x]), parent=len(tree) - 1)
    tree.set_parent(2, 0, path_cost=2.0)
    assert np.array_equal(tree.branch(2), [0, 2]) and tree.path_costs[2] == 2.0
    with pytest.raises(DimensionError, match="parent"):
        tree.add(np.array([3.0]), parent=7)
    with pytest.raises(DimensionError, match="parent"):
        tree.set_parent(1, 1, 0.0)


def test_rewire_shifts_the_subtree_costs_and_refuses_cycles():
    tree = Tree(RealVectorSpace([0], [10]))
    for k in range(5):                                     # a chain 0 - 1 - 2 - 3 - 4, path cost = index
        tree.add(np.array([float(k)]), parent=k - 1, path_cost=float(k))
    side = tree.add(np.array([0.5]), parent=0, path_cost=0.5)
    below = tree.rewire(2, side, 1.0)                      # 2 gets cheaper by 1: so do 3 and 4
    assert sorted(below.tolist()) == [3, 4]
    assert np.allclose(tree.path_costs, [0, 1, 1, 2, 3, 0.5])
    assert np.array_equal(tree.branch(4), [0, side, 2, 3, 4])
    with pytest.raises(DimensionError, match="cycle"):
        tree.rewire(2, 4, 0.0)                             # 4 is below 2
