"""A growing tree of configurations for sampling-based planners (RRT, T-RRT, RRT*, belief RRT).

Nodes live in contiguous arrays that double when full, so nearest-neighbour queries are one batched
call of the space's distance over every active node (numpy, no Python loop per node).  Each node has a
parent (``-1`` for roots), a state cost and a cost-from-root, and can be excluded from
nearest-neighbour queries (the belief planner retires solved branches, thesis 5.3.1).
"""

from __future__ import annotations

import numpy as np

from pliant.errors import DimensionError
from pliant.spaces import Space


class Tree:
    """Configurations ``(n, d)`` with parent links, state costs and path costs.

    ``capacity`` is the initial allocation (it grows by doubling).  Distances are the space's own
    (weighted) metric.
    """

    def __init__(self, space: Space, capacity: int = 1024) -> None:
        if capacity < 1:
            raise DimensionError("capacity must be at least 1", field="capacity", value=capacity)
        self.space = space
        self._q = np.empty((capacity, space.dim))
        self._parent = np.full(capacity, -1, dtype=np.int64)
        self._state_cost = np.zeros(capacity)
        self._path_cost = np.zeros(capacity)
        self._active = np.ones(capacity, dtype=bool)
        self._n = 0

    def __len__(self) -> int:
        return self._n

    @property
    def configurations(self) -> np.ndarray:
        """``(n, d)`` view of the nodes' configurations."""
        return self._q[: self._n]

    @property
    def parents(self) -> np.ndarray:
        """``(n,)`` parent index of each node (``-1`` for a root)."""
        return self._parent[: self._n]

    @property
    def state_costs(self) -> np.ndarray:
        """``(n,)`` state cost of each node."""
        return self._state_cost[: self._n]

    @property
    def path_costs(self) -> np.ndarray:
        """``(n,)`` cost of the path from the root to each node (the planner's objective)."""
        return self._path_cost[: self._n]

    @property
    def active(self) -> np.ndarray:
        """``(n,)`` whether each node takes part in nearest-neighbour queries."""
        return self._active[: self._n]

    def _grow(self) -> None:
        size = 2 * len(self._q)
        for name in ("_q", "_parent", "_state_cost", "_path_cost", "_active"):
            old = getattr(self, name)
            new = np.empty((size,) + old.shape[1:], dtype=old.dtype)
            new[: len(old)] = old
            setattr(self, name, new)

    def add(self, q: np.ndarray, parent: int = -1, state_cost: float = 0.0, path_cost: float = 0.0) -> int:
        """Append a node ``(d,)`` under ``parent`` (``-1``: a root); returns its index."""
        if parent >= self._n or parent < -1:
            raise DimensionError(f"parent must be -1 or a node index below {self._n}", field="parent", value=parent)
        if self._n == len(self._q):
            self._grow()
        i = self._n
        self._q[i] = q
        self._parent[i] = parent
        self._state_cost[i] = state_cost
        self._path_cost[i] = path_cost
        self._active[i] = True
        self._n += 1
        return i

    def set_parent(self, node: int, parent: int, path_cost: float) -> None:
        """Rewire ``node`` under ``parent`` with a new cost-from-root (descendants are not updated here)."""
        if parent == node or parent < 0 or parent >= self._n:
            raise DimensionError("parent must be another existing node", field="parent", value=parent)
        self._parent[node] = parent
        self._path_cost[node] = path_cost

    def rewire(self, node: int, parent: int, path_cost: float) -> np.ndarray:
        """Re-parent ``node`` under ``parent`` with a new cost-from-root and shift every descendant's cost by the
        same change (edge costs are unchanged, as for RRT*'s additive objectives); returns the descendants."""
        if 0 <= parent < self._n and node in self.branch(parent):
            raise DimensionError("parent is below node: the rewiring would form a cycle", field="parent", value=parent)
        below = self.descendants(node)
        delta = path_cost - self._path_cost[node]
        self.set_parent(node, parent, path_cost)
        self._path_cost[below] += delta
        return below

    def deactivate(self, nodes) -> None:
        """Exclude ``nodes`` from nearest-neighbour queries (they stay in the tree)."""
        self._active[np.asarray(nodes, dtype=np.int64)] = False

    def distances(self, q: np.ndarray) -> np.ndarray:
        """``(n,)`` distances from every node to ``q`` ``(d,)``."""
        return np.asarray(self.space.distance(self.configurations, q), dtype=np.float64)

    def nearest(self, q: np.ndarray) -> int:
        """Index of the active node nearest to ``q`` (``-1`` when no node is active)."""
        d = self.distances(q)
        d[~self.active] = np.inf
        i = int(np.argmin(d)) if len(d) else -1
        return i if i >= 0 and np.isfinite(d[i]) else -1

    def near(self, q: np.ndarray, radius: float) -> np.ndarray:
        """Indices of the active nodes within ``radius`` of ``q``, nearest first."""
        d = self.distances(q)
        inside = np.nonzero((d <= radius) & self.active)[0]
        return inside[np.argsort(d[inside], kind="stable")]

    def descendants(self, node: int) -> np.ndarray:
        """Indices of every node below ``node`` (breadth first, ``node`` excluded)."""
        out, frontier = [], np.array([node])
        parents = self.parents
        while frontier.size:
            frontier = np.nonzero(np.isin(parents, frontier))[0]
            out.append(frontier)
        return np.concatenate(out) if out else np.empty(0, dtype=np.int64)

    def branch(self, node: int) -> np.ndarray:
        """Node indices from the root to ``node`` inclusive."""
        chain = [node]
        while self._parent[chain[-1]] >= 0:
            chain.append(int(self._parent[chain[-1]]))
            if len(chain) > self._n:
                raise DimensionError("the parent links form a cycle", field="parent", value=node)
        return np.array(chain[::-1], dtype=np.int64)

    def path_to(self, node: int) -> np.ndarray:
        """Configurations ``(k, d)`` from the root to ``node``."""
        return self.configurations[self.branch(node)].copy()
