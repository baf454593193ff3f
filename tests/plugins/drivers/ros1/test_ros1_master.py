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


def test_a_busy_master_is_asked_again_and_an_absent_one_is_not():
    """A master that misses one answer (busy registering a node's topics on a loaded machine) is asked again, up to
    ``attempts`` times; with one attempt the same master is unreachable.  A refused connection is not retried."""
    need_ros()
    import threading
    from socketserver import ThreadingMixIn
    from xmlrpc.server import SimpleXMLRPCServer

    from pliant_ros1.master import free_port
    from pliant_ros1.node import check_master

    class Server(ThreadingMixIn, SimpleXMLRPCServer):
        daemon_threads = True

    calls = []

    def get_pid(caller_id):
        calls.append(caller_id)
        if len(calls) == 1:
            time.sleep(3.0)                 # the first question outlives its 1 s timeout; the next are answered
        return [1, "", 4242]

    server = Server(("127.0.0.1", 0), logRequests=False, allow_none=True)
    server.register_function(get_pid, "getPid")
    threading.Thread(target=server.serve_forever, daemon=True).start()
    uri = f"http://127.0.0.1:{server.server_address[1]}"
    try:
        assert check_master(uri, timeout=1.0, attempts=3) == 4242 and len(calls) == 2
        calls.clear()
        with pytest.raises(ConnectionLost, match=r"unreachable \(no answer within 1 s\)"):
            check_master(uri, timeout=1.0, attempts=1)
    finally:
        server.shutdown()
        server.server_close()
    absent = f"http://127.0.0.1:{free_port()}"
    start = time.monotonic()
    with pytest.raises(ConnectionLost, match="connection refused"):
        check_master(absent, timeout=1.0, attempts=3)
    assert time.monotonic() - start < 1.0
