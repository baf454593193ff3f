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

import numpy as np
from pliant.api import ConfigError


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
        from pliant import api
        from pliant.api import Context

        if step is not None and not (np.isfinite(step) and step > 0):
            raise ConfigError("must be a positive number of metric units", field="step", value=step)
        self.scene = scene
        context = Context(scene=unit_sensitivity_scene(scene))
        context.robot = api.registry.create("robot", robot, context, **(robot_options or {}))
        context.cost = api.registry.create("cost", cost, context)
        self.context, self.robot, self.space, self.cost = context, context.robot, context.robot.space, context.cost
        self.names = list(self.cost.feature_names())
        self.step = float(step) if step is not None else scene.resolution / 2

    def states(self, path: np.ndarray) -> np.ndarray:
        """The configurations ``(m, d)`` a path ``(k, d)`` is measured at: every waypoint and, between two, evenly
        spaced configurations at most :attr:`step` apart (metric units of the robot's space)."""
        return self.path_states([path])[0]

    def path_states(self, paths) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`states` of many paths at once: ``(states (M, d), counts (n,))``, the states of path ``i`` being
        the ``counts[i]`` rows after those of the paths before it.  ``paths``: a list of ``(k_i, d)`` arrays or an
        array ``(n, k, d)``.  One distance and one interpolation call for every segment of every path; the rows
        equal :meth:`states` path by path (the same element-wise arithmetic)."""
        if isinstance(paths, np.ndarray) and paths.ndim == 3:
            n_paths, k, d = paths.shape
            lengths = np.full(n_paths, k, dtype=np.int64)
            flat = np.ascontiguousarray(paths, dtype=np.float64).reshape(n_paths * k, d)
        else:
            paths = [np.atleast_2d(np.asarray(p, dtype=np.float64)) for p in paths]
            lengths = np.array([len(p) for p in paths], dtype=np.int64)
            flat = np.concatenate(paths) if paths else np.zeros((0, self.space.dim))
        if len(lengths) == 0:
            return np.zeros((0, self.space.dim)), np.zeros(0, dtype=np.int64)
        ends = np.cumsum(lengths)
        some = lengths > 0                              # an empty path has no state
        first = np.zeros(len(flat), dtype=bool)         # each path's first waypoint: copied as it is
        first[(ends - lengths)[some]] = True
        opens = np.ones(len(flat), dtype=bool)          # waypoints a segment starts from (all but each path's last)
        opens[(ends - 1)[some]] = False
        a = np.flatnonzero(opens)
        pieces = np.zeros(len(flat), dtype=np.int64)    # interpolated states of the segment starting at each waypoint
        if len(a):
            distance = np.asarray(self.space.distance(flat[a], flat[a + 1]), dtype=np.float64)
            pieces[a] = np.maximum(1, np.ceil(distance / self.step).astype(np.int64))
        rows = first + pieces                           # output rows owed to each waypoint, in path order
        offset = np.cumsum(rows) - rows
        out = np.empty((int(rows.sum()), flat.shape[1]))
        out[offset[first]] = flat[first]
        if len(a):
            n = pieces[a]
            segment = np.repeat(a, n)
            j = np.arange(int(n.sum()), dtype=np.int64) - np.repeat(np.cumsum(n) - n, n)        # 0 .. n - 1
            count = np.repeat(n, n).astype(np.float64)
            t = (j + 1).astype(np.float64) / count
            where = np.repeat(offset[a] + first[a], n) + j
            out[where] = self.space.interpolate(flat[segment], flat[segment + 1], t[:, None])
        counts = np.zeros(len(lengths), dtype=np.int64)
        if some.any():
            counts[some] = np.add.reduceat(rows, (ends - lengths)[some])
        return out, counts

    def of_path(self, path: np.ndarray) -> np.ndarray:
        """``V(tau)`` ``(n_objects,)``; NaN when a configuration is infeasible (a rigid collision, outside the grid)."""
        return self.cost.breakdown(self.states(path)).sum(axis=0)

    def of_paths(self, paths) -> np.ndarray:
        """``(n_paths, n_objects)`` for a list (or array ``(n, k, d)``) of paths, all measured in one batch."""
        return self.of_states(*self.path_states(paths))

    def of_states(self, states: np.ndarray, counts: np.ndarray) -> np.ndarray:
        """``(n_paths, n_objects)`` from the states of many paths as :meth:`path_states` gives them: one call of
        the cost model's breakdown, summed path by path (NaN rows make their path's features NaN)."""
        counts = np.asarray(counts, dtype=np.int64)
        if len(counts) == 0:
            return np.zeros((0, len(self.names)))
        out = np.zeros((len(counts), len(self.names)))
        some = counts > 0
        if some.any():
            rows = self.cost.breakdown(states)
            out[some] = np.add.reduceat(rows, (np.cumsum(counts) - counts)[some], axis=0)
        return out

    def outline(self, q: np.ndarray) -> np.ndarray:
        """World positions ``(n, h, 3)`` of the robot's outline at configurations ``(n, d)``: for a rigid robot the
        vertices of its body points' convex hull, which satisfy every half-space constraint exactly when all body
        points do (a half-space is convex); for others every body point."""
        q = np.atleast_2d(q)
        placement = self.outline_placement(q)
        if placement is None:
            return self.robot.body_points(q)
        rot, pos, hull = placement
        return np.einsum("nij,hj->nhi", rot, hull) + pos[:, None, :]

    def outline_placement(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """For a rigid robot, what :meth:`outline` places: rotations ``(n, 3, 3)``, positions ``(n, 3)`` (m) of
        configurations ``(n, d)`` and the hull's vertices ``(h, 3)`` in the body frame (m); None for others."""
        placement = self.robot.rigid_placement(np.atleast_2d(q))
        if placement is None:
            return None
        rot, pos, local = placement
        if getattr(self, "_outline_of", (None,))[0] is not local:
            self._outline_of = (local, local[_hull_vertices(local)])
        return rot, pos, self._outline_of[1]

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
