"""Shared fixtures: scenes with their robot (and cost model), built once per test session."""

from __future__ import annotations

import functools
import gc
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


@pytest.fixture(scope="session", autouse=True)
def pliant_cache_dir(tmp_path_factory):
    """The scene-preprocessing cache (:mod:`pliant.cache`) of this test session: a temporary directory, never
    ``~/.cache/pliant``; shared by the session's xdist workers and inherited by the processes tests start."""
    base = tmp_path_factory.getbasetemp()
    path = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "pliant-cache"
    path.mkdir(exist_ok=True)
    previous = os.environ.get("PLIANT_CACHE_DIR")
    os.environ["PLIANT_CACHE_DIR"] = str(path)
    yield path
    if previous is None:
        os.environ.pop("PLIANT_CACHE_DIR", None)
    else:
        os.environ["PLIANT_CACHE_DIR"] = previous


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


@pytest.fixture
def frozen_heap():
    """The heap that earlier tests left is frozen for this test (:func:`gc.freeze`): a full collection then walks
    only what this test allocates.  Without it, a generation-2 collection of a heap grown by a thousand earlier
    tests stalls every thread for 0.2-0.9 s (measured over the first half of ``make test`` at load 5), longer than
    the 0.1-0.25 s heartbeats and watchdogs that the driver tests exercise on loopback.  Real-time tests use it;
    the collector itself is not turned off."""
    gc.freeze()
    yield
    gc.unfreeze()
