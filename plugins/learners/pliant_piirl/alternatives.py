"""Straight insertions of a demonstration's own task: the alternatives the learner compares it with, besides its
local samples (docs/plugins/piirl.md, "Alternatives").

PIIRL's samples (:mod:`pliant_piirl.sampling`) are smooth perturbations of the demonstration: they say which way
is better *near* it, not whether another way into the same target would have been cheaper.  A near-optimal
demonstrator's path is cheaper than every one of them under sensitivity ratios far from its own (session 34: the
recovery's overshoot made every demonstration cheaper than every sample), and only the straight insertions it
passed over exclude those ratios.  The learner knows the task (the start, the target and the funnel's collision
planes), so it can draw those insertions itself: the probe turned outside to a direction ``d`` and slid along it
onto the target (:func:`~pliant_piirl.expert.straight_insertion`, the simulated expert's family).

:func:`straight_alternatives` measures a ``grid x (grid // 2 | 1)`` lattice of tilts over the funnel's openings
(``across_angle`` across the gap, ``along_angle`` along the edge) and a ``5 x 3`` lattice one coarse step around
the demonstration's own direction (the body z axis of its last configuration), and returns the features of those
that keep the probe inside the task's planes and have finite features.  They need a probe in SE(3) (a
configuration ``(x, y, z, qx, qy, qz, qw)``); for any other space there are none.
"""

from __future__ import annotations

import numpy as np

from pliant_piirl.demonstration import Demonstration
from pliant_piirl.expert import ExpertOptions, funnel_frame, straight_insertion, tilt_axes, tilt_of

#: the fine lattice around the demonstration's own direction: points across the gap, along the edge (one coarse
#: step either way)
AROUND = (5, 3)


def straight_alternatives(sampler, demonstration: Demonstration, grid: int,
                          options: ExpertOptions | None = None) -> np.ndarray:
    """Features ``(m, n_objects)`` of the valid straight insertions of ``demonstration``'s task: the coarse lattice
    of ``grid`` tilts across the gap (``grid // 2 | 1`` along the edge) and the :data:`AROUND` lattice around the
    demonstration's own direction.  ``sampler``: the fit's :class:`~pliant_piirl.sampling.PathSampler` (its robot,
    tip and funnel check); ``options``: the funnel openings searched and the insertion length (the simulated
    expert's).  ``grid`` 0, or a robot whose space is not SE(3), gives none."""
    n = len(sampler.features.names)
    if grid <= 0 or sampler.space.tangent_dim != 6 or np.shape(demonstration.path)[1] != 7:
        return np.zeros((0, n))
    o = options or ExpertOptions()
    task = demonstration.task
    frame = funnel_frame(task)
    alphas, betas = tilt_axes(grid, o)
    tilts = [(a, b) for a in alphas for b in betas]
    rot, _, _ = sampler.robot.rigid_placement(np.asarray(demonstration.path, dtype=np.float64)[-1:])
    own = tilt_of(rot[0][:, 2], frame)
    step_a = alphas[1] - alphas[0] if len(alphas) > 1 else 0.0
    step_b = betas[1] - betas[0] if len(betas) > 1 else 0.0
    for da in np.linspace(-step_a, step_a, AROUND[0]):
        for db in np.linspace(-step_b, step_b, AROUND[1]):
            if da or db:
                tilts.append((float(np.clip(own[0] + da, -o.across_angle, o.across_angle)),
                              float(np.clip(own[1] + db, -o.along_angle, o.along_angle))))
    paths = [straight_insertion(task, t, frame, sampler.tip, o.insertion) for t in tilts]
    return sampler.valid_with_features(paths, task)[1]
