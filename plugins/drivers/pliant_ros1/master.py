"""A ROS master on loopback: ``rosmaster --core -p PORT`` on a free port, for tests, benchmarks and the peers.

::

    from pliant_ros1.master import RosMaster

    with RosMaster() as master:          # a free port on 127.0.0.1
        print(master.uri)                # http://127.0.0.1:PORT
        ...                              # start peers and drivers with master_uri=master.uri

The master runs with ``ROS_IP=127.0.0.1`` and ``ROS_MASTER_URI`` set to its own URI (``ROS_HOSTNAME`` removed), so
its XML-RPC server binds to loopback only.  :meth:`RosMaster.start` returns once the master answers
``getPid``; :meth:`RosMaster.stop` terminates it (SIGTERM, then SIGKILL after ``stop_timeout`` s);
:meth:`RosMaster.restart` brings it back on the same port (every registration is lost, as with a real master).
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import tempfile
import time
from pathlib import Path

from pliant.api import ConnectionLost

#: the host every master this module starts binds to
LOOPBACK = "127.0.0.1"


def free_port(host: str = LOOPBACK) -> int:
    """A TCP port nobody listens on at ``host`` right now (the kernel's choice)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def loopback_environment(master_uri: str, base: dict[str, str] | None = None) -> dict[str, str]:
    """``base`` (default ``os.environ``) for a ROS process on loopback: ``ROS_MASTER_URI``, ``ROS_IP=127.0.0.1``,
    no ``ROS_HOSTNAME``."""
    env = dict(os.environ if base is None else base)
    env["ROS_MASTER_URI"] = master_uri
    env["ROS_IP"] = LOOPBACK
    env.pop("ROS_HOSTNAME", None)
    return env


class RosMaster:
    """A ``rosmaster --core`` process on ``127.0.0.1:port`` (a free port when ``port`` is None).

    log_dir: where the master's output goes (``ROS_LOG_DIR`` / ``ROS_HOME`` of the process; default a temporary
    directory removed on :meth:`stop`).  startup_timeout: seconds to wait for the master to answer.
    """

    def __init__(self, port: int | None = None, *, log_dir: str | Path | None = None, startup_timeout: float = 15.0,
                 stop_timeout: float = 3.0, executable: str | None = None) -> None:
        self.port = port
        self.startup_timeout = startup_timeout
        self.stop_timeout = stop_timeout
        self.executable = executable or shutil.which("rosmaster") or "/usr/bin/rosmaster"
        self._log_dir = Path(log_dir) if log_dir is not None else None
        self._own_log_dir: str | None = None
        self.process: subprocess.Popen | None = None

    @property
    def uri(self) -> str:
        """``http://127.0.0.1:PORT`` (valid once started)."""
        if self.port is None:
            raise ConnectionLost("the ROS master has not been started")
        return f"http://{LOOPBACK}:{self.port}"

    def alive(self) -> bool:
        """Whether the master process is running."""
        return self.process is not None and self.process.poll() is None

    def start(self) -> RosMaster:
        """Start the master and wait until it answers; :class:`ConnectionLost` if it does not."""
        from pliant_ros1.node import check_master

        if self.alive():
            return self
        if not Path(self.executable).exists():
            raise ConnectionLost(f"rosmaster not found ({self.executable}); install ROS 1 (Debian: ros-core)")
        if self.port is None:
            self.port = free_port()
        if self._log_dir is None and self._own_log_dir is None:
            self._own_log_dir = tempfile.mkdtemp(prefix="pliant-rosmaster-")
        log_dir = Path(self._log_dir or self._own_log_dir)
        log_dir.mkdir(parents=True, exist_ok=True)
        env = loopback_environment(self.uri)
        env.setdefault("ROS_HOME", str(log_dir))
        env["ROS_LOG_DIR"] = str(log_dir)
        self._output = open(log_dir / f"rosmaster-{self.port}.log", "ab")
        self.process = subprocess.Popen([self.executable, "--core", "-p", str(self.port)], env=env,
                                        stdin=subprocess.DEVNULL, stdout=self._output, stderr=subprocess.STDOUT,
                                        start_new_session=True)
        deadline = time.monotonic() + self.startup_timeout
        while True:
            if self.process.poll() is not None:
                self._output.close()
                tail = (log_dir / f"rosmaster-{self.port}.log").read_text(errors="replace").strip().splitlines()
                raise ConnectionLost(f"rosmaster on port {self.port} exited with {self.process.returncode}"
                                     + (f": {tail[-1]}" if tail else ""))
            try:
                check_master(self.uri, timeout=0.5)
                return self
            except ConnectionLost:
                if time.monotonic() > deadline:
                    self.stop()
                    raise ConnectionLost(f"rosmaster on port {self.port} did not answer within "
                                         f"{self.startup_timeout:g} s") from None
                time.sleep(0.02)

    def stop(self) -> None:
        """Terminate the master (SIGTERM, then SIGKILL); safe to call twice."""
        process, self.process = self.process, None
        if process is not None and process.poll() is None:
            process.terminate()
            try:
                process.wait(self.stop_timeout)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(self.stop_timeout)
        output = getattr(self, "_output", None)
        if output is not None and not output.closed:
            output.close()

    def kill(self) -> None:
        """Kill the master at once (SIGKILL), as a crash would."""
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait(self.stop_timeout)
        self.stop()

    def restart(self) -> RosMaster:
        """Stop (if running) and start again on the same port."""
        self.stop()
        return self.start()

    def close(self) -> None:
        """Stop the master and remove the log directory this object created."""
        self.stop()
        if self._own_log_dir is not None:
            shutil.rmtree(self._own_log_dir, ignore_errors=True)
            self._own_log_dir = None

    def __enter__(self) -> RosMaster:
        return self.start()

    def __exit__(self, *exc_info) -> None:
        self.close()
