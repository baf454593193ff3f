"""The reference for TS-RRT's figure of merit: the best arrangement of the same objects under the same task cost
with *free placement* (any collision-free poses on the table, no pushing), found by a long batched stochastic local
search, and random collision-free arrangements (the random initial states of the poster's demo).

The search keeps ``population`` arrangements; each round perturbs one random object of every member by a Gaussian
(``sigma`` m and ``sigma / r_o`` rad, shrinking geometrically from ``sigma_start`` to ``sigma_end``), and keeps the
perturbation when it is collision-free (:class:`~pliant_tsrrt.geometry.CollisionChecker`, the planner's margin
included) and cheaper.  Starts: random collision-free arrangements plus any given ones (e.g. the planner's result,
so the reference is never worse than an arrangement already known).  :func:`reference_optimum` and
:func:`random_arrangements` live in :mod:`pliant_tsrrt.refine`, whose improvement phase also uses them.
"""

from __future__ import annotations

import numpy as np

from pliant_tsrrt.refine import free_descent, patterns, random_arrangements, reference_optimum
from pliant_tsrrt.search import ObjectSpace


def optimise(space: ObjectSpace, rng: np.random.Generator, rounds: int = 4000, population: int = 64,
             starts: np.ndarray | None = None, sigma_start: float = 0.05, sigma_end: float = 5e-4) -> tuple[
                 np.ndarray, float]:
    """The cheapest collision-free arrangement found, and its cost: :func:`free_descent` from ``population``
    random collision-free arrangements (and ``starts``), with no extra margin."""
    pop = random_arrangements(space, rng, population)
    if starts is not None and len(starts):
        starts = np.asarray(starts, dtype=np.float64).reshape(-1, space.k, 3)
        starts = starts[~space.checker.in_collision(starts)]
        pop[: len(starts)] = starts[:population]
    pop, cost = free_descent(space, pop, rng, rounds=rounds, slack=0.0, sigma_start=sigma_start, sigma_end=sigma_end)
    best = int(np.argmin(cost))
    return pop[best], float(cost[best])


__all__ = ["optimise", "patterns", "random_arrangements", "reference_optimum"]
