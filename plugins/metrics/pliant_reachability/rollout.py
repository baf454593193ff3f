"""Simulated executions of one motion until each robot reaches the target or sticks (thesis 6.5's baselines).

Every robot is driven toward the target one control step at a time through the simulator's batched
``simulate``; it *succeeds* when it comes within ``epsilon_reached`` (weighted) of the target, or, for the
sampling-driven method, when it is nearer the target than every stuck contact found; it *fails* when it carried out
less than ``stuck_fraction`` of the noise-free controller's command
(:meth:`~.volumes.ReachableVolumes.progress`) in ``stuck_steps`` successive steps (thesis 6.5: two), or when
``max_steps`` run out.  Motion carried out, not distance gained toward the target, is what counts: a robot
sliding sideways along a face toward an opening gains little distance per step yet is not stuck.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.interfaces import Simulator

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


def rollout(volumes: ReachableVolumes, starts: np.ndarray, simulator: Simulator, rng: np.random.Generator, *,
            stuck_fraction: float, stuck_steps: int, max_steps: int, past: float | None = None) -> Rollouts:
    """Simulate configurations ``starts`` ``(n, d)`` toward the motion's target (see the module docstring).

    ``past``: also succeed once the weighted distance to the target falls below it (sampling-driven: the robot
    is then past every stuck contact found).
    """
    law = volumes.law
    q = np.array(starts, dtype=np.float64)
    n = len(q)
    success = np.zeros(n, dtype=bool)
    active = np.ones(n, dtype=bool)
    stalled = np.zeros(n, dtype=np.int64)
    steps = 0
    for _ in range(max_steps):
        idx = np.nonzero(active)[0]
        if len(idx) == 0:
            break
        before = q[idx].copy()
        q[idx] = simulator.simulate(q[idx], volumes.target, rng, law.dt).final
        steps += len(idx)
        x = volumes.coordinates(q[idx])
        done = volumes.distance_to_target(x) <= volumes.epsilon
        if past is not None:
            done |= volumes.distance_to_target(x) < past
        stalled[idx] = np.where(volumes.progress(before, x) < stuck_fraction, stalled[idx] + 1, 0)
        success[idx[done]] = True
        active[idx[done]] = False
        active[idx[stalled[idx] >= stuck_steps]] = False
    return Rollouts(success, steps)
