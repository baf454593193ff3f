"""The driver session protects its own timing (issue 31, item 6): while a command stream runs, the heap is frozen
and the thread switch interval is short; both are put back when the last stream closes, also after a failed start,
and a heap the caller froze stays the caller's."""

from __future__ import annotations

import gc
import itertools
import sys

import numpy as np
import pytest
from pliant.errors import EmergencyStop
from pliant.hardware.stream import REALTIME, SWITCH_INTERVAL, RealTimeGuard


@pytest.fixture
def unfrozen():
    """An unfrozen heap and a distinctive switch interval for the test (the autouse ``frozen_heap`` froze it)."""
    gc.unfreeze()
    previous = sys.getswitchinterval()
    sys.setswitchinterval(0.004)
    yield
    sys.setswitchinterval(previous)
    gc.freeze()                     # what frozen_heap expects to unfreeze


def test_a_session_freezes_the_heap_and_shortens_the_switch_interval_while_it_streams(unfrozen, robot_and_driver):
    robot, driver = robot_and_driver
    assert gc.get_freeze_count() == 0 and not REALTIME.active
    with driver:
        assert REALTIME.active and gc.isenabled()
        assert gc.get_freeze_count() > 0                  # the heap made before connecting is out of reach
        assert sys.getswitchinterval() == pytest.approx(SWITCH_INTERVAL)
        garbage = [[] for _ in range(100)]
        for a, b in itertools.pairwise(garbage):
            a.append(b)
            b.append(a)                                   # reference cycles: only the collector frees them
        del garbage, a, b
        before = REALTIME.pauses
        assert gc.collect() >= 100                        # the collector still runs and frees what streaming made
        assert REALTIME.pauses > before                   # and its pauses are timed
        driver.move_to([0.1, -0.1, 0.2])
        timing = driver.check()
        assert timing["gc_longest_pause"] >= 0 and timing["gc_frozen"] > 0 and timing["overruns"] >= 0
        assert timing["longest_write_gap"] > 0
    assert not REALTIME.active
    assert gc.get_freeze_count() == 0                     # restored on close
    assert sys.getswitchinterval() == pytest.approx(0.004)
    assert robot.violations() == []


def test_a_failed_start_restores_the_process(unfrozen, robot_and_driver):
    robot, driver = robot_and_driver
    robot.estop = True
    with pytest.raises(EmergencyStop):
        driver.connect()
    assert not REALTIME.active and gc.get_freeze_count() == 0
    assert sys.getswitchinterval() == pytest.approx(0.004)


def test_the_last_of_nested_users_restores_and_a_callers_freeze_is_kept(unfrozen):
    guard = RealTimeGuard()
    guard.acquire()
    guard.acquire()
    guard.release()
    assert guard.active and gc.get_freeze_count() > 0 and sys.getswitchinterval() == pytest.approx(SWITCH_INTERVAL)
    guard.release()
    guard.release()                                       # one release too many changes nothing
    assert not guard.active and gc.get_freeze_count() == 0 and sys.getswitchinterval() == pytest.approx(0.004)

    kept = np.zeros(3)                                    # noqa: F841 -- something the caller froze
    gc.freeze()
    frozen = gc.get_freeze_count()
    guard.acquire()
    guard.release()
    assert gc.get_freeze_count() >= frozen                # the caller's freeze is the caller's to undo
