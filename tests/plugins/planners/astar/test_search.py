"""The A* kernel is exact: it matches a brute-force Dijkstra on random grids."""

from __future__ import annotations

import heapq

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant_astar.search import path_deformation, path_length, search


def dijkstra(costs: np.ndarray, start, goal, p: float) -> float:
    """Brute force: edge s -> t weighs (1-p)|t - s| + p c(t); start weight p c(start)."""
    shape = costs.shape
    best = {start: p * costs[start]}
    heap = [(best[start], start)]
    while heap:
        d, s = heapq.heappop(heap)
        if s == goal:
            return d
        if d > best.get(s, np.inf):
            continue
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    if dx == dy == dz == 0:
                        continue
                    t = (s[0] + dx, s[1] + dy, s[2] + dz)
                    if not all(0 <= t[i] < shape[i] for i in range(3)) or np.isnan(costs[t]):
                        continue
                    nd = d + (1 - p) * np.sqrt(dx * dx + dy * dy + dz * dz) + p * costs[t]
                    if nd < best.get(t, np.inf):
                        best[t] = nd
                        heapq.heappush(heap, (nd, t))
    return np.inf


@settings(max_examples=60)
@given(st.integers(0, 2**32 - 1), st.floats(0.0, 1.0))
def test_astar_matches_dijkstra(seed, p):
    rng = np.random.default_rng(seed)
    shape = tuple(int(n) for n in rng.integers(2, 8, 3))
    costs = rng.choice([0.0, 0.0, 1.0, 3.5, 10.0], size=shape)
    costs[rng.random(shape) < 0.2] = np.nan
    start = tuple(int(rng.integers(0, n)) for n in shape)
    goal = tuple(int(rng.integers(0, n)) for n in shape)
    costs[start] = costs[goal] = 0.0
    cells, _, objective = search(costs, start, goal, p)
    expected = dijkstra(costs, start, goal, p)
    if np.isinf(expected):
        assert cells is None
        return
    assert abs(objective - expected) <= 1e-9 * max(1.0, expected)
    # the returned path really has that objective and is connected through passable cells
    assert tuple(cells[0]) == start and tuple(cells[-1]) == goal
    assert np.all(np.abs(np.diff(cells, axis=0)) <= 1)
    assert np.all(np.isfinite(costs[cells[:, 0], cells[:, 1], cells[:, 2]]))
    recomputed = (1 - p) * path_length(cells) + p * path_deformation(costs, cells)
    assert abs(recomputed - expected) <= 1e-9 * max(1.0, expected)


def test_straight_free_line():
    costs = np.zeros((10, 3, 3))
    cells, _, objective = search(costs, (0, 1, 1), (9, 1, 1), 0.3)
    assert len(cells) == 10 and objective == pytest.approx(0.7 * 9)


def test_unreachable_goal():
    costs = np.zeros((5, 5, 5))
    costs[2] = np.nan
    cells, expanded, objective = search(costs, (0, 0, 0), (4, 4, 4), 0.5)
    assert cells is None and np.isinf(objective) and expanded > 0


def test_p_one_prefers_zero_deformation_over_length():
    costs = np.zeros((5, 9, 1))
    costs[:4, 4, 0] = 5.0        # a soft wall with a gap at x = 4
    cells, _, _ = search(costs, (0, 0, 0), (0, 8, 0), 1.0)
    assert path_deformation(costs, cells) == 0.0
    cells0, _, _ = search(costs, (0, 0, 0), (0, 8, 0), 0.0)
    assert path_length(cells0) == 8.0 and path_deformation(costs, cells0) == 5.0
