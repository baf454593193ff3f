"""Sample paths around a demonstration, and the local optimiser of slightly sub-optimal ones (thesis 4.3.1).

Samples follow the smooth-noise process the chapter cites (Kalakrishnan et al., STOMP / PIIRL): the demonstration
is resampled to ``waypoints`` configurations evenly spaced along it; each sample perturbs them by tangent noise
``eps ~ N(0, R^-1)`` along the waypoint index, ``R = A^T A`` with ``A`` the second-difference (acceleration)
operator.  The start is clamped (zero noise) and the end is free, so the noise is smooth and grows toward the end
of the path, where an insertion's deformation happens.  A task that ends at a goal configuration (``goal``) clamps
the end as well: the noise vanishes at both ends.  Each tangent coordinate is scaled so that its largest
standard deviation is ``translation`` (m) or ``rotation`` (rad).  The last waypoint is then moved so that the
tip is back on the task's target: a sample is another way of doing the same task.  Samples that leave the
collision planes are redrawn (at most ``redraws`` times per sample asked for); those that are infeasible (NaN
features) are dropped.  Candidates are drawn, moved and checked a batch at a time, in arrays; the result is the
one of checking them one by one.

The local optimiser replaces a demonstration by the sample of least total deformation among those that
*strictly dominate* it (every feature no larger, one smaller), and repeats with new samples around the
replacement for up to ``rounds`` rounds or until none dominates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from pliant.api import option

from pliant_piirl.demonstration import Demonstration

#: the tolerance (m) of :meth:`DemonstrationTask.allows`, which the funnel check applies
FUNNEL_TOLERANCE = 1e-9


@dataclass(frozen=True)
class SampleOptions:
    """Options of the sample paths around demonstrations."""

    samples: int = option(100, "sample paths per demonstration (thesis: 100)", minimum=1)
    waypoints: int = option(12, "waypoints a demonstration is resampled to before perturbing", minimum=3)
    translation: float = option(0.004, "largest standard deviation of the position noise (m)", minimum=0.0)
    rotation: float = option(0.05, "largest standard deviation of the rotation noise (rad)", minimum=0.0)
    rounds: int = option(3, "local optimiser rounds (0: keep demonstrations as shown)", minimum=0)
    redraws: int = option(20, "most redraws of an invalid sample before it is dropped", minimum=0)
    alternatives: int = option(7, "straight insertions the fit also compares each demonstration with: tilts across "
                               "the funnel (x grid // 2 | 1 along it, and 14 around its own direction); 0: none",
                               minimum=0)


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
        """Up to ``n`` (default :attr:`SampleOptions.samples`) valid sample paths around ``demonstration``, each
        ``(waypoints, d)`` (configurations of the robot's space: m, unit quaternions)."""
        return self.draw_with_features(demonstration, rng, n)[0]

    def draw_with_features(self, demonstration: Demonstration, rng: np.random.Generator,
                           n: int | None = None) -> tuple[list[np.ndarray], np.ndarray]:
        """:meth:`draw` and the paths' features ``(len(paths), n_objects)`` (robot points, as
        :meth:`DeformationFeatures.of_paths` gives them), read once from the states the funnel check measured.

        Each batch of candidates is drawn, retracted and put back on the target as one array.  The funnel is
        checked first at the waypoints (a waypoint is one of the path's states, to rounding, so a path with one
        outside beyond rounding fails), then at every state of the survivors, in order, until ``n`` are accepted.
        Paths, features and the random stream are those of checking candidates one by one."""
        n = self.options.samples if n is None else n
        base = self.resample(demonstration.path)
        task = demonstration.task
        chol = self._chol if task.goal is None else self._chol_clamped
        inner = slice(1, 1 + len(chol))
        kept: list[np.ndarray] = []
        kept_states: list[np.ndarray] = []
        kept_counts: list[int] = []
        budget = n * (1 + self.options.redraws)
        while len(kept) < n and budget > 0:
            batch = min(budget, 2 * (n - len(kept)))
            budget -= batch
            noise = np.einsum("ij,bjt->bit", chol, rng.normal(size=(batch, len(chol), len(self._scale))))
            samples = np.repeat(base[None], batch, axis=0)
            samples[:, inner] = self.space.retract(base[inner], noise * self._scale)
            if task.goal is None:
                samples[:, -1] = self._onto_targets(samples[:, -1], task.target)
            else:
                samples[:, -1] = task.goal
            b, k, d = samples.shape
            maybe = self._paths_allowed(samples.reshape(b * k, d), np.full(b, k), task, exact=False)
            candidates = np.flatnonzero(maybe)
            while len(candidates) and len(kept) < n:
                take, candidates = candidates[:n - len(kept)], candidates[n - len(kept):]
                states, counts = self.features.path_states(samples[take])
                ok = self._paths_allowed(states, counts, task)
                starts = np.cumsum(counts) - counts
                for i in np.flatnonzero(ok):
                    kept.append(samples[take[i]])
                    kept_states.append(states[starts[i]:starts[i] + counts[i]])
                    kept_counts.append(counts[i])
        if not kept:
            return [], np.zeros((0, len(self.features.names)))
        feats = self.features.of_states(np.concatenate(kept_states), np.array(kept_counts))
        finite = np.all(np.isfinite(feats), axis=1)
        return [p for p, f in zip(kept, finite) if f], feats[finite]

    def valid_with_features(self, paths, task) -> tuple[list[np.ndarray], np.ndarray]:
        """The paths of ``paths`` (``(n, k, d)`` or a list of ``(k_i, d)``) that keep the robot inside ``task``'s
        collision planes at every measured state and have finite features, with those features ``(m, n_objects)``
        (robot points): what :meth:`draw_with_features` keeps of its candidates, for candidates made elsewhere."""
        paths = [np.asarray(p, dtype=np.float64) for p in paths]
        if not paths:
            return [], np.zeros((0, len(self.features.names)))
        states, counts = self.features.path_states(paths)
        ok = self._paths_allowed(states, counts, task)
        starts = np.cumsum(counts) - counts
        keep = np.flatnonzero(ok)
        if not len(keep):
            return [], np.zeros((0, len(self.features.names)))
        rows = np.concatenate([states[starts[i]:starts[i] + counts[i]] for i in keep])
        feats = self.features.of_states(rows, counts[keep])
        finite = np.all(np.isfinite(feats), axis=1)
        return [paths[i] for i, f in zip(keep, finite) if f], feats[finite]

    def _paths_allowed(self, states: np.ndarray, counts: np.ndarray, task, exact: bool = True) -> np.ndarray:
        """Bool ``(n,)``: whether every state of each path (``counts[i]`` consecutive rows of ``states``) keeps
        the robot's outline inside the task's collision planes: ``task.allows(outline(states)).all()`` path by
        path.  A rigid robot is checked by :func:`_funnel_codes`; a path it cannot decide (a point within
        rounding of a plane) is checked by ``task.allows`` itself, or, when not ``exact``, counted as allowed
        (a pre-check that may only reject what the exact check would reject)."""
        counts = np.asarray(counts, dtype=np.int64)
        starts = np.cumsum(counts) - counts
        if len(task.planes) == 0 or len(counts) == 0:
            return np.ones(len(counts), dtype=bool)
        placement = self.features.outline_placement(states)
        if placement is None:
            allowed = task.allows(self.features.outline(states)).all(axis=1)
            return np.logical_and.reduceat(allowed, starts)
        rot, pos, hull = placement
        planes = np.ascontiguousarray(task.planes, dtype=np.float64)
        limits = planes[:, 3] + FUNNEL_TOLERANCE
        # a bound on how far this kernel's n . x - limit and numpy's can differ (both round a sum of a few terms
        # of size at most |p| + |h| + |limit|), with four orders of magnitude to spare
        margin = 1e-12 * (1.0 + float(np.abs(limits).max()) + 2.0 * float(np.abs(pos).max())
                          + float(np.linalg.norm(hull, axis=1).max()))
        codes = np.empty(len(counts), dtype=np.int64)
        _funnel_codes(np.ascontiguousarray(rot), np.ascontiguousarray(pos), np.ascontiguousarray(hull),
                      np.ascontiguousarray(planes[:, :3]), limits, margin, counts, codes)
        if exact:
            for i in np.flatnonzero(codes < 0):
                rows = states[starts[i]:starts[i] + counts[i]]
                codes[i] = int(task.allows(self.features.outline(rows), FUNNEL_TOLERANCE).all())
        return codes != 0

    def _onto_targets(self, q: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Configurations ``(b, d)`` moved (positions only) so that the tip is on ``target`` (m)."""
        rot, _, _ = self.robot.rigid_placement(q)
        q = np.array(q, dtype=np.float64, copy=True)
        q[:, :3] = target - np.matmul(rot, self.tip)
        return q

    def improve(self, demonstration: Demonstration, rng: np.random.Generator) -> tuple[Demonstration, int]:
        """The local optimiser; returns the (possibly replaced) demonstration and how many replacements it made."""
        current, replaced, _, _ = self.improve_with_samples(demonstration, rng)
        return current, replaced

    def improve_with_samples(self, demonstration: Demonstration, rng: np.random.Generator
                             ) -> tuple[Demonstration, int, np.ndarray, np.ndarray | None]:
        """:meth:`improve`, and what it measured last: ``(demonstration, replacements, its features, features
        of the samples of the round that found nothing dominating it)``.  Those samples were drawn around the
        returned demonstration, as :meth:`draw_with_features` draws them, so a fit uses them instead of drawing
        again; the last item is None when the optimiser stopped otherwise (no rounds, its last round replaced the
        demonstration, or no sample was valid)."""
        current = demonstration
        mine = self.features.of_path(current.path)
        replaced = 0
        for _ in range(self.options.rounds):
            samples, feats = self.draw_with_features(current, rng)
            if not samples:
                break
            dominating = np.all(feats <= mine, axis=1) & np.any(feats < mine, axis=1)
            if not dominating.any():
                return current, replaced, mine, feats
            best = int(np.argmin(np.where(dominating, feats.sum(axis=1), np.inf)))
            current = Demonstration(current.task, samples[best], current.source)
            mine = feats[best]
            replaced += 1
        return current, replaced, mine, None


@numba.njit(cache=True, nogil=True)
def _funnel_codes(rotations, positions, hull, normals, limits, margin, counts, out):
    """For each path ``p``, made of the next ``counts[p]`` placements (``rotations`` ``(M, 3, 3)``, ``positions``
    ``(M, 3)``, m) of the outline ``hull`` ``(h, 3)`` (body frame, m): ``out[p]`` 0 when some placed vertex
    ``x`` has ``normals[j] . x - limits[j] > margin`` for some plane ``j`` (outside beyond doubt), 1 when every
    vertex is below ``-margin`` for every plane (inside beyond doubt), -1 otherwise.  A path stops at its first
    state outside."""
    a = 0
    for p in range(counts.shape[0]):
        end = a + counts[p]
        code = 1
        while a < end and code != 0:
            r = rotations[a]
            for v in range(hull.shape[0]):
                hx, hy, hz = hull[v, 0], hull[v, 1], hull[v, 2]
                x = r[0, 0] * hx + r[0, 1] * hy + r[0, 2] * hz + positions[a, 0]
                y = r[1, 0] * hx + r[1, 1] * hy + r[1, 2] * hz + positions[a, 1]
                z = r[2, 0] * hx + r[2, 1] * hy + r[2, 2] * hz + positions[a, 2]
                for j in range(normals.shape[0]):
                    s = normals[j, 0] * x + normals[j, 1] * y + normals[j, 2] * z - limits[j]
                    if s > margin:
                        code = 0
                        break
                    if s >= -margin:
                        code = -1
                if code == 0:
                    break
            a += 1
        a = end
        out[p] = code
