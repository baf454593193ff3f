"""Pareto sweeps of the A* objective over p (thesis 3.3.1: 101 values of p from 0 to 1)."""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass, field

import numpy as np
from pliant.api import BudgetExpired, Termination

from pliant_astar.search import path_deformation, path_length, search


@dataclass
class SweepRun:
    """One A* run of a sweep: its p, the path's cells ``(k, 3)``, length (voxels) and deformation."""

    p: float
    cells: np.ndarray | None
    length: float
    deformation: float
    expanded: int


@dataclass
class ParetoPoint:
    """A distinct Pareto-optimal path and every p that produced it."""

    cells: np.ndarray
    length: float
    deformation: float
    p_values: list[float] = field(default_factory=list)


def sweep(costs: np.ndarray, start, goal, p_values, termination: Termination | None = None,
          progress=None) -> list[SweepRun]:
    """Run A* for each p (the cost field is computed once by the caller); stops early on termination, also inside a
    search (whose p is then left out)."""
    runs = []
    for i, p in enumerate(p_values):
        if termination is not None and termination.should_stop(i):
            break
        try:
            with termination.interruptible() if termination is not None else nullcontext():
                cells, expanded, _ = search(costs, start, goal, float(p))
        except BudgetExpired:
            break
        if cells is None:
            runs.append(SweepRun(float(p), None, np.inf, np.inf, expanded))
        else:
            runs.append(SweepRun(float(p), cells, path_length(cells), path_deformation(costs, cells), expanded))
        if progress is not None:
            progress(i + 1, len(p_values))
    return runs


def pareto_front(runs: list[SweepRun], tol: float = 1e-9) -> list[ParetoPoint]:
    """The distinct non-dominated paths in (length, deformation), ordered by length.

    Paths with equal length and deformation (within ``tol``) are one point; a point is dominated
    when another is no worse in both and better in one.
    """
    points: list[ParetoPoint] = []
    for run in runs:
        if run.cells is None:
            continue
        for pt in points:
            if abs(pt.length - run.length) <= tol and abs(pt.deformation - run.deformation) <= tol:
                pt.p_values.append(run.p)
                break
        else:
            points.append(ParetoPoint(run.cells, run.length, run.deformation, [run.p]))
    front = [a for a in points
             if not any((b.length <= a.length + tol and b.deformation <= a.deformation + tol)
                        and (b.length < a.length - tol or b.deformation < a.deformation - tol) for b in points)]
    return sorted(front, key=lambda pt: (pt.length, pt.deformation))
