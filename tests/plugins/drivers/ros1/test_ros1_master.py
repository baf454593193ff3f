"""The loopback ROS master launcher and the master check every driver runs before joining the graph."""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import pytest
from pliant.errors import ConnectionLost
from ros1_helpers import need_ros


@contextlib.contextmanager
def _fake_master(get_pid):
    """A threaded XML-RPC server on loopback whose ``getPid`` is ``get_pid(caller_id)``: yields its URI."""
    import threading
    from socketserver import ThreadingMixIn
    from xmlrpc.server import SimpleXMLRPCServer

    class Server(ThreadingMixIn, SimpleXMLRPCServer):
        daemon_threads = True

    server = Server(("127.0.0.1", 0), logRequests=False, allow_none=True)
    server.register_function(get_pid, "getPid")
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


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
    from pliant_ros1.master import free_port
    from pliant_ros1.node import check_master

    calls = []

    def get_pid(caller_id):
        calls.append(caller_id)
        if len(calls) == 1:
            time.sleep(3.0)                 # the first question outlives its 1 s timeout; the next are answered
        return [1, "", 4242]

    with _fake_master(get_pid) as uri:
        assert check_master(uri, timeout=1.0, attempts=3) == 4242 and len(calls) == 2
        calls.clear()
        with pytest.raises(ConnectionLost, match=r"unreachable \(no answer within 1 s\)"):
            check_master(uri, timeout=1.0, attempts=1)
    absent = f"http://127.0.0.1:{free_port()}"
    start = time.monotonic()
    with pytest.raises(ConnectionLost, match="connection refused"):
        check_master(absent, timeout=1.0, attempts=3)
    assert time.monotonic() - start < 1.0


def test_the_watchdog_waits_out_a_silent_master_for_its_grace_and_loses_a_refusing_one_at_once():
    """Connected, a master that stops answering is lost only once it has been silent for ``grace`` s (and three
    checks): a loaded machine kept a live one from answering for 1.8 s.  One that answers again in time is kept; a
    refused connection is lost at once."""
    need_ros()
    import threading

    from pliant_ros1.master import free_port
    from pliant_ros1.node import MasterWatch

    stall = threading.Event()
    answered = []

    def get_pid(caller_id):
        if stall.is_set():
            time.sleep(30.0)                # silent: every check times out
        answered.append(time.monotonic())
        return [1, "", 4242]

    try:
        with _fake_master(get_pid) as uri:
            watch = MasterWatch(uri, period=0.05, timeout=0.2, grace=3.0).start()
            assert wait_for_answers(answered, 2)
            stall.set()                     # silent for 1 s, at least four checks of 0.2 s: within the grace
            time.sleep(1.0)
            stall.clear()
            assert wait_for_answers(answered, len(answered) + 2) and watch.error is None and watch.pid == 4242
            stall.set()                     # silent for good: lost, but not before the grace (three checks of
            began = time.monotonic()        # 0.25 s took 0.75 s; a check asked just before the stall counts)
            while watch.error is None and time.monotonic() - began < 30.0:
                time.sleep(0.05)
            assert time.monotonic() - began >= 2.5
            assert watch.error.startswith(f"ROS master at {uri} stopped answering (no answer within 0.2 s; silent "
                                          "for ")
            watch.stop()
    finally:
        stall.clear()
    gone = MasterWatch(f"http://127.0.0.1:{free_port()}", period=0.05, timeout=0.2, grace=60.0).start()
    began = time.monotonic()
    while gone.error is None and time.monotonic() - began < 30.0:
        time.sleep(0.05)
    assert gone.error is not None and gone.error.endswith("stopped answering (connection refused)")  # grace: 60 s
    gone.stop()


def wait_for_answers(answered: list, count: int, timeout: float = 30.0) -> bool:
    """Whether the fake master has answered ``count`` checks within ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while len(answered) < count:
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True
