"""The loopback ROS master launcher and the master check every driver runs before joining the graph."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from pliant.errors import ConnectionLost
from ros1_helpers import need_ros


def _listening_addresses(port: int) -> set[str]:
    """The local addresses with a TCP socket listening on ``port`` (Linux /proc/net/tcp and tcp6)."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        path = Path(table)
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            fields = line.split()
            address, hex_port = fields[1].rsplit(":", 1)
            if int(hex_port, 16) == port and fields[3] == "0A":          # 0A: LISTEN
                found.add(address)
    return found


def test_a_master_starts_on_a_free_loopback_port_restarts_and_stops(tmp_path):
    need_ros()
    from pliant_ros1.master import RosMaster
    from pliant_ros1.node import check_master

    with RosMaster(log_dir=tmp_path) as master:
        assert master.uri == f"http://127.0.0.1:{master.port}"
        pid = check_master(master.uri)
        assert pid == master.process.pid
        if Path("/proc/net/tcp").exists():
            assert _listening_addresses(master.port) == {"0100007F"}        # 127.0.0.1 only, nothing else
        port = master.port
        master.restart()
        assert master.port == port and check_master(master.uri) != pid
    assert not master.alive()
    with pytest.raises(ConnectionLost):
        check_master(master.uri)


def test_an_absent_master_is_one_line_naming_it_within_the_timeout():
    need_ros()
    from pliant_ros1.master import free_port
    from pliant_ros1.node import check_master

    uri = f"http://127.0.0.1:{free_port()}"
    start = time.monotonic()
    with pytest.raises(ConnectionLost) as info:
        check_master(uri, timeout=0.3)
    assert time.monotonic() - start < 1.0
    text = str(info.value)
    assert "\n" not in text and text == f"ROS master at {uri} unreachable (connection refused)"
    with pytest.raises(ConnectionLost, match="not of the form"):
        check_master("127.0.0.1:11311")
