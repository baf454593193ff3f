"""Plan repair during execution: push the objects that noise has displaced back to where the plan expects them,
instead of planning anew.

A replanning (:func:`pliant_tsrrt.search.grow` from the observed arrangement) returns a new plan whose cost is
whatever its tree found in the replanning budget: after a small deviation that is often 1.2-1.4 times the first
plan's cost, and the new plan, like the first, is long, so noise soon triggers the next replanning.  A repair keeps
the plan: each displaced object is pushed back toward its pose in the plan's predicted arrangement by the same beam
search the improvement phase uses (:func:`pliant_tsrrt.refine.push_toward`), and the rest of the plan follows.  When
the plan is done but the arrangement costs more than the tolerance, the repair pushes the objects toward the first
plan's final arrangement (:func:`pliant_tsrrt.refine.connect`); so does a deviation that cannot be undone, when the
pushes toward that arrangement end within the finishing tolerance of its cost.  A repair that cannot bring the
objects back (a blocked object, an invalid rest of the plan, no gain) returns ``None`` and execution replans as
before.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace

import numpy as np

from pliant_tsrrt.geometry import wrap
from pliant_tsrrt.refine import _pose_error, connect, push_toward


@dataclass(frozen=True)
class Repair:
    """A repaired plan from the observed arrangement: the ``actions`` (repair pushes first), their predicted
    ``states`` ``(m + 1, k, 3)``, the number of ``pushes`` the repair added and the ``objects`` it moved."""

    actions: list[int]
    states: np.ndarray
    pushes: int
    objects: list[int]


def pose_errors(space, observed: np.ndarray, expected: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per object: position error (m) and yaw error (rad, modulo the footprint's symmetry; 0 for circles) of
    arrangement ``observed`` against ``expected`` (both ``(k, 3)``): what execution monitors."""
    err_t = np.linalg.norm(observed[:, :2] - expected[:, :2], axis=1)
    dth = np.abs(wrap(observed[:, 2] - expected[:, 2], space.period))
    return err_t, np.where(space.scale > 0, dth, 0.0)


def _displaced(space, observed: np.ndarray, target: np.ndarray, distance: float, angle: float) -> list[int]:
    """The objects more than ``distance`` (m) or ``angle`` (rad, modulo the footprint's symmetry) from ``target``,
    most displaced first (pose error with the yaw weighted by the footprint's radius)."""
    err_t, dtheta = pose_errors(space, observed, target)
    off = (err_t > distance) | (dtheta > angle)
    errors = [float(_pose_error(space, o, observed[o], target[o])) for o in range(space.k)]
    return sorted((int(o) for o in np.nonzero(off)[0]), key=lambda o: -errors[o])


def _exact_yaw(space):
    """``space`` in which every object's yaw counts in full (period 2 pi, weighted by the footprint's radius, circles
    included): a box turned by its symmetry, or a turned can, is the same footprint, but the plan's remaining pushes
    (in the object's frame) would push it elsewhere, so a repair must bring back the yaw itself."""
    exact = copy.copy(space)
    exact.period = np.full(space.k, 2 * np.pi)
    exact.scale = np.asarray(space.fp.radius, dtype=np.float64).copy()
    return exact


def loosened(space, slack: float = 0.5):
    """``space`` with its clearance margin times ``slack``: the margin is there for the noise of execution, so the rest
    of a plan that was valid with it may use part of it once objects have drifted by millimetres."""
    return replace(space, checker=replace(space.checker, margin=space.checker.margin * slack))


def restore(space, observed: np.ndarray, expected: np.ndarray, rest: list[int], *, threshold: float,
            angle: float, depth: int = 12, width: int = 64, yaw_quota: int = 4, slack: float = 0.5,
            at_most: float | None = None) -> Repair | None:
    """Repair after a deviation: the objects of ``observed`` ``(k, 3)`` farther than half the replanning thresholds
    (``threshold`` m, ``angle`` rad) from ``expected`` (the plan's predicted arrangement at this step) are pushed back
    toward it, most displaced first, at most ``depth`` pushes each; then the plan's remaining actions ``rest``.
    ``None`` unless every object ends (as predicted by the models) within half the thresholds of ``expected`` and
    the whole sequence is valid with the clearance margin times ``slack`` (the objects are back only to within
    millimetres, and the plan's margin is there for exactly that) and, with ``at_most``, the predicted final cost is
    at most that (the rest of the plan from poses a few millimetres and degrees off can end far from the plan's
    end: the pushes act in each object's frame)."""
    space = _exact_yaw(space)
    objects = _displaced(space, observed, expected, threshold / 2, angle / 2)
    s, actions = observed, []
    for o in objects:
        _, seq, s = push_toward(space, s, o, expected[o], depth=depth, width=width, stop="closest",
                                yaw_quota=yaw_quota)
        actions += seq
    if _displaced(space, s, expected, threshold / 2, angle / 2):
        return None
    plan = actions + list(rest)
    states, ok = loosened(space, slack).rollout(observed, plan)
    if not ok or (at_most is not None and float(space.cost.cost(states[-1][None])[0]) > at_most):
        return None
    return Repair(plan, states, len(actions), objects)


def retarget(space, observed: np.ndarray, expected: np.ndarray, rest: list[int], *, threshold: float,
             angle: float, depth: int = 40, width: int = 64, yaw_quota: int = 4, slack: float = 0.5,
             at_most: float | None = None, objects: list[int] | None = None) -> Repair | None:
    """Repair after a deviation by re-planning the displaced objects' part of the plan: each object of ``observed``
    farther than half the thresholds from ``expected`` (the plan's predicted arrangement at this step) loses its
    remaining pushes of ``rest`` and is pushed instead, at most ``depth`` pushes, toward the pose the plan leaves it
    in (its yaw modulo the footprint's symmetry: no push of the plan follows), where the plan would have moved it
    first (one displaced object), or before the rest of the plan.  Unlike :func:`restore` it does not bring the
    object back to a pose on the way (under noise, a noisy turn of a heavy box is undone by more noisy turns).
    ``None`` unless every displaced object ends (as predicted by the models) within half the thresholds of that
    pose, the whole sequence is valid with the clearance margin times ``slack``, and, with ``at_most``, the
    predicted final cost is at most that.  ``objects``: only these of the displaced objects (all by default)."""
    displaced = _displaced(_exact_yaw(space), observed, expected, threshold / 2, angle / 2)
    objects = [o for o in displaced if objects is None or o in objects]
    if not objects:
        return None
    rest = list(rest)
    final = space.rollout(expected, rest)[0][-1]
    loose = loosened(space, slack)
    candidates = []
    starts = [0]
    if len(objects) == 1:
        first = next((i for i, a in enumerate(rest) if a // space.n_prims == objects[0]), None)
        if first:
            starts.insert(0, first)                    # where the plan would have moved the object next
    for at in starts:
        head = rest[:at]
        s = space.rollout(observed, head)[0][-1]
        added: list[int] = []
        for o in objects:
            _, seq, s = push_toward(space, s, o, final[o], depth=depth, width=width, stop="closest",
                                    yaw_quota=yaw_quota)
            added += seq
        if set(objects) & set(_displaced(space, s, final, threshold / 2, angle / 2)):
            continue
        plan = head + added + [a for a in rest[at:] if a // space.n_prims not in objects]
        states, ok = loose.rollout(observed, plan)
        if not ok or (at_most is not None and float(space.cost.cost(states[-1][None])[0]) > at_most):
            continue
        candidates.append(Repair(plan, states, len(added), objects))
    return min(candidates, key=lambda r: len(r.actions)) if candidates else None


def toward_goal(space, observed: np.ndarray, goal: np.ndarray, *, depth: int = 12, width: int = 64,
                yaw_quota: int = 4, distance: float = 0.002, angle: float = 0.01,
                at_most: float | None = None, push_cost: float = 0.0,
                enough: float | None = None) -> Repair | None:
    """Repair toward the first plan's final arrangement ``goal``: the objects of ``observed`` more than ``distance``
    (m) or ``angle`` (rad) from it are pushed toward it (two sweeps over them, most displaced first, at most
    ``depth`` pushes per object and sweep; the sequence cut where the predicted task cost, plus ``push_cost`` per
    push, is lowest; costs below ``enough`` count as ``enough``).  ``None``
    unless that lowers the predicted cost by at least 0.1 % and, with ``at_most``, ends at no more than that
    cost.  Used when a plan is done above the tolerance, and after a deviation that :func:`restore` cannot undo
    (then the rest of the plan is dropped)."""
    objects = _displaced(space, observed, goal, distance, angle)
    if not objects:
        return None
    cost_now = float(space.cost.cost(observed[None])[0])
    cost, actions = connect(space, observed, goal, objects, depth=depth, width=width, sweeps=2, stop="closest",
                            yaw_quota=yaw_quota, push_cost=push_cost,
                            enough=-np.inf if enough is None else enough)
    if not actions or cost > cost_now * (1 - 1e-3) or (at_most is not None and cost > at_most):
        return None
    states, ok = space.rollout(observed, actions)
    if not ok:
        return None
    return Repair(actions, states, len(actions), objects)


__all__ = ["Repair", "loosened", "pose_errors", "restore", "retarget", "toward_goal"]
