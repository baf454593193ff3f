"""Simulated executions of one motion until each robot reaches the target or sticks (thesis 6.5's baselines).

Every robot is driven toward the target one control step at a time through the simulator's batched
``simulate``; it *succeeds* when it comes within ``epsilon_reached`` (weighted) of the target, or, for the
sampling-driven method, when it is nearer the target than every stuck contact found; it *fails* when the
weighted length of its motion over the last ``stuck_steps`` control steps is below ``stuck_distance`` -- the
contact motion controller's stuck test (thesis app. C, whose executions the metric predicts) -- or when
``max_steps`` run out.
Motion, not distance gained toward the target, is what counts: a robot sliding sideways along a face toward an
opening gains little distance per step yet is not stuck.  (Thesis 6.5 stops a simulation after two successive
steps without progress and notes that this can disagree with the controller; measured here, it called robots
stuck that then slid into the hole.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import Simulator

from pliant_reachability.volumes import ReachableVolumes


@dataclass(frozen=True)
class Rollouts:
    """Outcome of simulated executions: success ``(n,)`` bool and the control steps simulated (all robots)."""

    success: np.ndarray
    steps: int

    @property
    def probability(self) -> float:
        """Fraction of successful executions (NaN for none)."""
        return float(np.mean(self.success)) if len(self.success) else float("nan")


class StuckWindow:
    """The contact controller's stuck test (thesis app. C) for many robots: stuck once the weighted length of the
    last ``steps`` control steps' motions is below ``distance``."""

    def __init__(self, n: int, steps: int, distance: float) -> None:
        self.lengths = np.full((n, steps), np.inf)
        self.count = np.zeros(n, dtype=np.int64)
        self.distance = distance

    def add(self, idx: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """Record one step's motion lengths ``(k,)`` of robots ``idx``; bool ``(k,)``: which are now stuck."""
        steps = self.lengths.shape[1]
        self.lengths[idx, self.count[idx] % steps] = lengths
        self.count[idx] += 1
        return np.sum(self.lengths[idx], axis=1) < self.distance


def rollout(volumes: ReachableVolumes, starts: np.ndarray, simulator: Simulator, rng: np.random.Generator, *,
            stuck_distance: float, stuck_steps: int, max_steps: int, past: float | None = None) -> Rollouts:
    """Simulate configurations ``starts`` ``(n, d)`` toward the motion's target (see the module docstring).

    ``past``: also succeed once the weighted distance to the target falls below it (sampling-driven: the robot
    is then past every stuck contact found).
    """
    law = volumes.law
    q = np.array(starts, dtype=np.float64)
    n = len(q)
    success = np.zeros(n, dtype=bool)
    active = np.ones(n, dtype=bool)
    window = StuckWindow(n, stuck_steps, stuck_distance)
    steps = 0
    for _ in range(max_steps):
        idx = np.nonzero(active)[0]
        if len(idx) == 0:
            break
        before = volumes.coordinates(q[idx])
        q[idx] = simulator.simulate(q[idx], volumes.target, rng, law.dt).final
        steps += len(idx)
        x = volumes.coordinates(q[idx])
        done = volumes.distance_to_target(x) <= volumes.epsilon
        if past is not None:
            done |= volumes.distance_to_target(x) < past
        stuck = window.add(idx, np.linalg.norm((x - before) * volumes.weights, axis=1)) & ~done
        success[idx[done]] = True
        active[idx[done | stuck]] = False
    return Rollouts(success, steps)
