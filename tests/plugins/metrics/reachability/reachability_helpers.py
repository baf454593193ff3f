"""Shared contexts of the reachable-volume metric tests: se2-through-passage with the kinematic simulator."""

import functools

import numpy as np
import pliant
from pliant.interfaces import Context

PASSAGE_SIMULATOR = {"kp": 1.0, "velocity_limit": 0.1, "angular_velocity_limit": 0.25, "frequency": 10.0}


@functools.lru_cache(maxsize=4)
def _passage(noise: str = "none", alpha: float = 0.0) -> Context:
    context = Context(scene=pliant.load_scene("se2-through-passage"))
    context.robot = pliant.registry.create("robot", "rigid", context)
    options = dict(PASSAGE_SIMULATOR)
    if noise != "none":
        options.update(noise=noise, noise_linear=alpha, noise_angular=alpha / 4)
    context.simulator = pliant.registry.create("simulator", "kinematic", context, **options)
    return context


def passage() -> Context:
    """se2-through-passage, the L-block, the kinematic simulator without noise (cached: treat as read-only)."""
    return _passage()


def noisy_passage() -> Context:
    """The same with eq. 6.14's noise at alpha = 0.125."""
    return _passage("floor", 0.125)


def metric(context, name="reachable-volume", **options):
    return pliant.registry.create("metric", name, context, **options)


START = np.array([0.2375, 0.12, 0.0])
GOAL = np.array([0.2375, 0.42, 0.0])
