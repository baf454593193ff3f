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


# --- the suite on several cores (``make test``: ``pytest -n 2 --dist loadgroup``; docs/testing.md) -------------------

#: tests that must share one pytest-xdist worker, by path prefix -> group: the ROS 1 tests share the session's ROS
#: master (one per worker otherwise) and their peers' real-time loops; the Ray tests start a two-node cluster of
#: their own on this machine (two at once would take four processes' ports and CPUs); the viewer's browser test writes
#: under out/viewer-test and runs a Chromium.  Everything else is safe in parallel: free loopback ports, a private
#: virtual CAN channel per test, tmp_path directories, and an atomic, locked scene cache shared by the workers.
XDIST_GROUPS = {
    "tests/plugins/drivers/ros1/": "ros1",
    "tests/framework/experiments/test_executor_ray.py": "ray",
    "tests/plugins/reports/viewer/test_viewer_browser.py": "browser",
}
#: tests that run threads or processes against wall-clock deadlines (heartbeats, state watchdogs, command streams,
#: a browser's frames), by path prefix: marked ``realtime``, and ``make test`` runs them in a
#: phase of their own, one at a time at normal priority, beside the CPU-bound tests at nice 19
#: (``tests/run_phases.py``), so that those cannot starve them (on two cores under two busy workers of the same
#: priority, threads stalled 0.3 s: a drive's heartbeat consumer and a 0.25 s state watchdog fired at connection).
#: A test elsewhere that needs this says ``@pytest.mark.realtime``.
REALTIME = (
    "tests/plugins/drivers/ros1/test_ros1_e2e.py",
    "tests/plugins/drivers/ros1/test_ros1_drivers.py",
    "tests/plugins/drivers/ros1/test_ros1_demo.py",
    "tests/plugins/drivers/ros1/test_ros1_deaths.py",
    "tests/plugins/drivers/ros1/test_ros1_master.py",
    "tests/plugins/drivers/ros2/",
    "tests/plugins/drivers/canopen/test_canopen_driver.py",
    "tests/plugins/drivers/canopen/test_canopen_e2e.py",
    "tests/plugins/drivers/canopen/test_canopen_heartbeat.py",
    "tests/framework/hardware/test_stream.py",
    "tests/framework/hardware/test_realtime.py",
    "tests/e2e/test_driver_world.py",
    "tests/plugins/reports/viewer/test_viewer_browser.py",
)
#: modules whose quick tests share a module-level cache (functools.cache) worth building once: kept on one worker
#: (their slow tests, which build their own, spread)
XDIST_SHARED_MODULES = ("tests/e2e/test_robot_pipelines.py",)


def _xdist_group(item) -> str | None:
    """The group of a test under ``--dist loadgroup``: a serial group above, else its module when it shares
    something with the module's other tests (a module-, class- or package-scoped fixture, or a module-level cache
    of ``XDIST_SHARED_MODULES``), else none (the test goes to whichever worker is free)."""
    path = item.nodeid.split("::")[0]
    for prefix, group in XDIST_GROUPS.items():
        if path.startswith(prefix):
            return group
    if path in XDIST_SHARED_MODULES and item.get_closest_marker("slow") is None:
        return path
    info = getattr(item, "_fixtureinfo", None)
    scopes = {getattr(d, "scope", "function") for defs in (info.name2fixturedefs.values() if info else ())
              for d in defs}
    return path if scopes & {"module", "class", "package"} else None


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Mark the tests under :data:`REALTIME` ``realtime``.  Under pytest-xdist also: put each test in its group
    (:func:`_xdist_group`, unless it names one with ``@pytest.mark.xdist_group``), and start the slow tests first so
    that no long test is left for the end while the other worker idles (``--no-loadscope-reorder`` keeps this
    order)."""
    for item in items:
        if item.nodeid.startswith(REALTIME):
            item.add_marker(pytest.mark.realtime)
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            group = _xdist_group(item)
            if group is not None:
                item.add_marker(pytest.mark.xdist_group(group))
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


#: pytest-xdist groups a test by appending ``@<group>`` to its node id; pytest 9.2's node ids no longer take it, and
#: pytest-xdist 3.8 (the latest) then spreads every group over the workers without a word (pytest-xdist#1386)
_BROKEN_GROUPS = ("9.2", "3.9")


def pytest_configure(config):
    """BLAS on one thread in every test process, as the ``pliant`` command runs (``pin_threads``: OpenBLAS's
    threads spin between the suite's small products and take the other worker's core; the user's
    ``OPENBLAS_NUM_THREADS`` and the like win).  Refuse ``--dist loadgroup`` with a pytest and pytest-xdist that
    ignore ``xdist_group`` (above): shared fixtures and reproduction records would be built on every worker and the
    serial groups (the Ray cluster) run side by side.  pyproject.toml's test extra pins pytest below 9.2."""
    from pliant.experiments.executor import pin_threads

    pin_threads(1)
    if os.environ.get("PYTEST_XDIST_WORKER") or config.getoption("dist", "no") != "loadgroup":
        return
    import xdist
    from packaging.version import Version

    if Version(pytest.__version__) >= Version(_BROKEN_GROUPS[0] + ".dev0") and \
            Version(xdist.__version__) < Version(_BROKEN_GROUPS[1]):
        raise pytest.UsageError(
            f"pytest {pytest.__version__} with pytest-xdist {xdist.__version__} ignores xdist_group under --dist "
            "loadgroup (pytest-xdist#1386): install the test extra's versions (make install: pytest < 9.2)")


def pytest_collection_finish(session):
    """The same, found in a worker whatever the versions: a grouped test whose node id lacks its ``@<group>``."""
    if not (os.environ.get("PYTEST_XDIST_WORKER") and session.config.getvalue("loadgroup")):
        return
    lost = [item.nodeid for item in session.items
            if item.get_closest_marker("xdist_group") is not None and "@" not in item.nodeid.rpartition("]")[2]
            .rpartition("::")[2]]
    if lost:
        raise pytest.UsageError(f"pytest-xdist's groups are not in effect: {lost[0]} lacks its '@group' suffix")
