"""Fixtures of the ROS 1 driver tests: one ROS master per test session on a free loopback port (restarted on the
same port when a test killed it), robot peers as child processes recording every command, and drivers that are
always closed.

rospy allows one node per process and one master per node: the test process becomes a node of the session's
master at the first driver's ``open()`` and stays one.  Tests that need ROS skip (with the reason) when rospy or
rosmaster are missing; the limits and URDF tests run without ROS.
"""

from __future__ import annotations

import pytest
from ros1_helpers import need_ros, unique_fault_topic


@pytest.fixture(scope="session")
def ros_session(tmp_path_factory):
    """The session's ROS master on loopback, with ROS_HOME, the log and the message cache in temporary
    directories and ROS_IP=127.0.0.1 in this process."""
    need_ros()
    from pliant_ros1.master import RosMaster

    home = tmp_path_factory.mktemp("ros_home")
    with pytest.MonkeyPatch.context() as env:
        env.setenv("ROS_HOME", str(home))
        env.setenv("ROS_LOG_DIR", str(home / "log"))
        env.setenv("ROS_IP", "127.0.0.1")
        env.delenv("ROS_HOSTNAME", raising=False)
        env.setenv("PLIANT_CACHE_DIR", str(tmp_path_factory.mktemp("pliant_cache")))
        master = RosMaster(log_dir=home / "master").start()
        env.setenv("ROS_MASTER_URI", master.uri)
        # pay the one-off costs (joining the graph, generating and importing the message types) before any test
        # times anything
        from pliant_ros1.messages import message_class, message_files
        from pliant_ros1.node import ensure_node

        ensure_node(master.uri, timeout=2.0, attempts=3)
        for name in message_files():
            message_class(name)
        try:
            yield master
        finally:
            master.close()


@pytest.fixture
def master(ros_session):
    """The session's master, restarted on its port if an earlier test killed it."""
    if not ros_session.alive():
        ros_session.start()
    return ros_session


@pytest.fixture
def make_peer(master, tmp_path):
    """``make_peer(robot, side="right", *extra)`` -> a started :class:`PeerProcess` recording to the test's
    directory (stopped afterwards)."""
    from pliant_ros1.testing.process import PeerProcess

    peers = []

    def make(robot: str, side: str = "right", *extra: str):
        name = f"{robot}-{side}-{len(peers)}"
        peer = PeerProcess(robot, master.uri, side=side, record=tmp_path / f"{name}.jsonl",
                           log=tmp_path / f"{name}.log", extra=list(extra), fault_topic=unique_fault_topic())
        peers.append(peer)
        return peer.start()

    yield make
    for peer in peers:
        peer.stop()


@pytest.fixture
def make_driver(master):
    """``make_driver(name, **options)`` -> a driver of the session's master (closed afterwards).  Short timeouts so
    that a failing test fails fast, and a stale-state watchdog of 0.5 s instead of the limits files' 0.1 s so that
    a loaded test machine does not starve a test of states (0.33 s seen at connection in CI at 0.25 s): the
    watchdog tests pass 0.3 s."""
    from pliant import registry

    drivers = []

    def make(name: str, **options):
        options = {"master_uri": master.uri, "connect_timeout": 10.0, "move_timeout": 10.0, "state_timeout": 0.5,
                   **options}
        driver = registry.create("driver", name, **options)
        drivers.append(driver)
        return driver

    yield make
    for driver in drivers:
        driver.close()


@pytest.fixture(autouse=True)
def _realtime(frozen_heap):
    """Heartbeats, watchdogs and command streams run in threads of this process: no multi-100 ms collector pauses
    (see ``frozen_heap``)."""
