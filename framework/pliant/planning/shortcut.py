"""Cost-aware shortcutting of a path (the post-processing step of sampling planners, e.g. OMPL's simplifier).

A path is densified at ``step``; then, ``iterations`` times, two of its states are drawn and the
stretch between them is replaced by the straight motion when that motion is valid and its cost (the
integral of the state cost, :meth:`PlanningProblem.path_cost`, plus ``length_weight`` x length) is
lower.  The result never costs more than the input, and every state of it passes the problem's
validity and the optional ``check`` (e.g. puncture detection of the whole path, thesis 4.3.4).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

from pliant.components import PlanningProblem
from pliant.errors import DimensionError


def _segment_costs(problem: PlanningProblem, dense: np.ndarray, length_weight: float) -> np.ndarray:
    """``(k-1,)``: cost of each step of a dense path, ``(c(q_j) + length_weight) |q_j - q_{j-1}|``."""
    steps = np.asarray(problem.space.distance(dense[:-1], dense[1:]), dtype=np.float64)
    costs = problem.cost.cost(dense[1:]) if problem.cost is not None else np.zeros(len(steps))
    return (costs + length_weight) * steps


def shortcut(problem: PlanningProblem, configurations: np.ndarray, rng: np.random.Generator, *, step: float,
             iterations: int = 200, length_weight: float = 0.0,
             check: Callable[[np.ndarray], bool] | None = None,
             stop: Callable[[], bool] | None = None) -> tuple[np.ndarray, float]:
    """Shortcut a path ``(k, d)``; returns the dense improved path and its cost.

    ``step``: densification and checking distance (space metric units).  ``check(path) -> bool`` may
    veto a candidate whole path (it sees the full dense path, so path-dependent checks stay exact).
    ``stop() -> bool``, asked before every iteration, ends the shortcutting early with the path so far (a planner's
    time budget: :meth:`pliant.termination.Condition.expired`); every path it can return is valid.
    """
    if not step > 0:
        raise DimensionError("step must be positive", field="step", value=step)
    if iterations < 0:
        raise DimensionError("iterations must be >= 0", field="iterations", value=iterations)
    dense = problem.densify(configurations, step)
    segments = _segment_costs(problem, dense, length_weight)
    for _ in range(iterations):
        if len(dense) < 3 or (stop is not None and stop()):
            break
        i, j = np.sort(rng.choice(len(dense), size=2, replace=False))
        if j - i < 2:
            continue
        bridge = problem.space.discretize(dense[i], dense[j], step)
        if not problem.is_valid(bridge[1:-1]).all():
            continue
        bridge_segments = _segment_costs(problem, bridge, length_weight)
        # the motion (the expensive check) only for a bridge that is cheaper: the same path as checking it first
        if not np.sum(bridge_segments) < np.sum(segments[i:j]) - 1e-12 \
                or not problem.motion_is_valid(dense[i], dense[j]):
            continue
        candidate = np.vstack([dense[: i + 1], bridge[1:-1], dense[j:]])
        if check is not None and not check(candidate):
            continue
        dense = candidate
        segments = np.concatenate([segments[:i], bridge_segments, segments[j:]])
    return dense, float(np.sum(segments))


def perturb(problem: PlanningProblem, configurations: np.ndarray, rng: np.random.Generator, *, step: float,
            spacing: float, sigma: float, iterations: int = 200, proposals: int = 8, length_weight: float = 0.0,
            check: Callable[[np.ndarray], bool] | None = None,
            stop: Callable[[], bool] | None = None) -> tuple[np.ndarray, float]:
    """Random local perturbation of a path's waypoints; returns the dense improved path and its cost.

    Shortcutting only removes detours: it cannot move a path that passes a costly region off-centre to
    the middle of a cheaper one (the cube through a hole near its edge).  This does: the path is
    resampled to waypoints ``spacing`` apart (space metric units); then, ``iterations`` times, one
    interior waypoint gets ``proposals`` candidate positions, each moved from it by a Gaussian of
    ``sigma`` per tangent coordinate, and the cheapest candidate whose two adjacent motions are valid
    and cheaper than the current ones (cost integral at ``step`` plus ``length_weight`` x length)
    replaces it.  A stochastic hill climb (the idea of STOMP's noisy updates without its smoothing
    matrix); the endpoints stay fixed, the cost never rises, and ``check(dense path) -> bool`` may veto
    a candidate whole path (path-dependent checks such as puncture detection stay exact); ``stop`` as
    :func:`shortcut`'s.
    """
    for name, value in (("step", step), ("spacing", spacing), ("sigma", sigma)):
        if not value > 0:
            raise DimensionError(f"{name} must be positive", field=name, value=value)
    if iterations < 0 or proposals < 1:
        raise DimensionError("iterations must be >= 0 and proposals >= 1", field="iterations/proposals",
                             value=(iterations, proposals))
    space = problem.space
    dense = problem.densify(configurations, step)
    lengths = np.atleast_1d(space.distance(dense[:-1], dense[1:])) if len(dense) > 1 else np.zeros(0)
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    count = max(2, int(np.ceil(arc[-1] / spacing)) + 1)
    picks = np.unique(np.searchsorted(arc, np.linspace(0.0, arc[-1], count)).clip(0, len(dense) - 1))
    index = np.unique(np.concatenate([[0], picks, [len(dense) - 1]]))
    waypoints = dense[index].copy()

    def motion(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
        states = space.discretize(a, b, step)
        return states, float(np.sum(_segment_costs(problem, states, length_weight)))

    # the pieces start as the input's own stretches between waypoints (a straight motion between two
    # waypoints could cut a corner of the input into an infeasible state); only moved waypoints get new ones
    segments = _segment_costs(problem, dense, length_weight)
    pieces = [(dense[a:b + 1], float(np.sum(segments[a:b]))) for a, b in itertools.pairwise(index)]
    for _ in range(iterations):
        if len(waypoints) < 3 or (stop is not None and stop()):
            break
        i = int(rng.integers(1, len(waypoints) - 1))
        current = pieces[i - 1][1] + pieces[i][1]
        candidates = space.retract(np.repeat(waypoints[i][None], proposals, axis=0),
                                   rng.normal(0.0, sigma, (proposals, space.tangent_dim)))
        best, best_cost = None, current - 1e-12
        for q in candidates:
            if not space.is_valid(q[None])[0]:
                continue
            before, c0 = motion(waypoints[i - 1], q)
            if not c0 < best_cost:
                continue
            after, c1 = motion(q, waypoints[i + 1])
            if not c0 + c1 < best_cost:
                continue
            if not (problem.is_valid(before[1:]).all() and problem.is_valid(after[1:-1]).all()
                    and problem.motions_valid(np.array([waypoints[i - 1], q]), np.array([q, waypoints[i + 1]])).all()):
                continue
            best, best_cost = (q, (before, c0), (after, c1)), c0 + c1
        if best is None:
            continue
        q, left, right = best
        if check is not None:
            trial = pieces[: i - 1] + [left, right] + pieces[i + 1:]
            if not check(_join(trial)):
                continue
        waypoints[i] = q
        pieces[i - 1], pieces[i] = left, right
    return _join(pieces), float(sum(c for _, c in pieces))


def _join(pieces: list[tuple[np.ndarray, float]]) -> np.ndarray:
    """The dense path of consecutive motions (each starts where the previous one ends)."""
    return np.vstack([pieces[0][0]] + [states[1:] for states, _ in pieces[1:]])
