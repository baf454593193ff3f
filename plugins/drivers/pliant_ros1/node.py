"""The process's one ROS node, and the ROS master's health.

rospy allows one node per process, registered with one master, and cannot re-initialise: :func:`ensure_node`
starts it on first use (``disable_signals``, anonymous, so pliant's own Ctrl-C handling stays in charge) and refuses
a second master with a clear error.  Before that, :func:`check_master` asks the master for its pid
(``rosgraph.Master.getPid``) under a short socket timeout, so an absent master is a one-line
:class:`~pliant.errors.ConnectionLost` within ``timeout`` seconds instead of rospy's endless retries.

:func:`ensure_node` sets ``ROS_MASTER_URI`` in this process's environment (rospy reads it there) and leaves the
process's logging as it was (rospy's own loggers write to rospy's log file under ``ROS_HOME`` / ``ROS_LOG_DIR``).
For a master on loopback with neither ``ROS_IP`` nor ``ROS_HOSTNAME`` set, the node is given ``ROS_IP=127.0.0.1``:
its XML-RPC and TCPROS servers then bind to loopback only and advertise a loopback address (rosgraph's
``get_bind_address``).  Talking to a robot on the network needs ``ROS_IP`` set to this machine's address on that
network, as for any ROS node.
"""

from __future__ import annotations

import logging
import os
import threading
import time
import xmlrpc.client
from urllib.parse import urlparse

from pliant.api import ConnectionLost, DriverError

_lock = threading.Lock()
_node_master: str | None = None


class _TimeoutTransport(xmlrpc.client.Transport):
    """An XML-RPC transport whose connections give up after ``timeout`` seconds."""

    def __init__(self, timeout: float) -> None:
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host):
        """An HTTP connection that gives up after ``timeout`` s."""
        connection = super().make_connection(host)
        connection.timeout = self.timeout
        return connection


#: checks of the master in a row without an answer before it is lost (connecting and watching alike)
MASTER_PATIENCE = 3
#: seconds a connected master may stay silent before it is lost (besides MASTER_PATIENCE checks): a loaded
#: machine once kept a live master from answering three checks of 0.5 s in a row (1.8 s) during a test
MASTER_GRACE = 3.0


def normalise(uri: str) -> str:
    """A master URI without its trailing slash (``http://127.0.0.1:11311``)."""
    return uri.strip().rstrip("/")


def is_loopback(uri: str) -> bool:
    """Whether the master URI names this machine's loopback interface."""
    host = urlparse(uri).hostname or ""
    return host == "localhost" or host.startswith("127.") or host == "::1"


class _NoAnswer(ConnectionLost):
    """The master did not answer within the timeout (it may be busy: asked again where patience allows)."""


def check_master(uri: str, timeout: float = 0.5, attempts: int = 1) -> int:
    """The pid of the ROS master at ``uri``, or :class:`ConnectionLost` naming it (one line).

    Each of ``attempts`` asks may take ``timeout`` s; a master that does not answer in time is asked again (a busy
    master: one registering a new node's topics on a loaded machine took more than 0.5 s in a test), and a refused
    connection (no master) or a malformed URI ends at once."""
    for _ in range(max(1, attempts) - 1):
        try:
            return _ask_pid(uri, timeout)
        except _NoAnswer:
            continue
    return _ask_pid(uri, timeout)


def _ask_pid(uri: str, timeout: float) -> int:
    import rosgraph

    uri = normalise(uri)
    parsed = urlparse(uri)
    if parsed.scheme not in ("http", "https") or not parsed.hostname or parsed.port is None:
        raise ConnectionLost(f"ROS master URI {uri!r} is not of the form http://HOST:PORT", field="master_uri",
                             value=uri)
    master = rosgraph.Master("/pliant", master_uri=uri)
    master.handle = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout))
    try:
        return int(master.getPid())
    except ConnectionRefusedError:
        reason = "connection refused"
    except TimeoutError:
        raise _NoAnswer(f"ROS master at {uri} unreachable (no answer within {timeout:g} s)") from None
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
    except (rosgraph.MasterException, xmlrpc.client.Error) as exc:
        reason = f"{type(exc).__name__}: {exc}".splitlines()[0]
    raise ConnectionLost(f"ROS master at {uri} unreachable ({reason})")


def ensure_node(master_uri: str, name: str = "pliant_driver", timeout: float = 0.5, attempts: int = 1) -> None:
    """Make sure this process is a ROS node of the master at ``master_uri`` (checked first, :func:`check_master`
    with ``timeout`` and ``attempts``; see the module doc).

    Raises :class:`ConnectionLost` when the master does not answer, and :class:`DriverError` when the process is
    already the node of another master (rospy allows one master per process: run that driver in another process).
    """
    import rospy

    global _node_master
    master_uri = normalise(master_uri)
    check_master(master_uri, timeout, attempts)
    with _lock:
        if rospy.core.is_initialized():
            current = normalise(_node_master or os.environ.get("ROS_MASTER_URI", ""))
            if current and current != master_uri:
                raise DriverError(f"this process is already the ROS node of the master at {current}; rospy allows "
                                  f"one master per process (use another process for {master_uri})",
                                  field="master_uri", value=master_uri)
            return
        os.environ["ROS_MASTER_URI"] = master_uri
        if is_loopback(master_uri) and not os.environ.get("ROS_IP") and not os.environ.get("ROS_HOSTNAME"):
            os.environ["ROS_IP"] = "127.0.0.1"
        root = logging.getLogger()
        saved = (list(root.handlers), root.level)
        try:
            rospy.init_node(name, argv=[name], anonymous=True, disable_signals=True)
        except rospy.ROSException as exc:
            raise ConnectionLost(f"cannot register with the ROS master at {master_uri}: {exc}".splitlines()[0]) \
                from None
        finally:
            _give_back_logging(root, *saved)
        _node_master = master_uri


def _give_back_logging(root: logging.Logger, handlers: list, level: int) -> None:
    """rospy's ``init_node`` replaces the root logger's handlers with its log file (and sets INFO): give the host
    application its logging back, and keep rospy's own loggers writing to rospy's file only."""
    ros_handlers = [h for h in root.handlers if h not in handlers]
    root.handlers[:] = handlers
    root.setLevel(level)
    for name in ("rospy", "rosout"):
        logger = logging.getLogger(name)
        for handler in ros_handlers:
            logger.addHandler(handler)
        logger.propagate = False


class MasterWatch:
    """Asks the master for its pid every ``period`` s in a daemon thread; :attr:`error` is the one-line reason once
    it is gone (it stays set: a master that comes back has lost every registration).

    A refused connection means the master's port is closed: gone at once.  A master that is merely slow (a loaded
    machine, a congested link) is gone only after ``patience`` consecutive checks without an answer within
    ``timeout`` s each that span at least ``grace`` s from the first unanswered one.  A different pid means it
    restarted.
    """

    def __init__(self, uri: str, period: float = 0.1, timeout: float = 0.5, patience: int = MASTER_PATIENCE,
                 grace: float = MASTER_GRACE) -> None:
        self.uri = normalise(uri)
        self.period = period
        self.timeout = timeout
        self.patience = patience
        self.grace = grace
        self.error: str | None = None
        self.pid: int | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="pliant-ros-master-watch", daemon=True)

    def start(self) -> MasterWatch:
        """Start watching (a daemon thread)."""
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop watching; returns within ``timeout`` + 1 s."""
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=self.timeout + 1.0)

    def _run(self) -> None:
        silent, since = 0, 0.0
        while not self._stop.wait(self.period):
            asked = time.monotonic()
            try:
                pid = check_master(self.uri, self.timeout)
            except ConnectionLost as exc:
                silent += 1
                since = since if silent > 1 else asked
                if "connection refused" in exc.message or (
                        silent >= self.patience and time.monotonic() - since >= self.grace):
                    reason = exc.message.replace(" unreachable ", " stopped answering ")
                    if silent > 1 and reason.endswith(")"):
                        reason = f"{reason[:-1]}; silent for {time.monotonic() - since:.1f} s)"
                    self.error = reason
                    return
                continue
            silent = 0
            if self.pid is not None and pid != self.pid:
                self.error = f"the ROS master at {self.uri} restarted (pid {self.pid} -> {pid}); every " \
                             "registration is lost"
                return
            self.pid = pid


def wait_for(condition, timeout: float, period: float = 0.01) -> bool:
    """Poll ``condition()`` until true or ``timeout`` s have passed; returns its last value."""
    deadline = time.monotonic() + timeout
    while True:
        if condition():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(period)
