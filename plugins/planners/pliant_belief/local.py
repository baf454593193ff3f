"""The local planner of thesis 5.3.2: EXTEND forward-simulates a belief toward a target and clusters the outcomes.

From node ``n_near`` toward ``q_target``: take ``N_particles`` particles (a copy of ``b_near`` when it
is a full set, else a uniform resample, so split nodes do not starve), forward-simulate them with the
pipeline's simulator (the kinematic simulator of app. B in the thesis), cluster the results
(:mod:`pliant.planning.clustering`, 5.3.3) into one node per cluster with
``P(n_near -> n_new) = |b_new| / N_particles``, estimate each new node's reversibility by simulating
``N_particles`` particles back toward ``n_near``, and the effective probability of reaching it within
``N_attempt`` tries (:func:`pliant_belief.belief.effective_probability`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields

import numpy as np
from pliant.api import PlanningProblem, angular_mask

from pliant_belief.belief import BeliefNode, BeliefTree, effective_probability


@dataclass(frozen=True)
class LocalPlannerSettings:
    """What EXTEND needs (units in each field's name or doc).

    particles: N_particles.  attempts: N_attempt.  speed / angular_speed: the actuators' speed limits
    (m/s or rad/s per translational / rotational tangent coordinate; joints count as translational); an
    action lasts as long as its slowest coordinate needs at those speeds, plus ``settle`` seconds.
    min_progress: an extension whose outcome moved less than this (space metric) adds nothing.
    reversibility: whether to simulate back to estimate reverse probabilities (Contact RRT skips it).
    """

    particles: int
    attempts: int
    speed: float
    angular_speed: float
    settle: float
    min_progress: float
    reversibility: bool = True

    @classmethod
    def from_options(cls, options, *, particles: int, min_progress: float, reversibility: bool) -> LocalPlannerSettings:
        """The settings of the planner's ``options``, every other field by its name, with the values the mode and the
        scene decide (``particles``, ``min_progress``, ``reversibility``)."""
        derived = {"particles": particles, "min_progress": min_progress, "reversibility": reversibility}
        return cls(**derived, **{f.name: getattr(options, f.name) for f in fields(cls) if f.name not in derived})


def action_duration(problem: PlanningProblem, start: np.ndarray, target: np.ndarray,
                    settings: LocalPlannerSettings) -> float:
    """Seconds to simulate an action from ``start`` toward ``target``."""
    delta = np.abs(problem.space.difference(target, start))
    limits = np.where(angular_mask(problem.space), settings.angular_speed, settings.speed)
    return float(np.max(delta / limits)) + settings.settle


def initial_particles(node: BeliefNode, n: int, rng: np.random.Generator) -> np.ndarray:
    """``(n, d)`` particles to simulate from ``node``: its belief when it is a full set, else a uniform resample."""
    if len(node.particles) == n:
        return node.particles.copy()
    return node.particles[rng.integers(0, len(node.particles), size=n)]


def goal_fraction(problem: PlanningProblem, particles: np.ndarray) -> float:
    """Fraction of ``particles`` inside the goal (tolerance or region)."""
    return float(np.mean(problem.in_goal(particles)))


def extend(tree: BeliefTree, near: int, target: np.ndarray, problem: PlanningProblem,
           cluster: Callable[[np.ndarray], np.ndarray], settings: LocalPlannerSettings,
           rng: np.random.Generator, counters: dict) -> list[int]:
    """EXTEND: simulate ``tree.nodes[near]``'s belief toward ``target``; add and return the new nodes' indices.

    ``cluster(particles (n, d)) -> labels (n,)`` is the clustering of 5.3.3.  ``counters`` accumulates
    ``particles_simulated``.  Returns ``[]`` when the outcome did not move (nothing learned).
    """
    simulator = problem.simulator
    node = tree.nodes[near]
    starts = initial_particles(node, settings.particles, rng)
    duration = action_duration(problem, node.expected, target, settings)
    outcome = simulator.simulate(starts, target, rng, duration)
    counters["particles_simulated"] += len(starts)
    final = outcome.final
    labels = cluster(final)
    clusters = [final[labels == k] for k in range(int(labels.max()) + 1)]
    clusters = [c for c in clusters if len(c)]
    space = problem.space
    moved = [float(space.distance(space.mean(c), node.expected)) >= settings.min_progress for c in clusters]
    if not any(moved):
        return []
    action_id = tree.new_action_id()
    probabilities = [len(c) / len(final) for c in clusters]
    reverse = [1.0] * len(clusters)
    if settings.reversibility:
        reverse = [_reverse_probability(node, c, problem, cluster, settings, rng, counters) for c in clusters]
    split = len(clusters) > 1
    added = []
    for k, (particles, p) in enumerate(zip(clusters, probabilities)):
        others = [(probabilities[j], reverse[j]) for j in range(len(clusters)) if j != k]
        miss = sum(pj for pj, _ in others)
        back = sum(pj * rj for pj, rj in others) / miss if miss > 0 else 1.0
        effective = min(1.0, effective_probability(p, back, settings.attempts))
        new = BeliefNode(particles=particles, action=np.asarray(target, dtype=np.float64).copy(), parent=near,
                         action_id=action_id, probability=p, reverse_probability=reverse[k],
                         effective_probability=effective, path_probability=node.path_probability * effective,
                         goal_fraction=goal_fraction(problem, particles), split=split)
        added.append(tree.add(new))
    return added


def _reverse_probability(node: BeliefNode, particles: np.ndarray, problem: PlanningProblem,
                         cluster: Callable[[np.ndarray], np.ndarray], settings: LocalPlannerSettings,
                         rng: np.random.Generator, counters: dict) -> float:
    """Fraction of ``N_particles`` particles from ``particles`` that, driven back toward ``node``'s expected
    configuration, end in the same cluster as ``node``'s belief (thesis 5.3.2)."""
    starts = particles[rng.integers(0, len(particles), size=settings.particles)]
    back_target = node.expected
    duration = action_duration(problem, problem.space.mean(particles), back_target, settings)
    back = problem.simulator.simulate(starts, back_target, rng, duration).final
    counters["particles_simulated"] += len(starts)
    labels = cluster(np.vstack([node.particles, back]))
    home = np.bincount(labels[: len(node.particles)]).argmax()
    return float(np.mean(labels[len(node.particles):] == home))
