"""The reference for TS-RRT's figure of merit: the best arrangement of the same objects under the same task cost
with *free placement* (any collision-free poses on the table, no pushing), found by a long batched stochastic local
search, and random collision-free arrangements (the random initial states of the poster's demo).

The search keeps ``population`` arrangements; each round perturbs one random object of every member by a Gaussian
(``sigma`` m and ``sigma / r_o`` rad, shrinking geometrically from ``sigma_start`` to ``sigma_end``), and keeps the
perturbation when it is collision-free (:class:`~pliant_tsrrt.geometry.CollisionChecker`, the planner's margin
included) and cheaper.  Starts: random collision-free arrangements plus any given ones (e.g. the planner's result,
so the reference is never worse than an arrangement already known).
"""

from __future__ import annotations

import numpy as np
from pliant.api import PlanningError

from pliant_tsrrt.refine import free_descent, patterns
from pliant_tsrrt.search import ObjectSpace


def random_arrangements(space: ObjectSpace, rng: np.random.Generator, count: int, tries: int = 2000,
                        clearance: float = 0.0) -> np.ndarray:
    """``count`` collision-free arrangements ``(count, k, 3)``, each object uniform on the table with any yaw, every
    footprint at least ``clearance`` (m) from the others, the obstacles and the table's edge (besides the margin)."""
    from dataclasses import replace

    checker = replace(space.checker, margin=space.checker.margin + 0.5 * clearance)
    out = []
    for _ in range(tries):
        batch = np.stack([space.random_config(rng) for _ in range(256)])
        out.extend(batch[~checker.in_collision(batch)])
        if len(out) >= count:
            return np.array(out[:count])
    raise PlanningError("could not place the objects without collision on the table", field="objects",
                        value=space.k)


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


def reference_optimum(space: ObjectSpace, rng: np.random.Generator, rounds: int = 4000, population: int = 64,
                      starts: np.ndarray | None = None, pattern_count: int = 512,
                      restarts: int = 2) -> tuple[np.ndarray, float]:
    """The reference optimum of the task cost over collision-free free placements (the figure of merit's
    denominator): the cheapest of several multi-start descents.  Starts: random collision-free arrangements (each
    box's yaw either uniform or snapped to a multiple of 90 degrees: multi-start over orientations), the
    ``population`` cheapest of ``pattern_count`` packed :func:`patterns` (rows, columns, shelves), and ``starts``
    (e.g. the planner's result).  Each of ``restarts`` rounds descends (:func:`free_descent`, ``rounds`` rounds) from
    a wide step and then polishes the best members with a narrow one.  A work budget (rounds, members), so the same
    answer under a seed on any machine."""
    k = space.k
    rand = random_arrangements(space, rng, population)
    snapped = rand.copy()
    box = space.scale > 0
    half = rng.random(population) < 0.5
    snapped[np.ix_(half, box, [2])] = (np.pi / 2) * rng.integers(0, 4, (int(half.sum()), int(box.sum()), 1))
    snapped = snapped[~space.checker.in_collision(snapped)]
    pats = patterns(space, rng, pattern_count)
    if len(pats):
        pats = pats[np.argsort(space.cost.cost(pats))[:population]]
    pools = [rand, snapped, pats]
    if starts is not None and len(starts):
        s = np.asarray(starts, dtype=np.float64).reshape(-1, k, 3)
        pools.append(s[~space.checker.in_collision(s)])
    pop = np.concatenate([p for p in pools if len(p)])
    best, best_cost = None, np.inf
    for _ in range(restarts):
        desc, cost = free_descent(space, pop, rng, rounds=rounds, slack=0.0, sigma_start=0.05, sigma_end=5e-4)
        top = desc[np.argsort(cost)[: max(8, population // 4)]]
        fine, fcost = free_descent(space, np.repeat(top, 2, axis=0), rng, rounds=rounds, slack=0.0,
                                   sigma_start=0.005, sigma_end=1e-5)
        i = int(np.argmin(fcost))
        if fcost[i] < best_cost:
            best, best_cost = fine[i].copy(), float(fcost[i])
        pop = np.concatenate([fine[np.argsort(fcost)[: len(pop) // 2]], pop[: len(pop) - len(pop) // 2]])
    return best, best_cost


__all__ = ["optimise", "patterns", "random_arrangements", "reference_optimum"]
