"""Batched edge evaluation for RRT*: discretise many edges at once, one cost call, per-edge sums.

An edge ``a -> b`` is discretised as :meth:`Space.discretize` does (``ceil(d(a, b) / step - 1e-9)`` equal
parts; the same interpolated states, bit for bit up to the interpolation's batching); its cost is the
discrete integral of :meth:`PlanningProblem.path_cost` over the states after ``a``,
``sum_j c(q_j) d(q_{j-1}, q_j)``, plus ``length_weight * d(a, b)`` — so the cost of a path is the
sum of its edges' costs, and a tree node's cost-from-root is the path cost of its branch (to rounding).
The steps ``d(q_{j-1}, q_j)`` are taken as ``d(a, b) / parts``: every built-in space interpolates at
constant speed along its geodesic (R^n, SE(2), SE(3) with slerp, their compounds), so this equals the
distance between consecutive states to rounding (tested against ``PlanningProblem.path_cost``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import CostModel, PlanningProblem


@dataclass
class Edges:
    """``m`` discretised edges.

    states: ``(k, d)`` every edge's states after its start, edge after edge.  offsets: ``(m + 1,)``,
    edge ``i`` owns ``states[offsets[i]:offsets[i + 1]]``.  state_costs: ``(k,)``.  cost: ``(m,)``
    edge costs (cost units).  valid: ``(m,)`` every state of the edge in bounds, passing the problem's
    checks and with a finite state cost not above the ceiling, and the motion collision-free at voxel
    resolution (:meth:`PlanningProblem.motions_valid`).  length: ``(m,)`` metric length.
    """

    states: np.ndarray
    offsets: np.ndarray
    state_costs: np.ndarray
    cost: np.ndarray
    valid: np.ndarray
    length: np.ndarray

    def of(self, i: int) -> np.ndarray:
        """The states ``(k_i, d)`` of edge ``i`` after its start."""
        return self.states[self.offsets[i]:self.offsets[i + 1]]


def state_validity(problem: PlanningProblem, q: np.ndarray, costs: np.ndarray, max_cost: float,
                   collisions: bool = True) -> np.ndarray:
    """Bool ``(n,)``: in bounds, collision-free (unless ``collisions`` is false: the states of a motion checked
    whole), passing ``problem.validity`` and the cost model's own check, cost <= ``max_cost``.

    A NaN cost (infeasible, thesis eq. 3.1) fails.  The cost model's ``is_valid`` is called only when
    it overrides the default (finite cost), which ``costs`` already says.
    """
    ok = np.asarray(problem.space.is_valid(q), dtype=bool) & (costs <= max_cost)
    if collisions and problem.checker is not None and ok.any():    # the core's checker, no cost model needed
        ok &= problem.checker.states_valid(q)
    if problem.validity is not None and ok.any():
        ok &= np.asarray(problem.validity(q), dtype=bool)
    cost = problem.cost
    if cost is not None and type(cost).is_valid is not CostModel.is_valid and ok.any():
        ok &= np.asarray(cost.is_valid(q), dtype=bool)
    return ok


def state_costs(problem: PlanningProblem, q: np.ndarray) -> np.ndarray:
    """State costs ``(n,)`` (zeros without a cost model)."""
    if problem.cost is None:
        return np.zeros(len(q))
    return np.asarray(problem.cost.cost(q), dtype=np.float64)


def evaluate_edges(problem: PlanningProblem, starts: np.ndarray, ends: np.ndarray, step: float,
                   length_weight: float = 0.0, max_cost: float = np.inf,
                   motions: np.ndarray | None = None, check_motions: bool = True) -> Edges:
    """Discretise the edges ``starts[i] -> ends[i]`` (``(m, d)`` each) at ``step`` and evaluate them in one batch.

    ``motions`` ``(m,)``: the verdicts of the same motions already checked the other way (``ends[i] -> starts[i]``);
    a motion is collision-free in either direction or in neither, so they are not checked again.
    ``check_motions=False`` leaves the motions unchecked: ``valid`` (and a finite ``cost``) then says only that
    every state passes, and the caller checks the motions it needs (:meth:`PlanningProblem.motions_valid`)."""
    space = problem.space
    starts, ends = np.broadcast_arrays(np.atleast_2d(starts), np.atleast_2d(ends))
    length = np.atleast_1d(np.asarray(space.distance(starts, ends), dtype=np.float64))
    # the slack of Space.discretize: an edge a hair longer than k steps (a steered edge of exactly max_step) is
    # split into k parts, as PlanningProblem.densify splits it for the final puncture check and path_cost
    counts = np.maximum(1, np.ceil(length / step - 1e-9).astype(np.int64))
    offsets = np.concatenate([[0], np.cumsum(counts)])
    owner = np.repeat(np.arange(len(starts)), counts)
    j = np.arange(offsets[-1]) - offsets[owner] + 1
    t = j * (1.0 / counts[owner])                         # as numpy.linspace computes i * (1 / n) ...
    t[offsets[1:] - 1] = 1.0                              # ... with the end exactly 1
    states = space.interpolate(starts[owner], ends[owner], t[:, None])
    steps = (length / counts)[owner]                     # interpolation is at constant speed along the geodesic
    costs = state_costs(problem, states)
    ok = state_validity(problem, states, costs, max_cost, collisions=False)     # collisions: the motions below
    weighted = np.where(ok, costs * steps, 0.0)
    cost = np.add.reduceat(weighted, offsets[:-1]) + length_weight * length
    valid = np.logical_and.reduceat(ok, offsets[:-1])
    if motions is not None:
        valid &= np.asarray(motions, dtype=bool)
    elif check_motions and valid.any():                   # the motions themselves, at voxel resolution
        valid[valid] = problem.motions_valid(starts[valid], ends[valid])
    return Edges(states, offsets, costs, np.where(valid, cost, np.inf), valid, length)
