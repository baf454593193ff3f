"""The base of every pluggable component (:class:`Component`): options, binding to a context, requirements.
"""

from __future__ import annotations

from abc import ABC
from typing import Any, ClassVar

import numpy as np

from pliant.components.context import Context
from pliant.errors import (
    DimensionError,
    PlanningError,
)
from pliant.options import NoOptions, build_options
from pliant.spaces import Space

KINDS = ("simulator", "robot", "controller", "planner", "metric", "cost", "learner", "driver")


class Component(ABC):  # noqa: B024 - ABCMeta enforces the abstract methods of the kinds below
    """Base of every pluggable component.

    Subclasses set :attr:`Options` to a frozen dataclass of documented options; the constructor
    validates keyword options against it (unknown names and bad values raise
    :class:`~pliant.errors.ConfigError`).  :meth:`bind` receives the pipeline's :class:`Context`.
    """

    kind: ClassVar[str] = ""
    Options: ClassVar[type] = NoOptions
    #: a bundled scene in which the conformance kit exercises this component (None: the default)
    example_scene: ClassVar[str | None] = None
    #: other components the conformance kit should create alongside, by kind (``{"cost": "voxel"}``)
    example_components: ClassVar[dict[str, str]] = {}

    def __init__(self, options: Any = None, *, source: str = "<options>", **kwargs: Any) -> None:
        if options is not None and kwargs:
            raise TypeError("pass either an Options instance or keyword options, not both")
        if isinstance(options, self.Options):
            self.options = options
        else:
            self.options = build_options(self.Options, options if options is not None else kwargs,
                                         source=source, prefix=self.kind)
        self.context: Context | None = None

    def bind(self, context: Context) -> None:
        """Attach to a pipeline's context.  Override to prepare (and call ``super().bind``)."""
        self.context = context

    def require(self, attribute: str):
        """The context's ``attribute`` (``"scene"``, ``"robot"``...), or a clear error if absent."""
        value = getattr(self.context, attribute, None) if self.context is not None else None
        if value is None:
            raise PlanningError(f"{type(self).__name__} needs a {attribute}; bind it to a context that has one",
                                field=attribute)
        return value


def check_batch(q: Any, space: Space, field: str = "configurations") -> tuple[np.ndarray, bool]:
    """``q`` as ``(n, d)`` float64 plus whether the input was a single ``(d,)`` configuration.

    Raises :class:`DimensionError` for a wrong width or non-finite entries.
    """
    arr = np.asarray(q, dtype=np.float64)
    single = arr.ndim == 1
    arr = np.atleast_2d(arr)
    if arr.ndim != 2 or arr.shape[1] != space.dim:
        raise DimensionError(f"must be (n, {space.dim}) or ({space.dim},) for this {space.kind} space",
                             field=field, value=list(np.shape(q)))
    if not np.all(np.isfinite(arr)):
        raise DimensionError("must be finite", field=field, value=np.asarray(q).tolist())
    return arr, single
