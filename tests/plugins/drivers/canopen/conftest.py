"""Fixtures of the CANopen driver tests: a private virtual CAN channel per test, the peer drives on it, drivers
that are always shut down, and a 3-joint arm (joint map + limits) for quick unit tests."""

from __future__ import annotations

import uuid

import pytest
from pliant_canopen.driver import CanopenDriver
from pliant_canopen.testing.peer import CanopenPeer

THREE_JOINT_LIMITS = """robot = "test-arm"
command_rate = 100.0
state_timeout = 0.1
max_state_rate = 1000.0
position_margin = 0.02
sources = ["test values"]
[[joints]]
name = "shoulder"
lower = -2.0
upper = 2.0
velocity = 1.0
acceleration = 4.0
jerk = 40.0
[[joints]]
name = "elbow"
lower = -1.5
upper = 2.5
velocity = 1.5
acceleration = 6.0
jerk = 60.0
[[joints]]
name = "wrist"
lower = -3.0
upper = 3.0
velocity = 2.0
acceleration = 8.0
jerk = 80.0
"""

THREE_JOINT_MAP = """robot = "test-arm"
limits = "limits.toml"
[[joints]]
name = "shoulder"
node = 11
counts_per_radian = 10000.0
[[joints]]
name = "elbow"
node = 12
encoder_resolution = 4096
gear_ratio = 100.0
direction = -1
offset = 0.5
[[joints]]
name = "wrist"
node = 13
counts_per_radian = 20000.0
velocity_factor = 9.549296585513721   # rpm per rad/s
"""


@pytest.fixture
def channel() -> str:
    """A virtual CAN channel of this test only (the virtual interface connects the buses of one process)."""
    return f"pliant-canopen-test-{uuid.uuid4().hex[:10]}"


@pytest.fixture
def arm3(tmp_path):
    """The path of a 3-joint joint map (nodes 11-13; scaling by counts_per_radian, encoder and gear, rpm)."""
    (tmp_path / "limits.toml").write_text(THREE_JOINT_LIMITS)
    path = tmp_path / "arm.toml"
    path.write_text(THREE_JOINT_MAP)
    return path


@pytest.fixture
def make_peer(channel):
    """``make_peer(**kwargs)`` -> a started :class:`CanopenPeer` on the test's channel (stopped afterwards)."""
    peers = []

    def make(joint_map=None, **kwargs) -> CanopenPeer:
        peer = CanopenPeer(joint_map, channel=channel, **kwargs).start()
        peers.append(peer)
        return peer

    yield make
    for peer in peers:
        peer.stop()


@pytest.fixture
def make_driver(channel):
    """``make_driver(**options)`` -> a :class:`CanopenDriver` on the test's channel (closed afterwards)."""
    drivers = []

    def make(**options) -> CanopenDriver:
        # the peer drives and the driver share this process: on a loaded 2-core machine a thread can stall for
        # longer than the limits file's 0.1 s watchdog (0.18 s seen once in `make test`) or the driver's 0.25 s
        # heartbeats (every drive faulted on a late master heartbeat at connection, in CI), which is not what these
        # tests are about; the watchdog itself is tested in tests/framework/hardware, heartbeat loss with its own
        options.setdefault("state_timeout", 0.5)
        options.setdefault("heartbeat_timeout", 0.5)
        driver = CanopenDriver(channel=channel, **options)
        drivers.append(driver)
        return driver

    yield make
    for driver in drivers:
        driver.close()


@pytest.fixture(autouse=True)
def _realtime(frozen_heap):
    """Heartbeats, watchdogs and command streams run in threads of this process: no multi-100 ms collector pauses
    (see ``frozen_heap``)."""
