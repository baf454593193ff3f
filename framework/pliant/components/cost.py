"""The cost kind: the cost of a configuration (the deformation cost of thesis ch. 3) and its gradient.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import ClassVar

import numpy as np

from pliant.components.base import Component


class CostModel(Component):
    """A state cost over configurations (e.g. the cost of deformation, thesis eq. 3.1).

    ``cost`` may return NaN for infeasible states, where the method defines it (documented by the
    plugin).  Costs are dimensionless unless the plugin states units.
    """

    kind = "cost"
    #: whether :meth:`gradient` is implemented
    has_gradient: ClassVar[bool] = False

    @abstractmethod
    def cost(self, q: np.ndarray) -> np.ndarray:
        """State cost ``(n,)`` of configurations ``(n, d)``; equal to ``n`` single calls."""

    def gradient(self, q: np.ndarray) -> np.ndarray:
        """Tangent-space gradient ``(n, t)`` of :meth:`cost` (thesis eq. 3.2)."""
        raise NotImplementedError(f"{type(self).__name__} has no gradient")

    def breakdown(self, q: np.ndarray) -> np.ndarray:
        """Per-feature costs ``(n, k)`` summing to :meth:`cost` (e.g. one column per object)."""
        return self.cost(q)[:, None]

    def feature_names(self) -> list[str]:
        """Names of the :meth:`breakdown` columns."""
        return ["cost"]

    def is_valid(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: feasible where the cost is finite."""
        return np.isfinite(self.cost(q))

    def translation_costs(self, origin: np.ndarray, spacing: float, shape: tuple[int, ...],
                          base: np.ndarray | None = None) -> np.ndarray:
        """State costs of every pure translation on a lattice, ``shape`` ``(nx, ny, nz)``.

        Configuration ``(i, j, k)`` is ``origin + spacing * (i, j, k)`` in the first three
        coordinates (``base`` supplies the remaining coordinates, e.g. a fixed orientation).  The
        default evaluates :meth:`cost` in batches; cost models may override it with something
        faster (the voxel model correlates the robot with the environment, thesis 3.2.3).
        """
        origin = np.asarray(origin, dtype=np.float64)
        axes = [origin[i] + spacing * np.arange(n) for i, n in enumerate(shape)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(shape))
        if base is not None:
            base = np.asarray(base, dtype=np.float64)
            grid = np.concatenate([grid, np.broadcast_to(base[len(shape):], (len(grid), base.size - len(shape)))],
                                  axis=1)
        out = np.concatenate([self.cost(grid[s:s + 8192]) for s in range(0, len(grid), 8192)])
        return out.reshape(shape)
