"""The controller kind (a control law toward a target) and the check of its commands.
"""

from __future__ import annotations

import functools
from abc import abstractmethod
from typing import Any

import numpy as np

from pliant.components.base import Component
from pliant.components.checks import WRAPPED, _space_of, check_duration, check_vector


def checked_command(method):
    """Wrap a controller's ``command(q, target, dt)``: finite configurations of the space's size and a finite
    positive ``dt`` -- a NaN in means an error, not a NaN command out.  (No bounds check: a measured configuration
    may sit a hair outside a joint limit.)"""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def command(self, q, target, dt, *args, **kwargs):
        dt = check_duration(dt)
        space = _space_of(self)
        size = space.dim if space is not None else np.size(q)
        q = check_vector(q, size, field="q")
        target = check_vector(target, size, field="target")
        return method(self, q, target, dt, *args, **kwargs)

    setattr(command, WRAPPED, True)
    return command


class Controller(Component):
    """Turns (current configuration, target) into a velocity command (thesis app. C)."""

    kind = "controller"

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # the core checks command's configurations and dt before the plugin's code runs
        super().__init_subclass__(**kwargs)
        if "command" in cls.__dict__:
            cls.command = checked_command(cls.__dict__["command"])

    def reset(self) -> None:
        """Forget internal state (e.g. the stuck-detection window) before a new motion."""

    @abstractmethod
    def command(self, q: np.ndarray, target: np.ndarray, dt: float) -> np.ndarray:
        """Tangent velocity ``(t,)`` to apply for ``dt`` seconds toward ``target``."""

    def reached(self, q: np.ndarray, target: np.ndarray) -> bool:
        """Whether ``q`` is close enough to ``target`` to move on."""
        return False
