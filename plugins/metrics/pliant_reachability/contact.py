"""Contact manifold characterisation (thesis 6.4.3): project near-contact samples to contact (eq. 6.9), tell
sliding from stuck by a short simulation, and mark sliding configurations downstream of stuck ones.

Projection.  The closest surface point ``p`` of a near-contact configuration is moved toward the obstacle
along the signed-distance gradient, ``dp = -(d(p) - h/4) grad d`` (``d`` the interpolated signed distance,
``h`` the voxel), through the pseudo-inverse of its Jacobian, ``dq = J(q, p)^+ dp`` (eq. 6.9), until it
touches: some surface point lies in a free voxel that shares a face with an occupied one (voxel-centre
clearance ``h/2``), none in an occupied one; at most ``iterations`` steps.  A step that collides is halved
(three times at most); configurations that collide anyway, or leave their reachable volume, are dropped (as
the thesis does).

Sliding or stuck.  Each contacting configuration is simulated toward the target, one control step at a time,
for ``horizon`` steps: it is *stuck* when its first ``stuck_steps`` steps move it less than ``stuck_distance``
in all (weighted), *becomes stuck* when some later window of ``stuck_steps`` steps does, else it *slides* --
the test that ends a simulated execution (:mod:`.rollout`, the contact controller's), so that the metric and
the simulation baselines mean the same thing by "stuck".  The thesis simulates one step and compares progress
toward the target with ``Delta_stuck``, and finds sliding configurations that stick later only by the
downstream check below; docs/plugins/reachability.md says why both are extended here.

Downstream.  A robot may slide for a while and then stick.  With ``r(q)`` the rejection of the motion
``q -> b`` from the path's direction ``a -> b`` (weighted coordinates), a sliding ``q_s`` *becomes stuck* when
some stuck ``q_k`` of the same or a later volume has ``|r(q_k)| < |r(q_s)|`` and an angle below ``theta``
between ``r(q_k)`` and ``r(q_s)`` (a stuck ``q_k`` on the path's axis, ``|r| <= axis``, matches every
direction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import RobotModel, Simulator

from pliant_reachability.clearance import Clearance
from pliant_reachability.rollout import StuckWindow
from pliant_reachability.volumes import ReachableVolumes

SLIDING, STUCK, BECOMES_STUCK = 0, 1, 2


@dataclass
class Contacts:
    """Contacting configurations of one motion, labelled.

    x: ``(k, t)`` target-tangent coordinates; volume: ``(k,)`` index of the reachable volume each came from;
    label: ``(k,)`` one of ``SLIDING``, ``STUCK``, ``BECOMES_STUCK``; simulated: control steps simulated.
    stuck_at: ``(k, t)`` coordinates where the simulation of each stuck contact stopped (NaN for the others and
    for contacts the downstream check marked).
    """

    x: np.ndarray
    volume: np.ndarray
    label: np.ndarray
    simulated: int = 0
    stuck_at: np.ndarray | None = None

    @property
    def stuckish(self) -> np.ndarray:
        """Bool ``(k,)``: stuck or becoming stuck."""
        return self.label != SLIDING


def project_to_contact(q: np.ndarray, robot: RobotModel, clearance: Clearance, iterations: int
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Move configurations ``(n, d)`` into contact (eq. 6.9); returns the configurations and a bool ``(n,)`` of
    those that reached contact without colliding."""
    space = robot.space
    q = np.array(q, dtype=np.float64)
    done = np.zeros(len(q), dtype=bool)
    failed = np.zeros(len(q), dtype=bool)
    grid = clearance.grid
    touch = 0.6 * grid.resolution            # voxel-centre clearance of a face neighbour: h / 2
    for _ in range(iterations + 1):
        active = np.nonzero(~done & ~failed)[0]
        if len(active) == 0:
            break
        dist, closest, colliding = clearance.query(q[active])
        failed[active[colliding]] = True
        touching = ~colliding & (dist <= touch)
        done[active[touching]] = True
        move = active[~colliding & ~touching]
        if len(move) == 0:
            break
        index = clearance.surface[closest[~colliding & ~touching]]
        trial = q[move].copy()
        for point in np.unique(index):
            rows = np.nonzero(index == point)[0]
            qs = q[move[rows]]
            p = robot.body_points(qs, np.array([point]))[:, 0]
            grad = grid.sdf_gradient_at(p)
            norm = np.linalg.norm(grad, axis=1, keepdims=True)
            direction = -grad / np.where(norm > 0, norm, 1.0)
            depth = grid.sdf_at(p) - 0.25 * grid.resolution
            dp = direction * np.maximum(depth, 0.0)[:, None]
            jac = robot.point_jacobians(qs, np.array([point]))[:, 0]          # (k, 3, t)
            dq = np.einsum("kts,ks->kt", np.linalg.pinv(jac), dp)
            trial[rows] = space.retract(qs, dq)
        # a projection step that collides is halved (twice at most) before the configuration gives up
        for _ in range(3):
            bad = clearance.query(trial)[2]
            if not bad.any():
                break
            delta = space.difference(trial[bad], q[move[bad]])
            trial[bad] = space.retract(q[move[bad]], 0.5 * delta)
        q[move] = trial
    return q, done & ~failed


def classify(volumes: ReachableVolumes, x: np.ndarray, volume: np.ndarray, simulator: Simulator,
             rng: np.random.Generator, stuck_distance: float, stuck_steps: int, horizon: int, theta: float,
             axis: float, check_downstream: bool = True, unresolved_stuck: bool = False,
             budgets: np.ndarray | None = None) -> Contacts:
    """Label contacting coordinates ``(k, t)`` sliding / stuck / becoming stuck (thesis 6.4.3); without
    ``check_downstream`` only the simulation labels them; with ``unresolved_stuck`` a contact that neither reached
    the target nor stuck within the horizon (a robot jammed and jittering) becomes stuck instead of sliding;
    ``budgets`` ``(k,)`` gives each contact its own horizon (at most ``horizon``)."""
    label = np.zeros(len(x), dtype=np.int64)
    stuck_at = np.full(x.shape, np.nan)
    if len(x) == 0:
        return Contacts(x, volume, label, 0, stuck_at)
    q = volumes.configurations(x)
    active = np.ones(len(x), dtype=bool)
    window = StuckWindow(len(x), stuck_steps, stuck_distance)
    simulated = 0
    for step in range(1, max(horizon, stuck_steps) + 1):
        idx = np.nonzero(active)[0]
        if len(idx) == 0:
            break
        before = volumes.coordinates(q[idx])
        q[idx] = simulator.simulate(q[idx], volumes.target, rng, volumes.law.dt).final
        simulated += len(idx)
        after = volumes.coordinates(q[idx])
        reached = volumes.distance_to_target(after) <= volumes.epsilon
        stuck = window.add(idx, np.linalg.norm((after - before) * volumes.weights, axis=1)) & ~reached
        label[idx[stuck]] = STUCK if step == stuck_steps else BECOMES_STUCK
        stuck_at[idx[stuck]] = after[stuck]
        active[idx[stuck | reached]] = False
        if budgets is not None:
            spent = idx[(budgets[idx] <= step) & ~stuck & ~reached]
            if unresolved_stuck:
                label[spent] = BECOMES_STUCK
            active[spent] = False
    if unresolved_stuck:
        label[active] = BECOMES_STUCK
    if check_downstream:
        label = downstream(volumes, x, volume, label, theta, axis)
    return Contacts(x, volume, label, simulated, stuck_at)


def rejections(volumes: ReachableVolumes, x: np.ndarray) -> np.ndarray:
    """Weighted rejection ``(k, t)`` of the motion ``q -> b`` from the path's direction ``a -> b``."""
    w = volumes.weights
    axis = -volumes.coordinates(volumes.start[None])[0] * w
    norm = np.linalg.norm(axis)
    motion = -x * w
    if norm == 0:
        return motion
    u = axis / norm
    return motion - np.outer(motion @ u, u)


def downstream(volumes: ReachableVolumes, x: np.ndarray, volume: np.ndarray, label: np.ndarray, theta: float,
               axis: float) -> np.ndarray:
    """Mark sliding configurations that pass through a stuck region downstream as ``BECOMES_STUCK``."""
    label = label.copy()
    stuck = np.nonzero(label == STUCK)[0]
    sliding = np.nonzero(label == SLIDING)[0]
    if len(stuck) == 0 or len(sliding) == 0:
        return label
    r = rejections(volumes, x)
    rs, rk = r[sliding], r[stuck]
    ns = np.linalg.norm(rs, axis=1)
    nk = np.linalg.norm(rk, axis=1)
    cos = (rs @ rk.T) / np.maximum(np.outer(ns, nk), 1e-300)
    aligned = (cos >= np.cos(theta)) | (nk[None, :] <= axis)
    later = volume[stuck][None, :] >= volume[sliding][:, None]
    closer = nk[None, :] < ns[:, None]
    label[sliding[np.any(aligned & later & closer, axis=1)]] = BECOMES_STUCK
    return label
