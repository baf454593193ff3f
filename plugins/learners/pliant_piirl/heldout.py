"""Held-out checks of the recovery (docs/experiments.md, "Development and held-out sets").

- :class:`NearOptimalDemonstrator`: a demonstrator other than the simulated expert, for held-out sets.  For a task
  it measures every straight insertion of the expert's search (the lattice of tilts and its refinements around the
  optimum, under the hidden sensitivities) and shows one drawn uniformly from the valid ones whose true cost is
  within ``slack`` (2%) of the cheapest.  It keeps what it measured (``candidates``), so that the ratios its
  demonstrations allow can be computed.
- :func:`allowed_ratio_interval`: the interval of ``S_a / S_b`` under which every shown path stays within its
  demonstrator's slack of the cheapest path that was on offer, ``S . V_k <= (1 + slack_k) S . C_kj`` for every
  candidate ``j`` of demonstration ``k``.  The constraints are linear in ``S``, so the set of allowed ``S`` is a
  polyhedral cone and each end of the interval is one linear programme (``S_b = 1``, minimise or maximise
  ``S_a``).  ``groups`` ties objects to classes (a class shares one value), as the hidden truth does.
- :func:`class_ratios`, :func:`in_order`: what a recovery is scored by.
- :func:`object_order_intervals`, :func:`order_determined`: whether the demonstrations themselves fix the order of
  every object below every object of the next class, when each object has a value of its own (a learner is not told
  which objects share a class).  Where they do not, a recovery in the wrong order can still keep every shown path
  within its slack, so no learner can be held to that order on that set.
"""

from __future__ import annotations

import itertools

import numpy as np
from pliant.api import PlanningError

from pliant_piirl.demonstration import Demonstration, DemonstrationTask
from pliant_piirl.expert import ExpertOptions, SimulatedExpert, funnel_frame, tilt_axes

#: the near-optimal demonstrator's slack: it shows a path within 2% of the cheapest true cost
SLACK = 0.02
#: how far beyond the allowed interval a recovered ratio may lie and still pass (a factor at each end)
WIDENING = 1.25


class NearOptimalDemonstrator(SimulatedExpert):
    """Shows a straight insertion drawn uniformly from those within ``slack`` of the cheapest true cost.

    The candidates are the expert's own search (``options``: lattice ``grid``, ``refine`` refinements around the
    optimum; its ``noise`` is not used).  After :meth:`demonstrate`, :attr:`candidates` holds the features
    ``(m, n_objects)`` of every valid straight insertion measured for that task, and :attr:`shown` the shown one's.
    """

    def __init__(self, features, sensitivities: dict[str, float], tip, options: ExpertOptions | None = None,
                 slack: float = SLACK) -> None:
        super().__init__(features, sensitivities, tip, options)
        self.slack = float(slack)
        self.candidates = np.zeros((0, len(features.names)))
        self.shown = np.zeros(len(features.names))

    def demonstrate(self, task: DemonstrationTask, rng: np.random.Generator) -> Demonstration:
        o = self.options
        frame = funnel_frame(task)
        alphas, betas = tilt_axes(o.grid, o)
        tilts, feats = self._measure(task, frame, np.array([(a, b) for a in alphas for b in betas]))
        for _ in range(o.refine):
            best = tilts[np.argmin(feats @ self.weights)]
            da = (alphas[1] - alphas[0]) if len(alphas) > 1 else 0.0
            db = (betas[1] - betas[0]) if len(betas) > 1 else 0.0
            alphas = np.clip(best[0] + np.linspace(-da, da, 7), -o.across_angle, o.across_angle)
            betas = np.clip(best[1] + np.linspace(-db, db, 5), -o.along_angle, o.along_angle)
            more_tilts, more = self._measure(task, frame, np.array([(a, b) for a in alphas for b in betas]))
            tilts, feats = np.concatenate([tilts, more_tilts]), np.concatenate([feats, more])
        cost = feats @ self.weights
        near = np.flatnonzero(cost <= (1.0 + self.slack) * cost.min())
        pick = int(rng.choice(near))
        self.candidates, self.shown = feats, feats[pick]
        return Demonstration(task, self.path(task, tilts[pick], frame), "near-optimal")

    def _measure(self, task, frame, tilts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        paths = [self.path(task, t, frame) for t in tilts]
        feats = self.features.of_paths(paths)
        ok = self.valid(task, paths) & np.all(np.isfinite(feats), axis=1)
        if not ok.any():
            raise PlanningError("the demonstrator found no valid straight insertion inside the funnel",
                                field="task.target", value=task.target.tolist())
        return tilts[ok], feats[ok]


def allowed_ratio_interval(shown, candidates, slack, groups: np.ndarray, a: int, b: int,
                           bounds: tuple[float, float] = (1e-4, 1e4)) -> tuple[float, float]:
    """``(lowest, highest)`` ratio ``s_a / s_b`` of class values ``s`` under which every shown path stays within
    its slack of every candidate: ``V_k . G s <= (1 + slack_k) C_kj . G s``.

    ``shown`` ``(K, n)``: the shown paths' features; ``candidates[k]`` ``(m_k, n)``: what demonstration ``k``'s
    demonstrator could have shown; ``slack``: a number or one per demonstration; ``groups`` ``(n, g)``: 1 where
    object ``i`` belongs to class ``c``; ``bounds``: each class value's range with ``s_b = 1`` (ends at a bound
    mean the demonstrations do not bound the ratio that way).  Raises ``ValueError`` when no ratio is allowed."""
    from scipy.optimize import linprog

    shown = np.asarray(shown, dtype=np.float64)
    groups = np.asarray(groups, dtype=np.float64)
    slack = np.broadcast_to(np.asarray(slack, dtype=np.float64), (len(shown),))
    rows = [(shown[k] - (1.0 + slack[k]) * np.asarray(c, dtype=np.float64)) @ groups
            for k, c in enumerate(candidates) if len(c)]
    a_ub = np.concatenate(rows) if rows else np.zeros((0, groups.shape[1]))
    a_ub = a_ub[np.any(np.abs(a_ub) > 1e-12, axis=1)]
    limits = [(1.0, 1.0) if c == b else bounds for c in range(groups.shape[1])]
    ends = []
    for sign in (1.0, -1.0):
        objective = np.zeros(groups.shape[1])
        objective[a] = sign
        # each row scaled to unit length: the features are counts of hundreds to thousands
        scale = np.maximum(np.linalg.norm(a_ub, axis=1), 1e-300)[:, None] if len(a_ub) else 1.0
        result = linprog(objective, A_ub=a_ub / scale if len(a_ub) else None,
                         b_ub=np.zeros(len(a_ub)) if len(a_ub) else None, bounds=limits, method="highs")
        if result.status != 0:
            raise ValueError(f"no ratio of class {a} to class {b} keeps every shown path within its slack "
                             f"({result.message})")
        ends.append(float(result.x[a]))
    return ends[0], ends[1]


def groups_of(names: list[str], classes: dict[str, str], order: list[str]) -> np.ndarray:
    """``(n, g)`` indicator of which class (in ``order``) each object of ``names`` belongs to."""
    return np.array([[1.0 if classes[n] == c else 0.0 for c in order] for n in names])


def class_ratios(sensitivities: dict[str, float], classes: dict[str, str], order: list[str]) -> dict[str, float]:
    """``{"M/L": ..., "H/L": ..., "H/M": ...}``: each class's geometric mean over its objects, divided pairwise
    (``order`` least sensitive first; keys are ``later/earlier``)."""
    mean = {c: float(np.exp(np.mean([np.log(sensitivities[n]) for n in classes if classes[n] == c])))
            for c in order}
    return {f"{order[j]}/{order[i]}": mean[order[j]] / mean[order[i]]
            for i in range(len(order)) for j in range(i + 1, len(order))}


def in_order(sensitivities: dict[str, float], classes: dict[str, str], order: list[str]) -> bool:
    """Every object of each class below every object of the next (``order`` least sensitive first)."""
    for low, high in itertools.pairwise(order):
        if max(sensitivities[n] for n in classes if classes[n] == low) >= \
                min(sensitivities[n] for n in classes if classes[n] == high):
            return False
    return True


def object_order_intervals(shown, candidates, slack, names: list[str], classes: dict[str, str],
                           order: list[str]) -> dict[str, tuple[float, float]]:
    """For every object of each class and every object of the next (``order`` least sensitive first), the interval
    of ``S_high / S_low`` (keys ``"high/low"`` by object name) under which every shown path stays within its slack of
    every candidate, each object free to take its own value: :func:`allowed_ratio_interval` with one group per
    object.  ``names``: the objects in the features' column order."""
    each = np.eye(len(names))
    intervals = {}
    for low, high in itertools.pairwise(order):
        for a in (n for n in names if classes[n] == low):
            for b in (n for n in names if classes[n] == high):
                intervals[f"{b}/{a}"] = allowed_ratio_interval(shown, candidates, slack, each, names.index(b),
                                                               names.index(a))
    return intervals


def order_determined(intervals: dict[str, tuple[float, float]]) -> bool:
    """Whether every sensitivity vector the demonstrations allow puts each object below every object of the next
    class: the lowest allowed ratio of every pair of :func:`object_order_intervals` above 1."""
    return all(lowest > 1.0 for lowest, _ in intervals.values())
