"""A ROS 2 peer in a child process (tests, benchmarks, demos): started, sent faults, stopped or killed.

Each peer gets its own ROS domain id (:func:`free_domain_id`, unless given) and discovery limited to this machine
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``): nothing leaves the machine and two test runs never see each other.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import time
from pathlib import Path

from pliant_ros2.testing.peer import READY

#: the domain ids tests draw from (ROS_DOMAIN_ID 0-101 and 215-232 are safe on Linux; 1-100 left to the user's)
_DOMAINS = range(101, 1, -1)


def free_domain_id(salt: int = 0) -> int:
    """A domain id this process has not used yet, different for every process (pid) and call: 2..101."""
    free_domain_id.count = getattr(free_domain_id, "count", 0) + 1
    return _DOMAINS[(os.getpid() * 7 + free_domain_id.count * 13 + salt) % len(_DOMAINS)]


class PeerProcess:
    """``python -m pliant_ros2.testing PRESET ...`` as a child process.

    ``extra``: more command-line arguments (``["--rate", "250"]``).  :meth:`start` waits for the ready line
    (``ready_timeout`` s); :meth:`fault` writes a fault switch to its stdin; :meth:`kill` is a crash, :meth:`stop` a
    clean exit.
    """

    def __init__(self, preset: str = "iiwa", *, domain_id: int | None = None, record: str | Path | None = None,
                 log: str | Path | None = None, extra: list[str] | tuple[str, ...] = (),
                 ready_timeout: float = 60.0) -> None:
        self.preset = preset
        self.domain_id = free_domain_id() if domain_id is None else int(domain_id)
        self.record = Path(record) if record is not None else None
        self.log = Path(log) if log is not None else None
        self.extra = list(extra)
        self.ready_timeout = ready_timeout
        self.process: subprocess.Popen | None = None

    def command_line(self) -> list[str]:
        from pliant_ros2.environment import python

        args = [python(), "-m", "pliant_ros2.testing", self.preset, "--exit-with-parent", str(os.getpid())]
        if self.record is not None:
            args += ["--record", str(self.record)]
        return args + self.extra

    def start(self, wait: bool = True) -> PeerProcess:
        """Start the child and (with ``wait``) wait for its ready line (:meth:`wait_ready`); without, a driver may
        start its own node meanwhile (both take a second or two)."""
        from pliant_ros2.environment import ros2_environment

        if self.log is None:
            self.log = Path(tempfile.mkstemp(prefix=f"pliant-ros2-peer-{self.preset}-", suffix=".log")[1])
        env = ros2_environment(self.domain_id, localhost=True, log_dir=self.log.parent / "ros_log")
        self._log_file = open(self.log, "wb")
        self.process = subprocess.Popen(self.command_line(), env=env, stdin=subprocess.PIPE, stdout=self._log_file,
                                        stderr=subprocess.STDOUT)
        return self.wait_ready() if wait else self

    def wait_ready(self) -> PeerProcess:
        """Wait for the ready line (``ready_timeout`` s); raises :class:`~pliant.errors.ConnectionLost` with the end
        of the peer's output when it does not come."""
        from pliant.api import ConnectionLost

        deadline = time.monotonic() + self.ready_timeout
        while READY not in self.log.read_text(errors="replace"):
            if self.process.poll() is not None or time.monotonic() > deadline:
                tail = self.log.read_text(errors="replace").strip().splitlines()[-5:]
                self.stop()
                raise ConnectionLost("the ROS 2 peer did not start: " + (" | ".join(tail) or "no output"))
            time.sleep(0.02)
        return self

    def alive(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def fault(self, name: str) -> None:
        """Switch on fault ``name`` (:data:`pliant_ros2.testing.peer.FAULTS`)."""
        self.process.stdin.write(f"{name}\n".encode())
        self.process.stdin.flush()

    def records(self) -> list[dict]:
        from pliant.api import read_jsonl

        return read_jsonl(self.record)[0] if self.record is not None else []   # a torn last line is skipped

    def kill(self) -> None:
        if self.alive():
            self.process.kill()
            self.process.wait(5.0)

    def stop(self, timeout: float = 5.0) -> None:
        """A clean exit (``quit`` on stdin), then SIGTERM, then SIGKILL; safe to call twice."""
        if self.alive():
            try:
                self.process.stdin.write(b"quit\n")
                self.process.stdin.flush()
                self.process.wait(timeout)
            except (OSError, ValueError, subprocess.TimeoutExpired):
                self.process.terminate()
                try:
                    self.process.wait(timeout)
                except subprocess.TimeoutExpired:
                    self.process.kill()
                    self.process.wait(timeout)
        if self.process is not None and self.process.stdin is not None and not self.process.stdin.closed:
            try:
                self.process.stdin.close()
            except OSError:
                pass
        log_file = getattr(self, "_log_file", None)
        if log_file is not None and not log_file.closed:
            log_file.close()

    def __enter__(self) -> PeerProcess:
        return self.start()

    def __exit__(self, *exc_info) -> None:
        self.stop()
