"""Per-object deformation features of a path (thesis 4.2): ``V_i(tau) = sum_k V_i(tau_k)``.

``V_i(tau_k)`` is the volume of object ``i`` the robot occupies at the ``k``-th configuration of the path,
discretised at a fixed spacing so that paths of different lengths are measured alike.  It is read from the cost
model's per-object breakdown (the ``cost`` kind's :meth:`~pliant.interfaces.CostModel.breakdown`) over a copy of
the scene whose sensitivities are all 1, so with deformability 1 objects and a rigid robot it counts robot body
points inside each object: the unit is "robot points" (one point stands for one voxel, ``resolution**3`` m^3).
The cost of a path under sensitivities ``S`` is then ``S . V`` (the chapter's ``C(tau)``).
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
from pliant.errors import ConfigError


def unit_sensitivity_scene(scene):
    """``scene`` with every object's sensitivity set to 1 (deformabilities kept): what the features are read from,
    so that no learner ever sees the scene's own sensitivities."""
    objects = [dataclasses.replace(o, material=dataclasses.replace(o.material, sensitivity=1.0))
               for o in scene.objects]
    return dataclasses.replace(scene, objects=objects)


class DeformationFeatures:
    """Features ``(n_objects,)`` of paths in ``scene`` for ``robot`` (a registered robot name and options).

    ``step``: spacing of the configurations a path is measured at, in the robot space's metric (default: half the
    scene's resolution).  ``cost``: the registered cost model to read the breakdown from (default ``voxel``).
    """

    def __init__(self, scene, *, robot: str = "rigid", robot_options: dict | None = None, cost: str = "voxel",
                 step: float | None = None) -> None:
        import pliant
        from pliant.interfaces import Context

        if step is not None and not (np.isfinite(step) and step > 0):
            raise ConfigError("must be a positive number of metric units", field="step", value=step)
        self.scene = scene
        context = Context(scene=unit_sensitivity_scene(scene))
        context.robot = pliant.registry.create("robot", robot, context, **(robot_options or {}))
        context.cost = pliant.registry.create("cost", cost, context)
        self.context, self.robot, self.space, self.cost = context, context.robot, context.robot.space, context.cost
        self.names = list(self.cost.feature_names())
        self.step = float(step) if step is not None else scene.resolution / 2

    def states(self, path: np.ndarray) -> np.ndarray:
        """The configurations ``(m, d)`` a path ``(k, d)`` is measured at: every waypoint and, between two, evenly
        spaced configurations at most :attr:`step` apart."""
        path = np.atleast_2d(np.asarray(path, dtype=np.float64))
        pieces = [path[:1]]
        for a, b in itertools.pairwise(path):
            n = max(1, int(np.ceil(float(self.space.distance(a, b)) / self.step)))
            t = np.arange(1, n + 1, dtype=np.float64)[:, None] / n
            pieces.append(self.space.interpolate(np.broadcast_to(a, (n, len(a))), np.broadcast_to(b, (n, len(b))), t))
        return np.concatenate(pieces)

    def of_path(self, path: np.ndarray) -> np.ndarray:
        """``V(tau)`` ``(n_objects,)``; NaN when a configuration is infeasible (a rigid collision, outside the grid)."""
        return self.cost.breakdown(self.states(path)).sum(axis=0)

    def of_paths(self, paths) -> np.ndarray:
        """``(n_paths, n_objects)`` for a list (or array) of paths, all measured in one batch."""
        states = [self.states(p) for p in paths]
        if not states:
            return np.zeros((0, len(self.names)))
        rows = self.cost.breakdown(np.concatenate(states))
        ends = np.cumsum([len(s) for s in states])[:-1]
        return np.stack([part.sum(axis=0) for part in np.split(rows, ends)])

    def outline(self, q: np.ndarray) -> np.ndarray:
        """World positions ``(n, h, 3)`` of the robot's outline at configurations ``(n, d)``: for a rigid robot the
        vertices of its body points' convex hull, which satisfy every half-space constraint exactly when all body
        points do (a half-space is convex); for others every body point."""
        q = np.atleast_2d(q)
        placement = self.robot.rigid_placement(q)
        if placement is None:
            return self.robot.body_points(q)
        rot, pos, local = placement
        if getattr(self, "_outline_of", (None,))[0] is not local:
            self._outline_of = (local, local[_hull_vertices(local)])
        return np.einsum("nij,hj->nhi", rot, self._outline_of[1]) + pos[:, None, :]

    def sensitivity_vector(self, sensitivities: dict[str, float]) -> np.ndarray:
        """``S`` ``(n_objects,)`` in feature order from ``{object name: sensitivity}`` (every object named)."""
        missing = [n for n in self.names if n not in sensitivities]
        if missing:
            raise ConfigError(f"no sensitivity for object(s) {missing}", field="sensitivities",
                              value=sorted(sensitivities))
        return np.array([float(sensitivities[n]) for n in self.names])


def _hull_vertices(points: np.ndarray) -> np.ndarray:
    """Indices of the convex hull's vertices among ``points`` ``(m, 3)``; every index when the points are flat or
    too few for Qhull (a planar robot's single layer)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return np.sort(ConvexHull(points).vertices)
    except (QhullError, ValueError):
        return np.arange(len(points))


def true_sensitivities(scene) -> dict[str, float]:
    """The scene's own per-object sensitivities: the hidden ground truth that only the simulated expert and the
    scoring of planned paths may read."""
    return {o.name: float(o.material.sensitivity) for o in scene.objects}
