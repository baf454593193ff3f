"""Argument checks every kind shares: a random generator, a duration, a vector, a configuration batch's space.

The kinds' own checks (a planner's result, a simulator's starts, a controller's command, a metric's path) live
with each kind (:mod:`pliant.components.planner` ...); the kinds wrap their subclasses' methods with them when the
subclass is defined (``__init_subclass__``), so a plugin author writes the method as usual.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pliant.errors import (
    DimensionError,
    PlanningError,
    SimulationError,
)

#: the attribute that marks a method as already wrapped (a subclass of a subclass is not wrapped twice)
WRAPPED = "__pliant_checked__"


def check_rng(rng: Any, *, field: str = "rng") -> np.random.Generator:
    """``rng`` if it is a :class:`numpy.random.Generator`, else :class:`~pliant.errors.PlanningError` (randomness is
    explicit: ``numpy.random.default_rng(seed)``, never a bare seed or the legacy global state)."""
    if not isinstance(rng, np.random.Generator):
        raise PlanningError("must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed))", field=field,
                            value=rng)
    return rng


def check_duration(dt: Any, *, field: str = "dt") -> float:
    """``dt`` (s) as a float if finite and positive, else :class:`~pliant.errors.SimulationError`."""
    try:
        value = float(dt)
    except (TypeError, ValueError):
        raise SimulationError("must be a number of seconds", field=field, value=dt) from None
    if not math.isfinite(value) or value <= 0.0:
        raise SimulationError("must be a finite positive number of seconds", field=field, value=dt)
    return value


def check_vector(values: Any, size: int, *, field: str) -> np.ndarray:
    """``values`` as a finite float64 ``(size,)`` array, else :class:`~pliant.errors.DimensionError`."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise DimensionError(f"must be {size} numbers", field=field, value=values) from None
    if arr.shape != (size,):
        raise DimensionError(f"must be {size} numbers (shape ({size},))", field=field, value=np.shape(values))
    if not np.all(np.isfinite(arr)):
        raise DimensionError("must be finite", field=field, value=arr.tolist())
    return arr


def _space_of(component) -> Any:
    context = getattr(component, "context", None)
    if context is None or getattr(context, "scene", None) is None:
        return None
    try:
        return context.space
    except Exception:  # a context without a robot yet: nothing to check against
        return None


def space_label(space) -> str:
    """``"r3"`` for a 3-D real vector space (``"r<d>"`` for others), else the space's kind (``"se2"``...)."""
    return f"r{space.dim}" if space.kind == "rn" else space.kind
