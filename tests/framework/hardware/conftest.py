"""A three-joint arm's limits file and an emulated robot behind the real driver stack."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from pliant.hardware.limits import load_limits
from pliant.testing.memory_robot import MemoryDriver, MemoryRobot

LIMITS = """
robot = "test-arm"
command_rate = 200.0
command_timeout = 0.2
state_timeout = 0.1
max_state_rate = 5000.0
position_margin = 0.05
sources = ["made up for tests"]
[[joints]]
name = "a"
lower = -1.0
upper = 1.0
velocity = 1.0
acceleration = 4.0
jerk = 40.0
[[joints]]
name = "b"
lower = -2.0
upper = 2.0
velocity = 2.0
acceleration = 8.0
jerk = 80.0
[[joints]]
name = "c"
lower = -0.5
upper = 1.5
velocity = 0.5
acceleration = 2.0
jerk = 20.0
"""

_ids = itertools.count(1)


@pytest.fixture(scope="session")
def limits_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("limits") / "arm.toml"
    path.write_text(LIMITS)
    return path


@pytest.fixture(scope="session")
def limits(limits_file):
    return load_limits(limits_file)


@pytest.fixture
def robot_and_driver(limits_file, limits):
    """(MemoryRobot at rest at zero, an unconnected MemoryDriver for it); the robot is stopped afterwards."""
    robot = MemoryRobot(limits, np.zeros(3)).start()
    rid = next(_ids)
    MemoryDriver.robots[rid] = (robot, limits_file)
    # a 1 s watchdog: a loaded test machine (load 20) starved the robot's state thread past 0.1 s; the watchdog's
    # own tests stop the robot's states outright, which any deadline catches
    driver = MemoryDriver(robot_id=rid, state_timeout=1.0)
    yield robot, driver
    driver.close()
    robot.stop()
    MemoryDriver.robots.pop(rid, None)


@pytest.fixture(autouse=True)
def _realtime(frozen_heap):
    """Heartbeats, watchdogs and command streams run in threads of this process: no multi-100 ms collector pauses
    (see ``frozen_heap``)."""
