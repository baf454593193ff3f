"""Fixtures of the ROS 2 driver tests: ROS 2 peers (emulated ros2_control arms) as child processes, each on a ROS
domain of its own with discovery limited to this machine, recording every command; and drivers that are always
closed.  Tests skip (with the reason) when the ROS 2 wheels are not installed (``make install`` puts them under
.venv/ros2)."""

from __future__ import annotations

import pytest


def need_ros2() -> None:
    """Skip the calling test when the ROS 2 wheels are missing."""
    from pliant_ros2.environment import ros2_prefix

    if ros2_prefix() is None:
        pytest.skip("ROS 2 is not installed: make install puts its wheels under .venv/ros2")


@pytest.fixture
def make_peer(tmp_path):
    """``make_peer(*extra, wait=True)`` -> a started iiwa :class:`PeerProcess` (its own domain id) recording to the
    test's directory; stopped afterwards.  ``wait=False`` returns at once: a driver connecting to it waits for its
    controllers anyway, and both processes start meanwhile."""
    need_ros2()
    from pliant_ros2.testing.process import PeerProcess

    peers = []

    def make(*extra: str, wait: bool = True):
        name = f"peer-{len(peers)}"
        peer = PeerProcess("iiwa", record=tmp_path / f"{name}.jsonl", log=tmp_path / f"{name}.log", extra=list(extra))
        peers.append(peer)
        return peer.start(wait=wait)

    yield make
    for peer in peers:
        peer.stop()


@pytest.fixture
def make_driver():
    """``make_driver(peer, name="iiwa-ros2", **options)`` -> a driver on the peer's domain, discovery on this machine
    only (closed afterwards).  Generous timeouts so that a loaded machine fails no test: a stale-state watchdog of
    0.5 s instead of the limits file's 0.1 s (the watchdog test passes its own)."""
    from pliant import registry

    drivers = []

    def make(peer, name: str = "iiwa-ros2", **options):
        options = {"domain_id": peer.domain_id, "localhost_only": True, "connect_timeout": 20.0,
                   "move_timeout": 20.0, "state_timeout": 0.5, **options}
        driver = registry.create("driver", name, **options)
        drivers.append(driver)
        return driver

    yield make
    for driver in drivers:
        driver.close()


@pytest.fixture(autouse=True)
def _realtime(frozen_heap):
    """The command stream and the driver's reader thread run in this process: no multi-100 ms collector pauses."""
