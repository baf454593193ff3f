"""Shared fixtures: scenes with their robot (and cost model), built once per test session."""

from __future__ import annotations

import functools
import os
import signal

import pytest
from hypothesis import settings
from pliant import load_scene, registry
from pliant.interfaces import Context

# Local runs explore new examples every time; CI (CI=true) replays a fixed sequence, so that a
# submission's result does not depend on the draw.  Failures found locally are kept as explicit tests.
settings.register_profile("pliant", deadline=None, print_blob=True)
settings.register_profile("ci", deadline=None, print_blob=True, derandomize=True)
settings.load_profile("ci" if os.environ.get("CI") else "pliant")


@functools.cache
def _context(scene: str, cost: str | None = None) -> Context:
    ctx = Context(scene=load_scene(scene))
    ctx.robot = registry.create("robot", "rigid", ctx)
    if cost:
        ctx.cost = registry.create("cost", cost, ctx)
    return ctx


@pytest.fixture
def scene_context():
    """``scene_context(name, cost=None)`` -> a cached Context with the rigid robot (and the cost model)."""
    return _context


@pytest.fixture
def python_sigint():
    """Python's own Ctrl-C handler for the test, whatever this process inherited (a process started in the
    background by a non-interactive shell inherits SIGINT ignored, and Python then leaves it ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)
