"""The ``ros2-control`` driver: an arm under ros2_control, through its standard controllers' topics.

* **commands, streamed** (``mode = "stream"``, the default): one ``std_msgs/Float64MultiArray`` per command period
  on ``/<namespace>/<forward_controller>/commands`` (a ``forward_command_controller`` /
  ``position_controllers/JointGroupPositionController``), positions in rad in the controller's joint order (the
  ``joints`` option).  The controller holds the last command it received: it has no command timeout.
* **commands through the trajectory controller** (``mode = "trajectory"``): every command goes as a
  ``trajectory_msgs/JointTrajectory`` of one point (positions, velocities, ``time_from_start`` one command period,
  ``header.stamp`` zero: "start now") to ``/<namespace>/<trajectory_controller>/joint_trajectory``; the controller
  splines between them.  :meth:`Ros2ControlDriver.send_trajectory` sends a whole timed path at once, every point
  checked against the limits first.
* **states**: ``sensor_msgs/JointState`` on ``/<namespace>/<state_topic>`` (the ``joint_state_broadcaster``), mapped
  from the controller's joint names to pliant's (``pliant_joints``) and then checked by the core like every driver's
  (names, order, stamps, the stale-state watchdog, floods).
* **QoS**: states best-effort by default (sensor data; it matches the broadcaster's reliable publisher), commands
  reliable (ros2_control subscribes reliably: a best-effort publisher would never connect, silently).
* **status**: ``lost`` when the node's process dies, when the state topic loses its publisher, or when the command
  topic loses its subscriber (the controller was deactivated or crashed): the core then brakes and raises
  :class:`~pliant.errors.ConnectionLost`.  Joint states that jump further than the arm can move between their
  stamps are refused by the core's safety layer for every driver (:func:`pliant.hardware.safety.state_jump`).

The ROS 2 node itself runs in a child process (:mod:`pliant_ros2.bridge`, started with
:func:`pliant_ros2.environment.ros2_environment`): rclpy from the pip wheels needs its library path set before the
interpreter starts, and its message packages share their names with ROS 1's.  The two processes exchange JSON lines
(about 0.1 ms per command).  Smoothing, limits, watchdogs, time-stamp checks and stops are pliant's core.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from pliant.api import (
    ConfigError,
    ConnectionLost,
    Driver,
    DriverOptions,
    JointState,
    LimitViolation,
    RobotStatus,
    option,
)

from pliant_ros2.robots import IIWA_LIMITS, IIWA_ROS2, topic


def default_domain_id() -> int:
    """``ROS_DOMAIN_ID`` from the environment, else 0."""
    try:
        return int(os.environ.get("ROS_DOMAIN_ID") or 0)
    except ValueError:
        return 0


@dataclass(frozen=True)
class Ros2ControlOptions(DriverOptions):
    """Options of the ``ros2-control`` driver (plus :class:`pliant.interfaces.DriverOptions`)."""

    namespace: str = option("", "the robot's ROS namespace (e.g. /lbr); controllers and the state topic live under it")
    joints: tuple[str, ...] = option((), "the controllers' joints, in their order (their YAML's joints list)")
    pliant_joints: tuple[str, ...] = option((), "the same joints as the limits file and the pipeline's robot name "
                                            "them, in the same order (default: joints)")
    forward_controller: str = option("forward_position_controller", "the forward_command_controller / "
                                     "JointGroupPositionController: commands on /<namespace>/<this>/commands")
    trajectory_controller: str = option("joint_trajectory_controller", "the joint_trajectory_controller: "
                                        "trajectories on /<namespace>/<this>/joint_trajectory")
    state_topic: str = option("joint_states", "the joint_state_broadcaster's topic, under the namespace (absolute "
                              "if it starts with /)")
    mode: str = option("stream", "stream: every command to the forward controller; trajectory: every command as a "
                       "one-point JointTrajectory to the trajectory controller", choices=("stream", "trajectory"))
    state_qos: str = option("best_effort", "QoS reliability of the joint-state subscription",
                            choices=("best_effort", "reliable"))
    command_qos: str = option("reliable", "QoS reliability of the command publishers (ros2_control subscribes "
                              "reliably: best_effort never connects to it)", choices=("reliable", "best_effort"))
    domain_id: int = option(None, "ROS domain id (default $ROS_DOMAIN_ID, else 0)", minimum=0, maximum=232,
                            default_factory=default_domain_id)
    localhost_only: bool = option(False, "limit discovery to this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST); "
                                  "false reaches the robot's computer on the subnet")
    startup_timeout: float = option(30.0, "seconds the ROS 2 node's process may take to start (importing rclpy)",
                                    minimum=0.1)


def _lines(stream):
    """Lines of a binary pipe, ending at EOF (no read-ahead buffering beyond one line)."""
    return iter(stream.readline, b"")


class Ros2ControlDriver(Driver):
    """An arm under ros2_control (see the module docstring)."""

    Options = Ros2ControlOptions
    #: the limits file of a preset (``iiwa-ros2``), None: the ``limits`` option must name one
    preset_limits: ClassVar[Path | None] = None
    #: options the conformance kit creates the driver with (it has no joints or limits of its own): the iiwa's
    example_options: ClassVar[dict[str, Any]] = {"joints": IIWA_ROS2["joints"],
                                                 "pliant_joints": IIWA_ROS2["pliant_joints"],
                                                 "limits": str(IIWA_LIMITS)}

    def __init__(self, options: Any = None, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        o = self.options
        if o.pliant_joints and len(o.pliant_joints) != len(o.joints):
            raise ConfigError(f"pliant_joints names {len(o.pliant_joints)} joints, joints {len(o.joints)}",
                              field="pliant_joints", value=list(o.pliant_joints))
        for field, names in (("joints", o.joints), ("pliant_joints", o.pliant_joints)):
            if len(set(names)) != len(names):
                raise ConfigError("a joint is named twice", field=field, value=list(names))
        self._names = tuple(o.pliant_joints or o.joints)
        self._to_pliant = dict(zip(o.joints, self._names))
        self._process: subprocess.Popen | None = None
        self._reader: threading.Thread | None = None
        self._state: JointState | None = None
        self._count = 0
        self._counts: dict[str, int] | None = None
        self._ever: dict[str, bool] = {}
        self._ready = threading.Event()
        self._graph: dict | None = None
        self._graph_event = threading.Event()
        self._error: str | None = None
        self._exited: str | None = None
        self._send_lock = threading.Lock()
        self._connected = False
        self._log_path: Path | None = None

    # --- what the robot is -----------------------------------------------------------------------------------

    def joint_names(self) -> tuple[str, ...]:
        """The commanded joints as pliant names them (``pliant_joints``, default ``joints``); a
        :class:`ConfigError` while the ``joints`` option is empty."""
        if not self._names:
            raise ConfigError("ros2-control needs the controllers' joints, in their order (joints = [...])",
                              field="joints", value=[])
        return self._names

    def default_limits_file(self):
        if self.preset_limits is not None:
            return self.preset_limits
        raise ConfigError("ros2-control has no limits of its own: name the arm's limits file (limits = \"...\"; "
                          "format in docs/drivers.md)", field="limits", value=None)

    @property
    def topics(self) -> dict[str, str]:
        """The command, trajectory and state topics (absolute names)."""
        o = self.options
        return {"command": topic(o.namespace, o.forward_controller, "commands"),
                "trajectory": topic(o.namespace, o.trajectory_controller, "joint_trajectory"),
                "state": topic(o.namespace, o.state_topic)}

    # --- the transport ---------------------------------------------------------------------------------------

    def open(self) -> None:
        """Start the node's process (:meth:`start_node`) and wait until the controller in use subscribes to its
        commands; raises :class:`ConnectionLost` in one line naming what is missing."""
        if self._connected:
            return
        o = self.options
        topics = self.topics
        self.joint_names()
        self.start_node()
        try:
            wanted = "command" if o.mode == "stream" else "trajectory"
            if not self._wait(lambda: (self._counts or {}).get(wanted, 0) > 0, o.connect_timeout):
                raise ConnectionLost(f"nothing subscribes to {topics[wanted]} within {o.connect_timeout:g} s (is the "
                                     f"{o.forward_controller if wanted == 'command' else o.trajectory_controller} "
                                     f"active, on ROS domain {o.domain_id}?{self._qos_hint()})")
        except BaseException:
            self.shutdown()
            raise
        self._connected = True

    def start_node(self) -> None:
        """Start the node's process and wait (up to ``startup_timeout``) until it runs; it subscribes to the states
        and advertises the commands at once (no command is sent)."""
        from pliant_ros2.environment import python, ros2_environment

        if self._process is not None:
            return
        o = self.options
        topics = self.topics
        config = {"node": f"pliant_driver_{os.getpid()}_{id(self) % 100000}", "joints": list(o.joints),
                  "state_topic": topics["state"], "command_topic": topics["command"],
                  "trajectory_topic": topics["trajectory"], "state_qos": o.state_qos, "command_qos": o.command_qos}
        env = ros2_environment(o.domain_id, localhost=o.localhost_only)
        Path(env["ROS_LOG_DIR"]).mkdir(parents=True, exist_ok=True)
        self._log_path = Path(tempfile.mkstemp(prefix="pliant-ros2-bridge-", suffix=".log",
                                               dir=env["ROS_LOG_DIR"])[1])
        self._state, self._count, self._counts, self._ever = None, 0, None, {}
        self._error, self._exited = None, None
        self._ready.clear()
        with open(self._log_path, "wb") as log:
            self._process = subprocess.Popen([python(), "-m", "pliant_ros2.bridge", json.dumps(config)], env=env,
                                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log)
        self._reader = threading.Thread(target=self._read, args=(self._process,), name="pliant-ros2-reader",
                                        daemon=True)
        self._reader.start()
        if not self._wait(self._ready.is_set, o.startup_timeout):
            error = self._error or self._exited or self._log_tail()
            self.shutdown()
            raise ConnectionLost(f"the ROS 2 node did not start within {o.startup_timeout:g} s: {error}")

    def _qos_hint(self) -> str:
        return " command_qos = best_effort never connects to ros2_control" if self.options.command_qos != \
            "reliable" else ""

    def _wait(self, condition, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not condition():
            if self._exited is not None or time.monotonic() > deadline:
                return bool(condition())
            time.sleep(0.005)
        return True

    def _log_tail(self) -> str:
        try:
            lines = self._log_path.read_text(errors="replace").strip().splitlines()
        except OSError:
            lines = []
        return " | ".join(lines[-3:]) or "no output"

    def _read(self, process: subprocess.Popen) -> None:
        """The reader thread: the node's JSON lines (states, subscriber counts, graphs, errors)."""
        for line in _lines(process.stdout):
            try:
                message = json.loads(line)
            except ValueError:
                continue
            kind = message.get("k")
            if kind == "s":
                self._received(message)
            elif kind == "c":
                self._counts = message
                for key in ("command", "trajectory", "state"):
                    if message.get(key):
                        self._ever[key] = True
            elif kind == "g":
                self._graph = message
                self._graph_event.set()
            elif kind == "ready":
                self._ready.set()
            elif kind == "e":
                self._error = message.get("m")
        code = process.wait()
        self._exited = f"the ROS 2 node's process exited (status {code}): {self._error or self._log_tail()}"

    def _received(self, message: dict) -> None:
        names = tuple(self._to_pliant.get(n, n) for n in message["n"])
        velocities = message.get("v")
        positions = np.asarray(message["p"], dtype=np.float64)
        stamp = float(message["t"])
        self._count += 1
        self._state = JointState(names, positions, None if velocities is None else np.asarray(velocities,
                                                                                             dtype=np.float64),
                                 stamp, time.monotonic(), self._count)

    def _send(self, message: dict) -> None:
        process = self._process
        if process is None or self._exited is not None:
            raise ConnectionLost(self._exited or "the driver is not connected")
        data = (json.dumps(message, separators=(",", ":")) + "\n").encode()
        try:
            with self._send_lock:
                process.stdin.write(data)
                process.stdin.flush()
        except (BrokenPipeError, OSError, ValueError) as exc:
            code = process.poll()
            why = f"status {code}" if code is not None else str(exc)
            raise ConnectionLost(f"the ROS 2 node's process exited ({why})") from None

    def shutdown(self) -> None:
        """Stop the node's process (a clean exit, then SIGKILL); safe to call twice."""
        self._connected = False
        process, self._process = self._process, None
        if process is not None:
            try:
                if process.poll() is None:
                    process.stdin.write(b'{"op":"quit"}\n')
                    process.stdin.flush()
                process.stdin.close()
            except (BrokenPipeError, OSError, ValueError):
                pass
            try:
                process.wait(5.0)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(5.0)
        reader, self._reader = self._reader, None
        if reader is not None:
            reader.join(timeout=2.0)
        if process is not None and process.stdout is not None:
            process.stdout.close()
        if process is not None and process.returncode == 0 and self._log_path is not None:
            self._log_path.unlink(missing_ok=True)         # a clean exit: its log (rclpy's stderr) says nothing

    def latest_state(self) -> JointState | None:
        return self._state

    def write(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """One command: to the forward controller (``mode = "stream"``) or, as a one-point trajectory reaching
        ``positions`` with ``velocities`` one command period from now, to the trajectory controller."""
        if self.options.mode == "stream":
            self._send({"op": "p", "p": np.asarray(positions, dtype=np.float64).tolist()})
        else:
            self._send({"op": "t", "points": [[self.limits.period, np.asarray(positions, dtype=np.float64).tolist(),
                                               np.asarray(velocities, dtype=np.float64).tolist()]]})

    def robot_status(self) -> RobotStatus:
        """Ready while connected; ``lost`` when the node's process died, the state topic lost its publisher or the
        controller in use stopped subscribing."""
        if not self._connected:
            return RobotStatus(enabled=False, detail="not connected")
        if self._exited is not None:
            return RobotStatus(lost=self._exited)
        counts = self._counts or {}
        topics = self.topics
        wanted = "command" if self.options.mode == "stream" else "trajectory"
        if self._ever.get(wanted) and not counts.get(wanted):
            return RobotStatus(lost=f"nothing subscribes to {topics[wanted]} any more (the controller was "
                                    "deactivated or is gone)")
        if self._ever.get("state") and not counts.get("state"):
            return RobotStatus(lost=f"nothing publishes {topics['state']} any more")
        return RobotStatus(detail=f"{topics[wanted]}: {counts.get(wanted, 0)} subscriber(s); {topics['state']}: "
                                  f"{counts.get('state', 0)} publisher(s); ROS domain {self.options.domain_id}")

    # --- beyond the transport ----------------------------------------------------------------------------------

    def graph(self, timeout: float = 5.0) -> dict:
        """What the node sees on the ROS graph: ``topics`` (name -> types, publishers, subscribers) and ``nodes``
        (needs an open connection: :meth:`open` or ``with driver``)."""
        self._graph_event.clear()
        self._send({"op": "graph"})
        if not self._wait(self._graph_event.is_set, timeout):
            raise ConnectionLost(f"the ROS 2 node did not describe the graph within {timeout:g} s")
        return self._graph

    def trajectory_points(self, times, positions, velocities=None) -> list:
        """A timed path as JointTrajectory points ``[t, positions, velocities]`` (``times`` s from now, ``(k,)``;
        ``positions`` ``(k, d)`` rad in :meth:`joint_names` order), refused with :class:`LimitViolation` unless every
        waypoint lies within the position limits and the motion from the measured state through the points keeps
        the limits.  Without ``velocities`` the arm rests at every point and the controller's cubic between two
        points peaks at 1.5 d/T rad/s, 6 d/T^2 rad/s^2 and 12 d/T^3 rad/s^3 (d the step, T the segment's
        duration): all three are checked against the velocity, acceleration and jerk limits.  With ``velocities``
        only each segment's mean speed and the point velocities are checked (the spline is then the controller's).
        """
        lim = self.limits
        times = np.asarray(times, dtype=np.float64)
        positions = np.atleast_2d(np.asarray(positions, dtype=np.float64))
        if len(times) != len(positions) or len(times) < 1 or np.any(np.diff(times) <= 0) or times[0] <= 0 \
                or positions.shape[1] != lim.dof or not np.all(np.isfinite(positions)):
            raise LimitViolation("a trajectory needs finite waypoints (d per point) at strictly increasing times "
                                 "after 0", field="trajectory", value=times.tolist()[:10])
        bad = (positions < lim.command_lower) | (positions > lim.command_upper)
        if np.any(bad):
            k, i = map(int, np.argwhere(bad)[0])
            raise LimitViolation(f"waypoint {k} at {positions[k, i]:.6g} rad lies outside the position limits",
                                 joint=lim.names[i], value=float(positions[k, i]),
                                 limit=[float(lim.command_lower[i]), float(lim.command_upper[i])])
        steps = np.abs(np.diff(np.vstack([self._measured_positions(), positions]), axis=0))
        durations = np.diff(np.concatenate([[0.0], times]))[:, None]
        if velocities is None:
            checks = ((1.5 * steps / durations, lim.velocity, "rad/s"),
                      (6.0 * steps / durations**2, lim.acceleration, "rad/s^2"),
                      (12.0 * steps / durations**3, lim.jerk, "rad/s^3"))
            velocities = np.zeros_like(positions)
        else:
            velocities = np.atleast_2d(np.asarray(velocities, dtype=np.float64))
            if velocities.shape != positions.shape or not np.all(np.isfinite(velocities)):
                raise LimitViolation("trajectory velocities: one per joint per point, finite",
                                     field="trajectory.velocities", value=velocities.tolist()[:3])
            checks = ((steps / durations, lim.velocity, "rad/s"), (np.abs(velocities), lim.velocity, "rad/s"))
        for needed, limit, unit in checks:
            over = needed > limit * (1 + 1e-9)
            if np.any(over):
                k, i = map(int, np.argwhere(over)[0])
                raise LimitViolation(f"reaching waypoint {k} needs {needed[k, i]:.4g} {unit}", joint=lim.names[i],
                                     value=float(needed[k, i]), limit=float(limit[i]))
        return [[float(t), p.tolist(), v.tolist()] for t, p, v in zip(times, positions, velocities)]

    def path_times(self, positions) -> np.ndarray:
        """The shortest times (s from now, ``(k,)``) at which the controller's cubic through ``positions`` ``(k, d)``,
        resting at every point, keeps the velocity, acceleration and jerk limits (see :meth:`trajectory_points`),
        from the measured state; each segment at least one command period."""
        lim = self.limits
        positions = np.atleast_2d(np.asarray(positions, dtype=np.float64))
        steps = np.abs(np.diff(np.vstack([self._measured_positions(), positions]), axis=0))
        durations = np.max(np.maximum.reduce([1.5 * steps / lim.velocity, np.sqrt(6.0 * steps / lim.acceleration),
                                              np.cbrt(12.0 * steps / lim.jerk)]), axis=1)
        return np.cumsum(np.maximum(durations * (1 + 1e-6), lim.period))

    def _measured_positions(self) -> np.ndarray:
        """The newest joint state's positions in :meth:`joint_names` order (a :class:`ConnectionLost` before the
        first, a :class:`~pliant.errors.DriverError` if it lacks a joint)."""
        state = self._state
        if state is None:
            raise ConnectionLost("no joint state received yet: a trajectory starts where the arm is")
        index = {n: i for i, n in enumerate(state.names)}
        missing = [n for n in self._names if n not in index]
        if missing:
            raise LimitViolation(f"the joint states lack {', '.join(missing)}", field="joints",
                                 value=list(state.names))
        return np.asarray(state.positions, dtype=np.float64)[[index[n] for n in self._names]]

    def send_trajectory(self, times, positions, velocities=None) -> None:
        """Send one whole trajectory to the trajectory controller (``times`` s from now, ``(k,)``; ``positions``
        ``(k, d)`` in :meth:`joint_names` order), after :meth:`trajectory_points` checked it.  Not while a command
        stream runs (its commands would replace the trajectory every period): open the driver without one
        (``driver.open()``), send, watch :meth:`latest_state`, and :meth:`hold` to stop."""
        if getattr(self, "_stream", None) is not None:
            raise ConfigError("send_trajectory is for a driver opened without a command stream (driver.open(), not "
                              "`with driver`)", field="mode", value=self.options.mode)
        self._send({"op": "t", "points": self.trajectory_points(times, positions, velocities)})

    def send_path(self, positions) -> np.ndarray:
        """Send ``positions`` ``(k, d)`` as one trajectory at :meth:`path_times` (within the limits); returns the
        times.  Same conditions as :meth:`send_trajectory`."""
        times = self.path_times(positions)
        self.send_trajectory(times, positions)
        return times

    def hold(self) -> None:
        """Tell the trajectory controller to hold where it is (an empty JointTrajectory)."""
        self._send({"op": "t", "points": []})


@dataclass(frozen=True)
class IiwaRos2Options(Ros2ControlOptions):
    """Options of ``iiwa-ros2``: those of ``ros2-control`` with the lbr_fri_ros2_stack's defaults."""

    namespace: str = option(IIWA_ROS2["namespace"], "the robot's ROS namespace (the stack's robot_name)")
    joints: tuple[str, ...] = option(IIWA_ROS2["joints"], "the controllers' joints (lbr_controllers.yaml)")
    pliant_joints: tuple[str, ...] = option(IIWA_ROS2["pliant_joints"], "the same axes as pliant's iiwa robot "
                                            "model and the limits file name them")


class IiwaRos2Driver(Ros2ControlDriver):
    """The KUKA LBR iiwa 7 R800 under the lbr_fri_ros2_stack (``iiwa-ros2``; :mod:`pliant_ros2.robots`)."""

    Options = IiwaRos2Options
    preset_limits = IIWA_LIMITS
