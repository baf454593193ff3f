"""Where the ROS 2 wheels are and the environment a ROS 2 process of this plugin runs in (no rclpy import here).

ROS 2's Python client (``rclpy``) and middleware (Fast DDS) install as ordinary wheels (``ros-rclpy``,
``ros-rmw-fastrtps-cpp``, ``ros-std-msgs``, ``ros-sensor-msgs``, ``ros-trajectory-msgs``, ``ros-builtin-interfaces``).
Three things make them awkward to import into pliant's own process, so every ROS 2 node of this plugin (the driver's
bridge, the test peer) runs in a child process started with :func:`ros2_environment`:

* their shared libraries are found through ``LD_LIBRARY_PATH`` only (``<prefix>/lib`` and every
  ``site-packages/ros_*.libs``), which the dynamic loader reads once, at process start: the wheels' own
  ``ros_wheels_bootstrapper.pth`` re-executes every interpreter of the venv to set it, marked by
  ``_ROS_WHEELS_BOOTSTRAP_COMPLETE=1``;
* their message packages (``std_msgs``, ``sensor_msgs``, ``trajectory_msgs``) have the same names as ROS 1's, which
  pliant's ROS 1 plugin imports from Debian's packages: one process can hold only one of the two;
* ``rclpy.init`` installs a SIGINT handler, writes logs under ``~/.ros`` unless ``ROS_LOG_DIR`` says otherwise, and
  shutting down while an executor still spins aborts the process.

``make install`` therefore puts the wheels under ``.venv/ros2`` (``pip install --prefix``), outside the venv's
``site-packages``: nothing else in the venv sees them.  :func:`ros2_prefix` finds them there, under
``$PLIANT_ROS2_PREFIX``, or in the running interpreter's own environment (``pip install 'pliant[ros2]'``).
"""

from __future__ import annotations

import importlib.util
import os
import sys
import sysconfig
from pathlib import Path

from pliant.api import ConfigError

#: the wheels a ROS 2 process of this plugin needs (the ``ros2`` extra of pyproject.toml)
WHEELS = ("ros-rclpy", "ros-rmw-fastrtps-cpp", "ros-std-msgs", "ros-sensor-msgs", "ros-trajectory-msgs",
          "ros-builtin-interfaces")
#: the middleware the wheels provide
RMW = "rmw_fastrtps_cpp"
#: what a child process inherits from a parent of another environment and must not
_CLEARED = ("_ROS_WHEELS_BOOTSTRAP_COMPLETE", "PYTHONHOME", "AMENT_PREFIX_PATH", "ROS_LOCALHOST_ONLY",
            "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "ROS_DOMAIN_ID", "FASTRTPS_DEFAULT_PROFILES_FILE",
            "FASTDDS_DEFAULT_PROFILES_FILE", "ROS_DISCOVERY_SERVER")


def _site_packages(prefix: Path) -> Path:
    return prefix / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / "site-packages"


def ros2_prefix() -> Path | None:
    """The prefix the ROS 2 wheels are installed under, or None: ``$PLIANT_ROS2_PREFIX``, else ``<venv>/ros2``
    (where ``make install`` puts them), else this interpreter's own prefix when ``rclpy`` is installed in it."""
    candidates = []
    if os.environ.get("PLIANT_ROS2_PREFIX"):
        candidates.append(Path(os.environ["PLIANT_ROS2_PREFIX"]))
    candidates.append(Path(sys.prefix) / "ros2")
    for prefix in candidates:
        if (_site_packages(prefix) / "rclpy").is_dir():
            return prefix
    if importlib.util.find_spec("rclpy") is not None:
        return Path(sys.prefix)
    return None


def require_prefix() -> Path:
    """:func:`ros2_prefix`, or a :class:`ConfigError` saying how to install the wheels."""
    prefix = ros2_prefix()
    if prefix is None:
        raise ConfigError("ROS 2 is not installed: `make install` puts its wheels under .venv/ros2 (or pip install "
                          f"--prefix .venv/ros2 {' '.join(WHEELS)}; or set PLIANT_ROS2_PREFIX)",
                          field="PLIANT_ROS2_PREFIX", value=os.environ.get("PLIANT_ROS2_PREFIX"))
    return prefix


def library_path(prefix: Path) -> list[str]:
    """The directories of the wheels' shared libraries: ``<prefix>/lib`` and every ``site-packages/ros_*.libs``."""
    site = _site_packages(prefix)
    return [str(prefix / "lib"), *sorted(str(p) for p in site.glob("ros_*.libs") if p.is_dir())]


def ros2_environment(domain_id: int, *, log_dir: str | Path | None = None, localhost: bool = True,
                     base: dict[str, str] | None = None) -> dict[str, str]:
    """The environment of a ROS 2 child process: the wheels' site-packages first on ``PYTHONPATH`` (so their
    ``std_msgs`` wins over ROS 1's), their libraries on ``LD_LIBRARY_PATH``, ``_ROS_WHEELS_BOOTSTRAP_COMPLETE=1``
    (no re-execution), ``RMW_IMPLEMENTATION=rmw_fastrtps_cpp``, ``ROS_DOMAIN_ID``, ``ROS_LOG_DIR`` (a temporary
    directory unless given) and, with ``localhost``, discovery limited to this machine
    (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, the Jazzy-and-later spelling, and ``ROS_LOCALHOST_ONLY=1`` for
    older distributions)."""
    import tempfile

    prefix = require_prefix()
    env = dict(os.environ if base is None else base)
    for name in _CLEARED:
        env.pop(name, None)
    site = str(_site_packages(prefix))
    own = str(Path(__file__).resolve().parents[1])          # plugins/drivers: pliant_ros2 importable as is
    paths = [site, own] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p and p not in (site, own)]
    env["PYTHONPATH"] = os.pathsep.join(paths)
    libs = library_path(prefix)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(libs + [p for p in env.get("LD_LIBRARY_PATH", "").split(os.pathsep)
                                                     if p and p not in libs])
    env["_ROS_WHEELS_BOOTSTRAP_COMPLETE"] = "1"
    env["AMENT_PREFIX_PATH"] = str(prefix)
    env["RMW_IMPLEMENTATION"] = env.get("PLIANT_ROS2_RMW") or RMW
    env["ROS_DOMAIN_ID"] = str(int(domain_id))
    env["ROS_LOG_DIR"] = str(log_dir) if log_dir is not None else \
        env.get("PLIANT_ROS2_LOG_DIR") or str(Path(tempfile.gettempdir()) / "pliant-ros2-log")
    env["RCUTILS_COLORIZED_OUTPUT"] = "0"
    env["PYTHONUNBUFFERED"] = "1"
    if localhost:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return env


def check_domain_id(value: int, field: str = "domain_id") -> int:
    """A ROS domain id (0-232: the range every DDS port mapping allows)."""
    if not 0 <= int(value) <= 232:
        raise ConfigError("a ROS domain id lies in 0..232", field=field, value=value)
    return int(value)


def python() -> str:
    """The interpreter of the child processes (this one: numpy and pliant_ros2 come from the same venv)."""
    return sys.executable or sysconfig.get_config_var("BINDIR") + "/python3"
