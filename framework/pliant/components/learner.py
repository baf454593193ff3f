"""The learner kind: fits a cost model's parameters from demonstrations (thesis ch. 4).
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Any

import numpy as np

from pliant.components.base import Component


class Learner(Component):
    """Fits parameters from data (demonstrations, action outcomes)."""

    kind = "learner"

    @abstractmethod
    def fit(self, data: Any, rng: np.random.Generator) -> dict[str, Any]:
        """Fit and return the learned parameters (names and units documented by the plugin)."""
