"""Sample paths around a demonstration, and the local optimiser of slightly sub-optimal ones (thesis 4.3.1).

Samples follow the smooth-noise process the chapter cites (Kalakrishnan et al., STOMP / PIIRL): the demonstration
is resampled to ``waypoints`` configurations evenly spaced along it; each sample perturbs them by tangent noise
``eps ~ N(0, R^-1)`` along the waypoint index, ``R = A^T A`` with ``A`` the second-difference (acceleration)
operator.  The start is clamped (zero noise) and the end is free, so the noise is smooth and grows toward the end
of the path, where an insertion's deformation happens.  A task that ends at a goal configuration (``goal``) clamps
the end as well: the noise vanishes at both ends.  Each tangent coordinate is scaled so that its largest
standard deviation is ``translation`` (m) or ``rotation`` (rad).  The last waypoint is then moved so that the
tip is back on the task's target: a sample is another way of doing the same task.  Samples that leave the
collision planes or are infeasible (NaN features) are redrawn.

The local optimiser replaces a demonstration by the sample of least total deformation among those that
*strictly dominate* it (every feature no larger, one smaller), and repeats with new samples around the
replacement for up to ``rounds`` rounds or until none dominates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.options import option

from pliant_piirl.demonstration import Demonstration


@dataclass(frozen=True)
class SampleOptions:
    """Options of the sample paths around demonstrations."""

    samples: int = option(100, "sample paths per demonstration (thesis: 100)", minimum=1)
    waypoints: int = option(12, "waypoints a demonstration is resampled to before perturbing", minimum=3)
    translation: float = option(0.004, "largest standard deviation of the position noise (m)", minimum=0.0)
    rotation: float = option(0.05, "largest standard deviation of the rotation noise (rad)", minimum=0.0)
    rounds: int = option(3, "local optimiser rounds (0: keep demonstrations as shown)", minimum=0)
    redraws: int = option(20, "most redraws of an invalid sample before it is dropped", minimum=0)


def smooth_covariance(k: int, clamp_end: bool = False) -> np.ndarray:
    """``R^-1`` ``(k, k)`` for ``k`` waypoints, start clamped and end free (or clamped too), scaled to a largest
    variance of 1."""
    if clamp_end:
        a = np.zeros((k + 1, k))                    # accelerations with zero ghosts beyond both clamped ends
        for r in range(k + 1):
            for c, w in ((r - 2, 1.0), (r - 1, -2.0), (r, 1.0)):
                if 1 <= c < k - 1:
                    a[r, c] = w
        r_ = a.T @ a
        r_[0, 0] = r_[k - 1, k - 1] = 1.0
        cov = np.linalg.inv(r_)
        cov[0, :] = cov[:, 0] = cov[k - 1, :] = cov[:, k - 1] = 0.0
        return cov / cov.diagonal().max()
    a = np.zeros((k, k))
    for r in range(k):          # accelerations over [0 (ghost), 0 (start), x_1, ..., x_{k-1}]; none past the end
        for c, w in ((r - 2, 1.0), (r - 1, -2.0), (r, 1.0)):
            if 1 <= c < k:
                a[r, c] = w
    r = a.T @ a
    r[0, 0] = 1.0                                   # the clamped start: unit precision, zeroed below
    cov = np.linalg.inv(r)
    cov[0, :] = cov[:, 0] = 0.0
    return cov / cov.diagonal().max()


class PathSampler:
    """Draws sample paths around demonstrations in the space of ``features`` (a ``DeformationFeatures``) for a
    rigid robot whose ``tip`` (body frame, m) must end on the task's target."""

    def __init__(self, features, tip, options: SampleOptions | None = None) -> None:
        self.features, self.options = features, options or SampleOptions()
        self.space, self.robot = features.space, features.robot
        self.tip = np.asarray(tip, dtype=np.float64)
        k = self.options.waypoints
        self._chol = np.linalg.cholesky(smooth_covariance(k)[1:, 1:])
        self._chol_clamped = np.linalg.cholesky(smooth_covariance(k, clamp_end=True)[1:-1, 1:-1])
        t = self.space.tangent_dim
        self._scale = np.full(t, self.options.translation)
        if t == 6:
            self._scale[3:] = self.options.rotation
        elif t == 3 and getattr(self.space, "kind", "") == "se2":
            self._scale[2] = self.options.rotation

    def resample(self, path: np.ndarray) -> np.ndarray:
        """``path`` as :attr:`SampleOptions.waypoints` configurations evenly spaced along it (metric units)."""
        path = np.asarray(path, dtype=np.float64)
        seg = np.asarray(self.space.distance(path[:-1], path[1:]), dtype=np.float64)
        at = np.concatenate([[0.0], np.cumsum(seg)])
        want = np.linspace(0.0, at[-1], self.options.waypoints)
        out = np.empty((len(want), path.shape[1]))
        for i, s in enumerate(want):
            j = min(int(np.searchsorted(at, s, side="right")) - 1, len(seg) - 1)
            t = 0.0 if seg[j] == 0 else (s - at[j]) / seg[j]
            out[i] = self.space.interpolate(path[j], path[j + 1], min(max(t, 0.0), 1.0))
        return out

    def draw(self, demonstration: Demonstration, rng: np.random.Generator, n: int | None = None) -> list[np.ndarray]:
        """Up to ``n`` (default :attr:`SampleOptions.samples`) valid sample paths around ``demonstration``."""
        n = self.options.samples if n is None else n
        base = self.resample(demonstration.path)
        task = demonstration.task
        out: list[np.ndarray] = []
        budget = n * (1 + self.options.redraws)
        while len(out) < n and budget > 0:
            batch = min(budget, 2 * (n - len(out)))
            budget -= batch
            chol = self._chol if task.goal is None else self._chol_clamped
            noise = np.einsum("ij,bjt->bit", chol, rng.normal(size=(batch, len(chol), len(self._scale))))
            for eps in noise * self._scale:
                sample = base.copy()
                sample[1:1 + len(chol)] = self.space.retract(base[1:1 + len(chol)], eps)
                if task.goal is None:
                    sample[-1] = self._onto_target(sample[-1], task.target)
                else:
                    sample[-1] = task.goal
                if task.allows(self.features.outline(self.features.states(sample))).all():
                    out.append(sample)
                    if len(out) == n:
                        break
        feats = self.features.of_paths(out) if out else np.zeros((0, len(self.features.names)))
        return [p for p, f in zip(out, feats) if np.all(np.isfinite(f))]

    def _onto_target(self, q: np.ndarray, target: np.ndarray) -> np.ndarray:
        rot, _, _ = self.robot.rigid_placement(q[None])
        q = q.copy()
        q[:3] = target - rot[0] @ self.tip
        return q

    def improve(self, demonstration: Demonstration, rng: np.random.Generator) -> tuple[Demonstration, int]:
        """The local optimiser; returns the (possibly replaced) demonstration and how many replacements it made."""
        current = demonstration
        mine = self.features.of_path(current.path)
        replaced = 0
        for _ in range(self.options.rounds):
            samples = self.draw(current, rng)
            if not samples:
                break
            feats = self.features.of_paths(samples)
            dominating = np.all(feats <= mine, axis=1) & np.any(feats < mine, axis=1)
            if not dominating.any():
                break
            best = int(np.argmin(np.where(dominating, feats.sum(axis=1), np.inf)))
            current = Demonstration(current.task, samples[best], current.source)
            mine = feats[best]
            replaced += 1
        return current, replaced
