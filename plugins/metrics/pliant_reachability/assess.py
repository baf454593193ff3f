"""One waypoint-to-waypoint motion assessed by reachable-volume sampling (thesis 6.4.2-6.4.4).

:func:`sample_motion` draws uniform samples in every reachable volume (``density`` per unit of weighted
measure, 6.4.2; :func:`sample_counts`), sorts them into colliding / near contact / free with
:class:`~.clearance.Clearance`, projects the near-contact ones to contact and labels them (:mod:`.contact`).
Two estimates follow:

- :func:`image_probability`, the primary variant (6.4.4): for every free sample ``q`` of ``RV_j``, the image of
  one control step -- the box swept from ``q`` to its noise-free successor, widened by the largest actuation
  error (no less than half the expected spacing of samples, ``density^(-1/t)``) -- is searched for contacts
  of ``RV_j`` and ``RV_(j+1)`` (the step sweeps through both; with ``RV_(j+1)``'s alone, as the thesis writes, a
  robot stopped at a wall is outside the obstacle-free ``RV_(j+1)`` and its contact is never found); if any of
  them is stuck (or becomes stuck), ``image_samples`` noisy futures are drawn
  around the successor (truncated normal, sigma half the bound, as eq. 6.15).  A future that collides means
  the motion ``q -> q_future`` meets the contact manifold; where it first does is found by bisection on the
  segment, and the future counts as stuck when the relevant contact nearest that point is (eq. 6.10).  (The
  thesis takes the contact nearest the future itself; a future a whole step inside an obstacle is far from
  where the robot stops.)  ``P_stuck(RV_j -> RV_(j+1))`` is the *mean* over the free samples
  of ``RV_j`` (eq. 6.11 writes a sum, which exceeds 1 as soon as samples are many; with uniform samples the
  mean is the probability it means), ``P_exec`` of the motion their complement's product (eq. 6.12).
- :func:`sampling_driven_probability`, the simplified variant: the stuck contacts set how far to simulate; the
  free samples of ``RV_0`` are simulated until they are past them (:mod:`.rollout`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from pliant.api import ClusteringContext, RobotModel, Simulator, ac_connected, truncated_normal

from pliant_reachability.clearance import Clearance
from pliant_reachability.contact import Contacts, classify, project_to_contact
from pliant_reachability.rollout import Rollouts, rollout
from pliant_reachability.volumes import ReachableVolumes


@dataclass(frozen=True)
class SamplingSettings:
    """How densely and how the volumes are sampled (see the metric options for units and defaults)."""

    density: float
    max_samples: int
    near_distance: float
    projection_iterations: int
    stuck_distance: float
    theta: float
    axis: float
    image_samples: int
    stuck_steps: int
    contact_horizon: int

    @classmethod
    def from_options(cls, options, *, density: float, axis: float) -> SamplingSettings:
        """The settings of the metric's ``options``, every field by its name, with this pair's ``density`` and
        ``axis`` (derived from the options and the volumes)."""
        derived = {"density": density, "axis": axis}
        return cls(**derived, **{f.name: getattr(options, f.name) for f in fields(cls) if f.name not in derived})


@dataclass
class SampledMotion:
    """Samples of every reachable volume of one motion, and its labelled contacts.

    x: per volume, ``(n_i, t)`` sample coordinates; colliding: per volume, bool ``(n_i,)``.
    contacts: the projected, labelled contacts; simulated: control steps simulated to label them.
    """

    volumes: ReachableVolumes
    x: list[np.ndarray]
    colliding: list[np.ndarray]
    contacts: Contacts

    @property
    def sample_count(self) -> int:
        return int(sum(len(x) for x in self.x))


def sample_counts(volumes: ReachableVolumes, density: float, max_samples: int) -> np.ndarray:
    """Samples per volume: ``density`` times the weighted measure, each side counted as at least the expected
    spacing ``density^(-1/t)``, within ``[1, max_samples]``.

    The floor matters where the controller squeezes one dimension below the spacing (a rotation converging
    to its target) while the others stay wide: the plain measure would then give such a volume one sample.
    """
    spacing = density ** (-1.0 / len(volumes.weights))
    sides = np.maximum((volumes.upper - volumes.lower) * volumes.weights, spacing)
    return np.clip(np.round(density * np.prod(sides, axis=1)), 1, max_samples).astype(np.int64)


def reachable_from(x: np.ndarray, previous: np.ndarray, volumes: ReachableVolumes, context: ClusteringContext
                   ) -> np.ndarray:
    """Bool ``(n,)``: the samples ``x`` whose nearest sample of the previous volume (weighted) is AC-connected to them
    (thesis 6.6.2 with the clustering of 5.3.3, :func:`pliant.planning.clustering.ac_connected`)."""
    if len(previous) == 0 or len(x) == 0:
        return np.zeros(len(x), dtype=bool)
    nearest = np.empty(len(x), dtype=np.int64)
    for s in range(0, len(x), 1024):
        d = np.linalg.norm((x[s:s + 1024, None, :] - previous[None, :, :]) * volumes.weights, axis=2)
        nearest[s:s + 1024] = np.argmin(d, axis=1)
    return ac_connected(volumes.configurations(x), volumes.configurations(previous[nearest]), context)


def sample_motion(volumes: ReachableVolumes, settings: SamplingSettings, robot: RobotModel, clearance: Clearance,
                  simulator: Simulator, rng: np.random.Generator,
                  reachability: ClusteringContext | None = None) -> SampledMotion:
    """Sample, sort and label (thesis 6.4.2-6.4.3); see the module docstring.  With ``reachability``, samples not
    reachable from the previous volume's (:func:`reachable_from`) are set aside with the colliding ones."""
    counts = sample_counts(volumes, settings.density, settings.max_samples)
    xs, colliding, contact_x, contact_volume = [], [], [], []
    near_limit = settings.near_distance * clearance.grid.resolution
    for i, n in enumerate(counts):
        x = volumes.sample(i, rng, int(n))
        q = volumes.configurations(x)
        dist, _, col = clearance.query(q)
        if reachability is not None and i > 0:
            col = col | ~reachable_from(x, xs[-1][~colliding[-1]], volumes, reachability)
        xs.append(x)
        colliding.append(col)
        near = np.nonzero(~col & (dist <= near_limit))[0]
        if len(near) == 0:
            continue
        projected, ok = project_to_contact(q[near], robot, clearance, settings.projection_iterations)
        px = volumes.coordinates(projected[ok])
        inside = volumes.contains(i, px) | (i == 0)
        contact_x.append(px[inside])
        contact_volume.append(np.full(int(inside.sum()), i))
    t = len(volumes.weights)
    cx = np.concatenate(contact_x) if contact_x else np.zeros((0, t))
    cv = np.concatenate(contact_volume) if contact_volume else np.zeros(0, dtype=np.int64)
    contacts = classify(volumes, cx, cv, simulator, rng, settings.stuck_distance, settings.stuck_steps,
                        settings.contact_horizon, settings.theta, settings.axis)
    return SampledMotion(volumes, xs, colliding, contacts)


def image_probability(sampled: SampledMotion, settings: SamplingSettings, clearance: Clearance,
                      rng: np.random.Generator, bisections: int = 5) -> tuple[float, np.ndarray]:
    """``P_exec`` of the motion by the image estimate (eq. 6.10-6.12) and ``P_stuck`` per volume pair."""
    volumes, contacts = sampled.volumes, sampled.contacts
    law, w = volumes.law, volumes.weights
    spacing = settings.density ** (-1.0 / len(w)) / w                # expected sample spacing per coordinate
    p_stuck = np.zeros(max(len(volumes) - 1, 0))
    stuckish = contacts.stuckish
    for j in range(len(volumes) - 1):
        here = (contacts.volume == j) | (contacts.volume == j + 1)
        if not np.any(here & stuckish):
            continue
        cx, cs = contacts.x[here], stuckish[here]
        x = sampled.x[j][~sampled.colliding[j]]
        if len(x) == 0:
            continue
        q = volumes.configurations(x)
        velocity = law.velocity(q, volumes.target)
        x_next = volumes.coordinates(law.step(q, volumes.target))
        half = np.maximum(law.noise_bounds(velocity), 0.5 * spacing)
        # the image of one step: the box swept from q to its noise-free successor, widened by the noise bound
        low, high = np.minimum(x, x_next) - half, np.maximum(x, x_next) + half
        inside = np.all((cx[None, :, :] >= low[:, None, :]) & (cx[None, :, :] <= high[:, None, :]), axis=2)
        candidates = np.nonzero(np.any(inside & cs[None, :], axis=1))[0]
        if len(candidates) == 0:
            continue
        k = settings.image_samples
        t = len(w)
        future = x_next[candidates, None, :] + truncated_normal(rng, np.repeat(half[candidates, None, :], k, axis=1))
        hits = clearance.colliding(volumes.configurations(future.reshape(-1, t))).reshape(len(candidates), k)
        rows, draws = np.nonzero(hits)
        if len(rows) == 0:
            continue
        # where the motion q -> q_future first meets the contact manifold (bisection on the segment)
        free_end = np.repeat(x[candidates], k, axis=0).reshape(len(candidates), k, t)[rows, draws]
        hit_end = future[rows, draws]
        for _ in range(bisections):
            middle = 0.5 * (free_end + hit_end)
            collides = clearance.colliding(volumes.configurations(middle))
            hit_end = np.where(collides[:, None], middle, hit_end)
            free_end = np.where(collides[:, None], free_end, middle)
        stuck_count = np.zeros(len(candidates))
        for row in np.unique(rows):
            relevant = np.nonzero(inside[candidates[row]])[0]
            meets = free_end[rows == row]
            d = np.linalg.norm((meets[:, None, :] - cx[None, relevant, :]) * w, axis=2)
            stuck_count[row] = np.count_nonzero(cs[relevant[np.argmin(d, axis=1)]])
        p_stuck[j] = float(np.sum(stuck_count / k)) / len(x)
    return float(np.prod(1.0 - p_stuck)), p_stuck


def sampling_driven_probability(sampled: SampledMotion, settings: SamplingSettings, simulator: Simulator,
                                rng: np.random.Generator, max_steps: int) -> tuple[float, Rollouts | None]:
    """``P_exec`` by the sampling-driven method: 1 when no contact is stuck, else the fraction of ``RV_0``'s free
    samples that, simulated, get nearer the target than every place a contact's simulation stuck, by the expected
    sample spacing (or reach it), without sticking.

    The thesis simulates until the robots "reach ``RV_(s+1)``", the volume after the last one holding a stuck
    sample; but the obstacle-free volumes are boxes that also hold the stuck robots, so "past the stuck
    contacts" is tested by distance to the target instead."""
    contacts = sampled.contacts
    if not contacts.stuckish.any():
        return 1.0, None
    volumes = sampled.volumes
    ends = contacts.stuck_at[np.all(np.isfinite(contacts.stuck_at), axis=1)]
    # nearer than every place a contact stuck, by the expected sample spacing (2 * axis): a robot stuck beside a
    # sampled one is not past it
    past = float(np.min(volumes.distance_to_target(ends if len(ends) else contacts.x[contacts.stuckish])))
    past -= 2.0 * settings.axis
    starts = volumes.configurations(sampled.x[0][~sampled.colliding[0]])
    if len(starts) == 0:
        return 0.0, Rollouts(np.zeros(0, dtype=bool), 0)
    result = rollout(volumes, starts, simulator, rng, stuck_distance=settings.stuck_distance,
                     stuck_steps=settings.stuck_steps, max_steps=max_steps, past=past)
    return result.probability, result


@dataclass
class PropagatedMotion:
    """The particles of :func:`propagated_probability`: per particle, whether it survived, and the work done."""

    survived: np.ndarray
    events: int
    labelled: int
    simulated: int
    checked: int


def propagated_probability(volumes: ReachableVolumes, settings: SamplingSettings, clearance: Clearance,
                           simulator: Simulator, rng: np.random.Generator, starts: np.ndarray,
                           labelled: int, max_steps: int, bisections: int = 5) -> tuple[float, PropagatedMotion]:
    """``P_exec`` of the motion from particles of the obstacle-free distribution (``distribution = "propagated"``).

    The thesis samples each reachable volume uniformly, which over-weights the volume's rim where robots rarely
    are (its 6.6 names this the metric's main source of error), and multiplies per-volume means as if the volumes
    were independent.  Here the samples of ``RV_j`` are instead particles of the controller's obstacle-free
    distribution at step ``j`` (``starts``, uniform in the start ball, moved one noisy control step at a time with
    eq. 6.14's noise drawn as the simulator draws it, :meth:`pliant.execution.actuation.ControlLaw.step_noise`; they
    stay inside the volumes by Theorem 2), and each particle's own path is followed: where
    its step from a free configuration into a colliding one first meets the contact manifold (bisection on the
    step, as for the images) is a *contact event*.  Up to ``labelled`` events, chosen at random, are labelled by
    simulating them until they reach the target, stick, or run out of what is left of an execution's step
    budget (``max_steps`` less the steps before the event; running out counts as stuck: a jammed robot jitters
    without arriving) with
    :func:`~.contact.classify` -- the simulation sees a slide that ends stuck, so the thesis's downstream
    heuristic is not applied;
    every other event takes the label of the nearest labelled one (the thesis's stuck-region lookup).  Only a
    particle's first event counts: after it the robot slides or sticks, while the particle, which ignores
    obstacles, goes on through them.  ``P_exec`` is the fraction of particles whose first event is not stuck.
    """
    law, w = volumes.law, volumes.weights
    q = np.array(starts, dtype=np.float64)
    n = len(q)
    distance, _, colliding = clearance.query(q)
    free = ~colliding
    checked = n
    # rigid bodies: a lower bound on each particle's clearance skips the check while it cannot have hit anything
    rigid = clearance.reach is not None
    bound = clearance.lower_bound(q, distance) if rigid else np.zeros(n)
    met = np.zeros(n, dtype=bool)
    event_particle, event_x, event_step = [], [], []
    for step_index in range(len(volumes) - 1):
        velocity = law.velocity(q, volumes.target)
        step = velocity * law.dt + law.step_noise(rng, q, velocity)
        q_next = law.space.retract(q, step)
        if rigid:
            bound -= np.linalg.norm(step[:, ~law.angular], axis=1) + \
                np.linalg.norm(step[:, law.angular], axis=1) * clearance.reach
        check = np.nonzero(bound <= 0.0)[0] if rigid else np.arange(n)
        colliding = np.zeros(n, dtype=bool)
        distance, _, colliding[check] = clearance.query(q_next[check])
        if rigid:
            bound[check] = clearance.lower_bound(q_next[check], distance)
        checked += len(check)
        meets = np.nonzero(free & colliding & ~met)[0]
        met[meets] = True
        if len(meets):
            free_end = volumes.coordinates(q[meets])
            hit_end = volumes.coordinates(q_next[meets])
            for _ in range(bisections):
                middle = 0.5 * (free_end + hit_end)
                collides = clearance.colliding(volumes.configurations(middle))
                checked += len(middle)
                hit_end = np.where(collides[:, None], middle, hit_end)
                free_end = np.where(collides[:, None], free_end, middle)
            event_particle.append(meets)
            event_x.append(free_end)
            event_step.append(np.full(len(meets), step_index))
        q, free = q_next, ~colliding
    survived = np.ones(n, dtype=bool)
    if not event_particle:
        return 1.0, PropagatedMotion(survived, 0, 0, 0, checked)
    particle = np.concatenate(event_particle)
    x = np.concatenate(event_x)
    chosen = rng.choice(len(x), size=min(labelled, len(x)), replace=False)
    # each labelled event simulated for what is left of an execution's step budget when it happened
    budgets = np.maximum(max_steps - np.concatenate(event_step)[chosen], settings.stuck_steps)
    contacts = classify(volumes, x[chosen], np.zeros(len(chosen), dtype=np.int64), simulator, rng,
                        settings.stuck_distance, settings.stuck_steps, max_steps, settings.theta, settings.axis,
                        check_downstream=False, unresolved_stuck=True, budgets=budgets)
    stuck = np.zeros(len(x), dtype=bool)
    for s in range(0, len(x), 2048):                   # nearest labelled event, in weighted coordinates
        d = np.linalg.norm((x[s:s + 2048, None, :] - contacts.x[None, :, :]) * w, axis=2)
        stuck[s:s + 2048] = contacts.stuckish[np.argmin(d, axis=1)]
    survived[particle[stuck]] = False
    return float(np.mean(survived)), PropagatedMotion(survived, len(x), len(chosen), contacts.simulated, checked)
