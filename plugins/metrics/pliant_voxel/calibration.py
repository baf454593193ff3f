"""Calibrating planner cost against measured deformation (thesis 3.3.2 and Table 3.1).

The thesis scales the planner's cost to measured deformation (pixels of a camera, or m^3 of
tetrahedral volume change in simulation) by the mean ratio of measured to planned deformation over
every point of the calibration paths, then reports each path's calibrated cost against its
measurement.  :func:`fit_calibration` does that and, as further estimates, the least-squares scale
through the origin, the ratio of totals, and a power law of the path total.

Why a power law: towing the 400-tetrahedron soft cube along the cube-wall paths in pybullet, the
measured volume change of a path grows sub-linearly with its voxel cost (exponent 0.47-0.58 on the
15 A* paths of ``pliant bench cube_wall_calibration``): a path that cuts the hole's corner overlaps
many voxels, but the soft cube's volume change saturates.  No single scale then fits both centred and
corner-cutting paths (25% mean error at best); ``measured = a * planned^b`` of the path totals does
(7-14% held out), so it is what :meth:`Calibration.apply_path` uses when fitted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import DimensionError


@dataclass
class Calibration:
    """A fitted scale from planner cost to measured deformation.

    scale: the thesis's estimate, mean of ``measured / planned`` over points with planned > 0.
    least_squares_scale: ``argmin_k sum (k planned - measured)^2`` over every point.
    total_scale: ``sum(measured) / sum(planned)`` over every point: the scale that makes the mean
        calibrated path cost equal the mean measured one (Table 3.1 compares those means).
    path_errors: per path, ``|scale * sum(planned) - sum(measured)| / sum(measured)`` (NaN when a path
        measured nothing).
    power_factor, power_exponent: ``a`` and ``b`` of ``sum(measured) = a sum(planned)^b`` over the paths,
        by least squares of the logarithms (needs two paths with different positive totals; NaN otherwise).
    """

    scale: float
    least_squares_scale: float
    path_errors: np.ndarray
    total_scale: float = float("nan")
    power_factor: float = float("nan")
    power_exponent: float = float("nan")

    @property
    def mean_error(self) -> float:
        """Mean relative error over the paths with a measurement."""
        finite = self.path_errors[np.isfinite(self.path_errors)]
        return float(finite.mean()) if finite.size else float("nan")

    def apply(self, planned_cost) -> np.ndarray:
        """Planner costs in the measurement's units."""
        return self.scale * np.asarray(planned_cost, dtype=np.float64)

    def apply_path(self, path_total) -> np.ndarray:
        """Calibrated path totals: the power law when fitted, else ``total_scale`` (measurement units)."""
        total = np.asarray(path_total, dtype=np.float64)
        if np.isfinite(self.power_factor) and np.isfinite(self.power_exponent):
            return self.power_factor * np.power(np.maximum(total, 0.0), self.power_exponent)
        return self.total_scale * total


def fit_calibration(planned: list, measured: list) -> Calibration:
    """Fit the scale from paired per-point data of several paths.

    ``planned[k]`` and ``measured[k]`` are arrays of equal length: the planner's state cost and the
    measured deformation at each point of path ``k``.
    """
    if len(planned) != len(measured) or not planned:
        raise DimensionError("planned and measured need one array per path, the same number of paths",
                             field="planned/measured", value=(len(planned), len(measured)))
    p_all, m_all = [], []
    for k, (p, m) in enumerate(zip(planned, measured)):
        p = np.asarray(p, dtype=np.float64)
        m = np.asarray(m, dtype=np.float64)
        if p.shape != m.shape or p.ndim != 1:
            raise DimensionError("each path's planned and measured arrays must be 1-D of equal length",
                                 field=f"path[{k}]", value=(p.shape, m.shape))
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(m))) or np.any(p < 0):
            raise DimensionError("costs must be finite and non-negative", field=f"path[{k}]")
        p_all.append(p)
        m_all.append(m)
    p_cat, m_cat = np.concatenate(p_all), np.concatenate(m_all)
    touched = p_cat > 0
    if not touched.any():
        raise DimensionError("no point has a positive planned cost: nothing to calibrate", field="planned")
    scale = float(np.mean(m_cat[touched] / p_cat[touched]))
    ls = float(np.dot(p_cat, m_cat) / np.dot(p_cat, p_cat))
    errors = np.array([abs(scale * p.sum() - m.sum()) / m.sum() if m.sum() > 0 else np.nan
                       for p, m in zip(p_all, m_all)])
    factor, exponent = float("nan"), float("nan")
    totals = np.array([(p.sum(), m.sum()) for p, m in zip(p_all, m_all)])
    usable = (totals[:, 0] > 0) & (totals[:, 1] > 0)
    if usable.sum() >= 2 and np.ptp(np.log(totals[usable, 0])) > 0:
        exponent, log_factor = np.polyfit(np.log(totals[usable, 0]), np.log(totals[usable, 1]), 1)
        factor, exponent = float(np.exp(log_factor)), float(exponent)
    return Calibration(scale, ls, errors, float(m_cat.sum() / p_cat.sum()), factor, exponent)
