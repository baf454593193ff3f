"""A path metric: length in the space's metric, the largest step, and the number of waypoints."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import Path, PathMetric, PlanningProblem, option


@dataclass(frozen=True)
class PathLengthOptions:
    """Options of :class:`PathLength`."""

    scale: float = option(1.0, "multiplier applied to lengths (e.g. 1000 for millimetres)", minimum=0.0)


class PathLength(PathMetric):
    """Scores a path by its length (space metric units x ``scale``) and its largest step."""

    Options = PathLengthOptions

    def evaluate(self, path: Path, problem: PlanningProblem, rng: np.random.Generator) -> dict[str, float]:
        q = path.configurations
        steps = problem.space.distance(q[:-1], q[1:]) if len(q) > 1 else np.zeros(1)
        return {"length": float(np.sum(steps)) * self.options.scale,
                "largest_step": float(np.max(steps)) * self.options.scale,
                "waypoints": float(len(q))}
