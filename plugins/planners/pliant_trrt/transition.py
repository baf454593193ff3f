"""The transition test of T-RRT (Jaillet, Cortes, Simeon 2010, Algorithm 2), as thesis 3.2.4 uses it.

A new node cheaper than its parent is always accepted.  A costlier one is accepted with probability
``exp(-(slope) / (K T))`` where ``slope = (c_new - c_parent) / distance`` (cost per unit of the
space's metric) and ``T`` is the temperature: an acceptance cools it (``T / alpha``) and resets the
failure count; after ``n_fail_max`` consecutive refusals it heats up (``T * alpha``), so the tree
climbs cost barriers only when it has to.  ``max_cost`` bounds the acceptable state cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class TransitionTest:
    """Temperature state of T-RRT's transition test.

    temperature: current T (> 0).  k: the cost normalisation K (cost per unit distance).
    alpha: heating / cooling factor (> 1).  n_fail_max: refusals in a row before heating.
    max_cost: states costlier than this are always refused.
    cost_range_cooling: cool by ``alpha ** (rise / (0.1 * cost range))`` after an uphill acceptance (the
    T-RO 2010 version of T-RRT; the cost range is that of the states tested so far) instead of ``alpha``.
    """

    temperature: float
    k: float = 1.0
    alpha: float = 2.0
    n_fail_max: int = 10
    max_cost: float = math.inf
    cost_range_cooling: bool = False
    n_fail: int = 0
    lowest: float = math.inf
    highest: float = -math.inf
    accepted_uphill: int = 0
    refused: int = 0

    def probability(self, parent_cost: float, new_cost: float, distance: float) -> float:
        """Acceptance probability of a transition (1 downhill or flat, 0 above ``max_cost``)."""
        if not new_cost <= self.max_cost:
            return 0.0
        if new_cost <= parent_cost:
            return 1.0
        slope = (new_cost - parent_cost) / max(distance, 1e-12)
        return math.exp(-slope / (self.k * self.temperature))

    def __call__(self, parent_cost: float, new_cost: float, distance: float, rng: np.random.Generator) -> bool:
        """Accept or refuse, updating the temperature and the failure count as the rule says."""
        if not new_cost <= self.max_cost:
            return False                    # above the cost ceiling: refused without touching the temperature
        self.lowest = min(self.lowest, parent_cost, new_cost)
        self.highest = max(self.highest, parent_cost, new_cost)
        p = self.probability(parent_cost, new_cost, distance)
        if p >= 1.0:
            return True
        if p > 0.0 and rng.random() < p:
            rise = new_cost - parent_cost
            span = self.highest - self.lowest
            if self.cost_range_cooling and span > 0:
                # Jaillet et al. (2010, IEEE T-RO): cool more after a bigger climb, relative to the cost range seen
                self.temperature /= self.alpha ** (rise / (0.1 * span))
            else:
                self.temperature /= self.alpha
            self.n_fail = 0
            self.accepted_uphill += 1
            return True
        self.refused += 1
        if self.n_fail >= self.n_fail_max:
            self.temperature *= self.alpha
            self.n_fail = 0
        else:
            self.n_fail += 1
        return False
