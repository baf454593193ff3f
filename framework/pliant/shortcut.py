"""Cost-aware shortcutting of a path (the post-processing step of sampling planners, e.g. OMPL's simplifier).

A path is densified at ``step``; then, ``iterations`` times, two of its states are drawn and the
stretch between them is replaced by the straight motion when that motion is valid and its cost (the
integral of the state cost, :meth:`PlanningProblem.path_cost`, plus ``length_weight`` x length) is
lower.  The result never costs more than the input, and every state of it passes the problem's
validity and the optional ``check`` (e.g. puncture detection of the whole path, thesis 4.3.4).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pliant.errors import DimensionError
from pliant.interfaces import PlanningProblem


def _segment_costs(problem: PlanningProblem, dense: np.ndarray, length_weight: float) -> np.ndarray:
    """``(k-1,)``: cost of each step of a dense path, ``(c(q_j) + length_weight) |q_j - q_{j-1}|``."""
    steps = np.asarray(problem.space.distance(dense[:-1], dense[1:]), dtype=np.float64)
    costs = problem.cost.cost(dense[1:]) if problem.cost is not None else np.zeros(len(steps))
    return (costs + length_weight) * steps


def shortcut(problem: PlanningProblem, configurations: np.ndarray, rng: np.random.Generator, *, step: float,
             iterations: int = 200, length_weight: float = 0.0,
             check: Callable[[np.ndarray], bool] | None = None) -> tuple[np.ndarray, float]:
    """Shortcut a path ``(k, d)``; returns the dense improved path and its cost.

    ``step``: densification and checking distance (space metric units).  ``check(path) -> bool`` may
    veto a candidate whole path (it sees the full dense path, so path-dependent checks stay exact).
    """
    if not step > 0:
        raise DimensionError("step must be positive", field="step", value=step)
    if iterations < 0:
        raise DimensionError("iterations must be >= 0", field="iterations", value=iterations)
    dense = problem.densify(configurations, step)
    segments = _segment_costs(problem, dense, length_weight)
    for _ in range(iterations):
        if len(dense) < 3:
            break
        i, j = np.sort(rng.choice(len(dense), size=2, replace=False))
        if j - i < 2:
            continue
        bridge = problem.space.discretize(dense[i], dense[j], step)
        if not problem.is_valid(bridge[1:-1]).all():
            continue
        bridge_segments = _segment_costs(problem, bridge, length_weight)
        if not np.sum(bridge_segments) < np.sum(segments[i:j]) - 1e-12:
            continue
        candidate = np.vstack([dense[: i + 1], bridge[1:-1], dense[j:]])
        if check is not None and not check(candidate):
            continue
        dense = candidate
        segments = np.concatenate([segments[:i], bridge_segments, segments[j:]])
    return dense, float(np.sum(segments))
