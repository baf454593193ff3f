"""A robot peer in a child process (tests, benchmarks, the demo): started, sent faults, stopped or killed."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from pliant_ros1.testing.peer import DEFAULT_FAULT_TOPIC, READY
from pliant_ros1.testing.record import read_record


class PeerProcess:
    """``python -m pliant_ros1.testing ROBOT ...`` as a child process (tests, benchmarks).

    ``extra`` are more command-line arguments (``["--simulator", "none"]``).  :meth:`start` waits until the peer
    prints its ready line (``ready_timeout`` s); :meth:`fault` publishes a fault switch on its topic (this process
    becomes a ROS node of the same master); :meth:`kill` is a crash, :meth:`stop` a clean exit.
    """

    def __init__(self, robot: str, master_uri: str, *, side: str = "right", record: str | Path | None = None,
                 extra: list[str] | tuple[str, ...] = (), log: str | Path | None = None,
                 ready_timeout: float = 90.0, fault_topic: str = DEFAULT_FAULT_TOPIC) -> None:
        self.robot, self.side, self.master_uri = robot, side, master_uri
        self.record = Path(record) if record is not None else None
        self.extra = list(extra)
        self.log = Path(log) if log is not None else None
        self.ready_timeout = ready_timeout
        self.fault_topic = fault_topic
        self.process: subprocess.Popen | None = None
        self._fault_pub = None

    def command_line(self) -> list[str]:
        """The peer's command line (this Python, ``-m pliant_ros1.testing``, the robot and the options)."""
        args = [sys.executable, "-m", "pliant_ros1.testing", self.robot, "--side", self.side, "--master",
                self.master_uri, "--fault-topic", self.fault_topic, "--exit-with-parent", str(os.getpid())]
        if self.record is not None:
            args += ["--record", str(self.record)]
        return args + self.extra

    def start(self) -> PeerProcess:
        """Start the child process (stdout and stderr to ``log``) and wait for its ready line; raises
        :class:`~pliant.errors.ConnectionLost` with the end of its output when it does not come."""
        from pliant.api import ConnectionLost

        from pliant_ros1.master import loopback_environment

        if self.log is None:
            import tempfile

            self.log = Path(tempfile.mkstemp(prefix=f"pliant-peer-{self.robot}-", suffix=".log")[1])
        self._log_file = open(self.log, "wb")
        self.process = subprocess.Popen(self.command_line(), env=loopback_environment(self.master_uri),
                                        stdin=subprocess.DEVNULL, stdout=self._log_file, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + self.ready_timeout
        while READY not in self.log.read_text(errors="replace"):
            if self.process.poll() is not None or time.monotonic() > deadline:
                tail = self.log.read_text(errors="replace").strip().splitlines()[-5:]
                self.stop()
                raise ConnectionLost(f"the {self.robot} peer did not start: " + (" | ".join(tail) or "no output"))
            time.sleep(0.02)
        return self

    def alive(self) -> bool:
        """Whether the child process is running."""
        return self.process is not None and self.process.poll() is None

    def fault(self, name: str, timeout: float = 5.0) -> None:
        """Switch on fault ``name`` in the peer (over its ROS fault topic)."""
        import rospy
        from std_msgs.msg import String

        from pliant_ros1.node import ensure_node, wait_for

        if self._fault_pub is None:
            # as patient as the driver: a master busy registering the peer's and the driver's topics on a loaded
            # machine took more than 0.5 s to answer (a CI run of session 34)
            ensure_node(self.master_uri, timeout=2.0, attempts=3)
            self._fault_pub = rospy.Publisher(self.fault_topic, String, queue_size=10)
        if not wait_for(lambda: self._fault_pub.get_num_connections() > 0, timeout):
            raise TimeoutError(f"the peer does not listen on {self.fault_topic}")
        self._fault_pub.publish(String(name))

    def records(self) -> list[dict]:
        """The peer's record so far (:func:`read_record`)."""
        return read_record(self.record) if self.record is not None and self.record.exists() else []

    def kill(self) -> None:
        """SIGKILL: the controller crashes."""
        if self.alive():
            self.process.kill()
            self.process.wait(5.0)

    def stop(self, timeout: float = 5.0) -> None:
        """SIGTERM, then SIGKILL; drop the fault publisher; safe to call twice."""
        if self._fault_pub is not None:
            try:
                self._fault_pub.unregister()
            except Exception:
                pass
            self._fault_pub = None
        if self.alive():
            self.process.terminate()
            try:
                self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout)
        log_file = getattr(self, "_log_file", None)
        if log_file is not None and not log_file.closed:
            log_file.close()

    def __enter__(self) -> PeerProcess:
        return self.start()

    def __exit__(self, *exc_info) -> None:
        self.stop()
