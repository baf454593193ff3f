"""The simulated expert: a demonstrator that knows the hidden sensitivities (thesis 4.3.1's person, unattended).

For a task (start, target, funnel) it plans the cheapest *straight insertion* under the scene's own
sensitivities: the probe turns outside the objects to a direction ``d``, then slides along ``d`` until its tip
touches the target.  The path is ``[start, pre-insertion, final]``: the final configuration has the tip on the
target and the body axis along ``d``; the pre-insertion one is ``insertion`` metres further out along ``d``.  The
directions searched are the funnel's axis tilted by ``alpha`` across the gap and ``beta`` along the edge, on a
``grid x (grid // 2 | 1)`` lattice within the funnel's openings, then refined ``refine`` times on finer lattices
around the best; a candidate is valid when every measured
configuration keeps the probe inside the collision planes and its cost is finite.  The cheapest valid direction
(true cost ``S . V``) is the optimum.

Sub-optimality (documented, as the issue asks): the expert's hand is unsteady; the shown direction is the
optimum's tilts plus Gaussian noise of ``noise`` rad on each, redrawn until valid.  With ``noise = 0`` the expert
is the optimiser itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import PlanningError, option

from pliant_piirl.demonstration import Demonstration, DemonstrationTask
from pliant_piirl.tasks import rotation_onto


@dataclass(frozen=True)
class ExpertOptions:
    """Options of :class:`SimulatedExpert`."""

    grid: int = option(21, "directions per funnel axis searched (odd, so the axis itself is one)", minimum=1)
    refine: int = option(2, "refinements of the search around the best direction, each a finer lattice", minimum=0)
    noise: float = option(0.01, "the expert's sub-optimality: Gaussian noise on each tilt (rad)", minimum=0.0)
    insertion: float = option(0.07, "length of the straight insertion (m)", minimum=1e-9)
    across_angle: float = option(0.6, "largest tilt across the gap searched (rad)", minimum=0.0, maximum=1.5)
    along_angle: float = option(0.15, "largest tilt along the edge searched (rad)", minimum=0.0, maximum=1.5)


class SimulatedExpert:
    """Shows demonstrations for tasks, knowing ``sensitivities`` (``{object: S}``, the ground truth).

    ``features``: a :class:`~pliant_piirl.features.DeformationFeatures` of the scene; ``tip``: the probe tip in its
    body frame (m); the body z axis is the probe's axis, pointing from the tip backwards.
    """

    def __init__(self, features, sensitivities: dict[str, float], tip, options: ExpertOptions | None = None) -> None:
        self.features, self.options = features, options or ExpertOptions()
        self.weights = features.sensitivity_vector(sensitivities)
        self.tip = np.asarray(tip, dtype=np.float64)

    def demonstrate(self, task: DemonstrationTask, rng: np.random.Generator) -> Demonstration:
        """The expert's (slightly sub-optimal) path for ``task``."""
        best, frame = self.optimum(task)
        o = self.options
        if o.noise > 0:
            for _ in range(100):
                tilt = best + rng.normal(scale=o.noise, size=2)
                path = self.path(task, tilt, frame)
                if self.valid(task, [path])[0]:
                    return Demonstration(task, path, "simulated-expert")
        return Demonstration(task, self.path(task, best, frame), "simulated-expert")

    def optimum(self, task: DemonstrationTask) -> tuple[np.ndarray, tuple]:
        """The cheapest valid tilts ``(alpha, beta)`` (rad) and the funnel frame they are measured in."""
        o = self.options
        frame = funnel_frame(task)
        alphas, betas = tilt_axes(o.grid, o)
        best = self._best(task, frame, np.array([(a, b) for a in alphas for b in betas]))
        # refine: the same lattice, ``refine`` times finer, over one coarse step around the best
        for _ in range(o.refine):
            da = (alphas[1] - alphas[0]) if len(alphas) > 1 else 0.0
            db = (betas[1] - betas[0]) if len(betas) > 1 else 0.0
            alphas = np.clip(best[0] + np.linspace(-da, da, 7), -o.across_angle, o.across_angle)
            betas = np.clip(best[1] + np.linspace(-db, db, 5), -o.along_angle, o.along_angle)
            best = self._best(task, frame, np.array([(a, b) for a in alphas for b in betas]))
        return best, frame

    def _best(self, task, frame, tilts: np.ndarray) -> np.ndarray:
        paths = [self.path(task, t, frame) for t in tilts]
        cost = self.features.of_paths(paths) @ self.weights
        ok = self.valid(task, paths) & np.isfinite(cost)
        if not ok.any():
            raise PlanningError("the expert found no valid straight insertion inside the funnel",
                                field="task.target", value=task.target.tolist())
        # ties (common: the cost counts voxels) go to the smallest tilt
        order = np.lexsort((np.abs(tilts).sum(axis=1), np.where(ok, cost, np.inf)))
        return tilts[order[0]]

    def path(self, task: DemonstrationTask, tilt, frame) -> np.ndarray:
        """``[start, pre-insertion, final]`` for tilts ``(alpha, beta)`` (rad) in the funnel ``frame``."""
        return straight_insertion(task, tilt, frame, self.tip, self.options.insertion)

    def valid(self, task: DemonstrationTask, paths) -> np.ndarray:
        """Whether every measured configuration of each path keeps the probe inside the task's planes."""
        out = np.empty(len(paths), dtype=bool)
        for k, p in enumerate(paths):
            out[k] = bool(task.allows(self.features.outline(self.features.states(p))).all())
        return out


def tilt_axes(grid: int, options: ExpertOptions) -> tuple[np.ndarray, np.ndarray]:
    """The funnel's lattice of tilts: ``grid`` values across the gap within ``+-across_angle`` and ``grid // 2 | 1``
    (odd, so the axis itself is one) along the edge within ``+-along_angle`` (rad); the axis alone for ``grid`` 1."""
    if grid <= 1:
        return np.zeros(1), np.zeros(1)
    return (np.linspace(-options.across_angle, options.across_angle, grid),
            np.linspace(-options.along_angle, options.along_angle, max(1, grid // 2 | 1)))


def straight_insertion(task: DemonstrationTask, tilt, frame, tip: np.ndarray, insertion: float) -> np.ndarray:
    """The straight insertion ``[start, pre-insertion, final]`` along the funnel ``frame``'s axis tilted by
    ``(alpha, beta)`` (rad) across the gap and along the edge: the probe's body z axis along the direction ``d``,
    its ``tip`` (body frame, m) on the target at the end and ``insertion`` metres further out along ``d`` before."""
    axis, across, along = frame
    d = axis + np.tan(tilt[0]) * across + np.tan(tilt[1]) * along
    d /= np.linalg.norm(d)
    q = rotation_onto(d)
    offset = _rotate(q, tip)
    final = np.r_[task.target - offset, q]
    pre = np.r_[task.target + d * insertion - offset, q]
    return np.array([task.start, pre, final])


def tilt_of(direction: np.ndarray, frame) -> np.ndarray:
    """The tilts ``(alpha, beta)`` (rad) in the funnel ``frame`` of an insertion ``direction`` (the probe's body z
    axis, pointing out of the environment): the inverse of :func:`straight_insertion`'s direction for a direction on
    the funnel's side (``direction . axis > 0``)."""
    axis, across, along = frame
    d = np.asarray(direction, dtype=np.float64)
    return np.array([np.arctan2(d @ across, d @ axis), np.arctan2(d @ along, d @ axis)])


def funnel_frame(task: DemonstrationTask) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The funnel's axis (target to edge, or to the start's tip when the task has no edge), and the unit vectors
    across the gap and along the edge, read back from the first and third collision planes."""
    axis = (task.edge if task.edge is not None else task.start[:3]) - task.target
    axis = axis / np.linalg.norm(axis)
    if len(task.planes) >= 3:
        across = task.planes[0, :3] + axis * (-(task.planes[0, :3] @ axis))
        along = task.planes[2, :3] + axis * (-(task.planes[2, :3] @ axis))
    else:
        across = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        along = np.cross(axis, across)
    across /= np.linalg.norm(across)
    along = along - across * (along @ across)
    along /= np.linalg.norm(along)
    return axis, across, along


def _rotate(quaternion: np.ndarray, vector: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(quaternion).apply(vector)
