"""Robot peers: one ROS node per robot that behaves as that robot's controller, for testing the drivers.

::

    python -m pliant_ros1.peer baxter --side right --master http://127.0.0.1:11311 --record commands.jsonl
    pliant ros-peer pr2 --side left --simulator pybullet

A peer speaks the robot's own topics, types and rates (:mod:`pliant_ros1.robots`):

* **baxter**: ``/robot/joint_states`` at 100 Hz naming both arms, the head and the torso (``head_nod, head_pan,
  left_e0 ... right_w2, torso_t0``); ``/robot/state`` (AssemblyState) at 20 Hz and on every change; commands on
  ``/robot/limb/<side>/joint_command`` (POSITION_MODE only; other modes are recorded and ignored).  It starts
  *disabled* (``--enabled`` to start enabled) until ``/robot/set_super_enable`` is true, ignores commands while
  disabled or e-stopped, holds position 0.2 s after the last command, and follows commands at most at
  ``speed_ratio`` x the velocity limits (0.3 at start, set on ``/robot/limb/<side>/set_speed_ratio``).
* **pr2**: ``/joint_states`` at 100 Hz naming every movable joint of the PR2 URDF; single-point (or multi-point:
  the last point is the goal) ``JointTrajectory`` on ``/<r|l>_arm_controller/command``; it holds the last point.
  ``/power_board/state`` (``pr2_msgs/PowerBoardState``) at 1 Hz and on every change, ``/pr2_ethercat/motors_halted``
  (latched) on every change, and the services ``/pr2_ethercat/reset_motors`` and ``halt_motors``
  (``std_srvs/Empty``); it starts with the motors running and ignores commands while they are halted.
* **iiwa**: ``/iiwa/state/JointPosition`` at 250 Hz (no names, float32 values); ``/iiwa/command/JointPosition``; it
  keeps going to the last destination.

The arm moves in a pliant simulator (:mod:`pliant_ros1.emulator`, default ``kinematic`` at 500 Hz in the robot's
default scene), so the joint states are physical.  Every command received is appended to the ``--record`` file
(JSON lines, flushed at once): ``{"kind": "command", "t": monotonic s, "positions": [...] (the arm's joints in
command order, null for a joint the message did not name), "velocities": [...] or null, "names": [...],
"accepted": bool}``; the arm's state at 50 Hz (``"kind": "state"``) and every fault switch (``"kind": "event"``)
go there too, so a test can check every command against the limits file (:func:`command_violations`).

**Fault switches**: publish a ``std_msgs/String`` on ``/pliant_peer/fault`` (``--fault-topic``), e.g.
``rostopic pub -1 /pliant_peer/fault std_msgs/String stale``; :meth:`PeerProcess.fault` does it from Python.

============== =============================================================================================
``stale``      stop publishing joint states (the node stays up; commands are still obeyed)
``names-wrong`` rename the arm's first joint in the joint states (``<name>_renamed``)
``names-shuffle`` publish the joints in a shuffled order (positions shuffled alike: still correct data)
``names-duplicate`` name the arm's first joint twice (in place of its second)
``stamps-backwards`` from now on, stamp joint states 1 s earlier (one jump back in time)
``stamps-repeat`` keep stamping joint states with one frozen time while the arm moves
``flood``      publish joint states at ``--flood-rate`` (default 10 kHz)
``disable``    (Baxter) disable the robot; (PR2) halt the motors: it holds and ignores commands until enabled again
``estop``      (Baxter) assert the e-stop (button pressed, source user); (PR2) press the run-stop (the motors halt):
               disabled, enabling refused
``die``        exit at once (``os._exit``), as a crashed controller
``clear``      end every switch above (after an e-stop the robot stays disabled, as Baxter after a reset and a PR2
               whose motors need reset_motors)
============== =============================================================================================

Joint states are stamped with the wall-clock time of the physics tick they sample (as a real controller stamps
its samples), so a stalled simulation shows as repeated stamps, and the driver's watchdog sees it.  If the physics
loop fails the peer says so on stderr and exits (status 3) rather than publish a frozen arm.  SIGTERM or Ctrl-C
stops the peer cleanly; ``--exit-with-parent PID`` also stops it when that process dies (:class:`PeerProcess`
passes its own pid, so a crashed test leaves no peer behind).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from pliant.api import JointLimits, load_limits

from pliant_ros1.emulator import SIMULATORS, ArmEmulator, build_simulator
from pliant_ros1.robots import ROBOTS, SIDES, joint_limits_from_urdf, ros_robot, state_joints, urdf_path

#: where fault switches arrive
DEFAULT_FAULT_TOPIC = "/pliant_peer/fault"
#: the fault switches (see the module docstring)
FAULTS = ("stale", "names-wrong", "names-shuffle", "names-duplicate", "stamps-backwards", "stamps-repeat", "flood",
          "disable", "estop", "die", "clear")
#: how far inside the command range the default start configuration is placed (rad)
START_MARGIN = 0.05
#: the peer's state lines in the record file, per second
RECORD_STATE_RATE = 50.0
#: Baxter's /robot/state rate (Hz; also published on every change)
ASSEMBLY_RATE = 20.0
#: the PR2's /power_board/state rate (Hz; also published on every change) and its EtherCAT master's namespace
POWER_RATE = 1.0
PR2_ETHERCAT = "/pr2_ethercat"
READY = "pliant-peer ready"


class RobotPeer:
    """A robot's controller on ROS (see the module docstring); :meth:`start`, then :meth:`run` or :meth:`stop`.

    robot: ``pr2``, ``baxter`` or ``iiwa``.  side: ``right`` / ``left`` (PR2, Baxter).  master_uri: the ROS master.
    scene / simulator / simulator_options / physics_rate (Hz): the simulated arm.  state_rate: joint states per
    second (default the robot's).  record: the JSON-lines file of commands, states and events.  start: the initial
    joint positions (default the scene's start moved ``START_MARGIN`` inside the command range).  limits: a limits
    file (default the plugin's).  enabled: Baxter starts enabled (default disabled, as the real robot).
    speed_ratio: Baxter's initial speed ratio (0.3).  flood_rate: joint states per second during ``flood``.
    """

    def __init__(self, robot: str, side: str = "right", *, master_uri: str | None = None, scene: str | None = None,
                 simulator: str = "kinematic", simulator_options: dict[str, Any] | None = None,
                 physics_rate: float = 500.0, state_rate: float | None = None, record: str | Path | None = None,
                 start=None, limits: str | Path | None = None, seed: int = 0, enabled: bool = False,
                 speed_ratio: float = 0.3, fault_topic: str = DEFAULT_FAULT_TOPIC,
                 flood_rate: float = 10000.0) -> None:
        from pliant.api import ConfigError

        if robot not in ROBOTS:
            raise ConfigError(f"unknown robot (peers: {', '.join(ROBOTS)})", field="robot", value=robot)
        if simulator not in SIMULATORS:
            raise ConfigError(f"must be one of {', '.join(SIMULATORS)}", field="simulator", value=simulator)
        self.spec = ros_robot(robot, side)
        self.robot = robot
        self.side = side
        self.master_uri = master_uri or os.environ.get("ROS_MASTER_URI") or "http://127.0.0.1:11311"
        self.limits: JointLimits = load_limits(limits or self.spec.limits_file).select(self.spec.joints)
        self.scene_name = scene or self.spec.scene
        self.simulator_name = simulator
        self.simulator_options = dict(simulator_options or {})
        self.physics_rate = float(physics_rate)
        self.state_rate = float(state_rate or self.spec.state_rate)
        self.flood_rate = float(flood_rate)
        self.record_path = Path(record) if record is not None else None
        self.start_positions = None if start is None else np.asarray(start, dtype=np.float64)
        self.seed = seed
        self.fault_topic = fault_topic
        # robot state
        self.enabled = bool(enabled) if robot == "baxter" else True
        self.estop = False
        self.speed_ratio = float(speed_ratio) if robot == "baxter" else 1.0
        # fault switches
        self.publishing = True
        self.flood = False
        self.names_fault = ""
        self.stamp_offset = 0.0
        self.frozen_stamp: float | None = None
        self.rng = np.random.default_rng(seed)
        self._permutation: np.ndarray | None = None
        # plumbing
        self.emulator: ArmEmulator | None = None
        self._record = None
        self._record_lock = threading.Lock()
        self._stop = threading.Event()
        self._assembly_changed = threading.Event()      # Baxter: publish /robot/state now
        self._threads: list[threading.Thread] = []
        self._handles: list = []
        self._next_record_state = 0.0
        self.commands_received = 0
        self.states_published = 0

    # --- set-up ----------------------------------------------------------------------------------------------

    def _start_configuration(self, scene) -> np.ndarray:
        if self.start_positions is not None:
            q = self.start_positions
        else:
            q = np.asarray(scene.start, dtype=np.float64)
            q = np.clip(q, self.limits.command_lower + START_MARGIN, self.limits.command_upper - START_MARGIN)
        if q.shape != (self.limits.dof,):
            from pliant.api import ConfigError

            raise ConfigError(f"needs {self.limits.dof} joint positions", field="start", value=q.tolist())
        return q

    def _fixed_positions(self) -> dict[str, float]:
        """The joints the peer does not move: 0, or the middle of their URDF range when 0 is outside it."""
        values = {}
        path = urdf_path(self.robot)
        for name in state_joints(self.robot):
            try:
                limit = joint_limits_from_urdf(path, name)
            except KeyError:                       # a state joint the URDF lacks (Baxter's head_nod, torso_t0)
                values[name] = 0.0
                continue
            lo, hi = limit["lower"], limit["upper"]
            values[name] = 0.0 if lo is None or hi is None or lo <= 0.0 <= hi else 0.5 * (lo + hi)
        return values

    def start(self) -> RobotPeer:
        """Build the simulated arm, join the ROS graph and start publishing."""
        from pliant import api

        from pliant_ros1.node import ensure_node

        if self.simulator_name == "none":
            simulator, scene = None, api.load_scene(self.scene_name)
        else:
            simulator, scene = build_simulator(self.scene_name, self.spec.group, self.simulator_name, self.limits,
                                               self.physics_rate, self.simulator_options)
        self.emulator = ArmEmulator(self.limits, self._start_configuration(scene), simulator=simulator,
                                    physics_rate=self.physics_rate, command_timeout=self.spec.command_timeout,
                                    speed_ratio=self.speed_ratio, seed=self.seed, on_tick=self._on_tick,
                                    on_error=self._on_physics_error)
        self.emulator.active = self.enabled and not self.estop
        if self.record_path is not None:
            self.record_path.parent.mkdir(parents=True, exist_ok=True)
            self._record = open(self.record_path, "a", buffering=1)
        self.state_names = list(state_joints(self.robot))
        fixed = self._fixed_positions()
        self.state_values = np.array([fixed[n] for n in self.state_names])
        self.arm_index = np.array([self.state_names.index(n) for n in self.spec.joints])
        self.joint_index = {n: i for i, n in enumerate(self.spec.joints)}
        ensure_node(self.master_uri, name=f"pliant_peer_{self.robot}", timeout=2.0)
        self._advertise()
        self.emulator.start()
        self._spawn(self._publish_states, "pliant-peer-states")
        if self.robot == "baxter":
            self._spawn(self._publish_assembly, "pliant-peer-assembly")
        if self.robot == "pr2":
            self._spawn(self._publish_power, "pliant-peer-power")
        self._event(f"started: {self.robot} {self.side} at {self.emulator.state()[0].round(4).tolist()}, "
                    f"simulator {self.simulator_name}, enabled {self.enabled}")
        return self

    def _spawn(self, target, name: str) -> None:
        thread = threading.Thread(target=target, name=name, daemon=True)
        thread.start()
        self._threads.append(thread)

    def _advertise(self) -> None:
        import rospy
        from std_msgs.msg import String

        from pliant_ros1.messages import message_class

        def subscribe(topic, kind, callback):
            self._handles.append(rospy.Subscriber(topic, kind, callback, queue_size=None, tcp_nodelay=True))

        def advertise(topic, kind, **kwargs):
            publisher = rospy.Publisher(topic, kind, queue_size=100, **kwargs)
            self._handles.append(publisher)
            return publisher

        subscribe(self.fault_topic, String, lambda msg: self.fault(msg.data))
        if self.robot == "iiwa":
            self._state_type = message_class("iiwa_msgs/JointPosition")
            subscribe(self.spec.command_topic, self._state_type, self._on_iiwa_command)
        else:
            from sensor_msgs.msg import JointState

            self._state_type = JointState
        self._state_pub = advertise(self.spec.state_topic, self._state_type)
        if self.robot == "pr2":
            from std_msgs.msg import Bool
            from std_srvs.srv import Empty, EmptyResponse
            from trajectory_msgs.msg import JointTrajectory

            subscribe(self.spec.command_topic, JointTrajectory, self._on_pr2_command)
            self._power_type = message_class("pr2_msgs/PowerBoardState")
            self._power_pub = advertise("/power_board/state", self._power_type)
            self._halted_pub = advertise(f"{PR2_ETHERCAT}/motors_halted", Bool, latch=True)

            def reset(_request):
                self._set_enabled(not self.estop, "reset_motors" + (" refused: run-stop pressed" if self.estop
                                                                   else ""))
                return EmptyResponse()

            def halt(_request):
                self._set_enabled(False, "halt_motors")
                return EmptyResponse()

            self._handles.append(rospy.Service(f"{PR2_ETHERCAT}/reset_motors", Empty, reset))
            self._handles.append(rospy.Service(f"{PR2_ETHERCAT}/halt_motors", Empty, halt))
        if self.robot == "baxter":
            from std_msgs.msg import Bool, Float64

            subscribe(self.spec.command_topic, message_class("baxter_core_msgs/JointCommand"),
                      self._on_baxter_command)
            subscribe("/robot/set_super_enable", Bool, self._on_enable)
            subscribe(f"/robot/limb/{self.side}/set_speed_ratio", Float64, self._on_speed_ratio)
            self._assembly_type = message_class("baxter_core_msgs/AssemblyState")
            self._assembly_pub = advertise("/robot/state", self._assembly_type, latch=True)

    # --- the record -------------------------------------------------------------------------------------------

    def _write(self, line: dict) -> None:
        if self._record is None:
            return
        text = json.dumps(line, separators=(",", ":"))
        with self._record_lock:
            if not self._record.closed:
                self._record.write(text + "\n")

    def _event(self, event: str) -> None:
        self._write({"kind": "event", "t": time.monotonic(), "event": event})

    def _on_tick(self, now: float, q: np.ndarray, v: np.ndarray) -> None:
        if now >= self._next_record_state:
            self._next_record_state = now + 1.0 / RECORD_STATE_RATE
            line = {"kind": "state", "t": now, "positions": q.tolist(), "velocities": v.tolist()}
            simulator = self.emulator.simulator
            if simulator is not None:           # ground truth a real robot does not have: for the benchmark
                line["contact"] = bool(simulator.in_contact())
            self._write(line)

    def _on_physics_error(self, exc: BaseException) -> None:
        import traceback

        self._event(f"the physics loop failed: {type(exc).__name__}: {exc}")
        traceback.print_exception(exc, file=sys.stderr)
        print(f"pliant-peer: the simulated arm failed ({type(exc).__name__}: {exc}); exiting", file=sys.stderr,
              flush=True)
        if self._record is not None:
            self._record.flush()
        os._exit(3)

    def _received(self, positions: np.ndarray, velocities, names, accepted: bool,
                  duration: float | None = None) -> None:
        self.commands_received += 1
        self._write({"kind": "command", "t": time.monotonic(),
                     "positions": [None if np.isnan(p) else float(p) for p in positions],
                     "velocities": None if velocities is None else
                     [None if np.isnan(x) else float(x) for x in velocities],
                     "names": list(names), "accepted": accepted})
        if accepted:
            self.emulator.command(positions, duration)

    def _by_name(self, names, values) -> np.ndarray:
        out = np.full(self.limits.dof, np.nan)
        for name, value in zip(names, values):
            i = self.joint_index.get(name)
            if i is not None:
                out[i] = value
        return out

    # --- commands ---------------------------------------------------------------------------------------------

    def _on_baxter_command(self, msg) -> None:
        positions = self._by_name(msg.names, msg.command)
        ok = msg.mode == 1 and len(msg.names) == len(msg.command)
        self._received(positions, None, msg.names, ok and self.enabled and not self.estop)

    def _on_pr2_command(self, msg) -> None:
        if not msg.points:
            return
        point = msg.points[-1]
        velocities = self._by_name(msg.joint_names, point.velocities) if len(point.velocities) else None
        self._received(self._by_name(msg.joint_names, point.positions), velocities, msg.joint_names,
                       len(point.positions) == len(msg.joint_names) and self.enabled and not self.estop,
                       point.time_from_start.to_sec())

    def _on_iiwa_command(self, msg) -> None:
        p = msg.position
        self._received(np.array([p.a1, p.a2, p.a3, p.a4, p.a5, p.a6, p.a7], dtype=np.float64), None,
                       self.spec.joints, True)

    def _on_enable(self, msg) -> None:
        self._set_enabled(bool(msg.data) and not self.estop, f"set_super_enable {bool(msg.data)}")

    def _on_speed_ratio(self, msg) -> None:
        self.speed_ratio = float(np.clip(msg.data, 0.0, 1.0))
        self.emulator.speed_ratio = self.speed_ratio
        self._event(f"speed ratio {self.speed_ratio:g}")

    def _set_enabled(self, enabled: bool, why: str) -> None:
        if enabled != self.enabled:
            self.enabled = enabled
            self._event(f"{'enabled' if enabled else 'disabled'} ({why})")
        self.emulator.active = self.enabled and not self.estop
        if not self.emulator.active:
            self.emulator.hold()
        if self.robot in ("baxter", "pr2"):
            self._assembly_changed.set()

    # --- faults -----------------------------------------------------------------------------------------------

    def fault(self, name: str) -> None:
        """Switch on fault ``name`` (one of :data:`FAULTS`; see the module docstring)."""
        name = name.strip()
        self._event(f"fault {name}")
        if name == "stale":
            self.publishing = False
        elif name in ("names-wrong", "names-shuffle", "names-duplicate"):
            self._permutation = self.rng.permutation(len(self.state_names)) if name == "names-shuffle" else None
            self.names_fault = name
        elif name == "stamps-backwards":
            self.stamp_offset -= 1.0
        elif name == "stamps-repeat":
            self.frozen_stamp = self.emulator.state()[2]
        elif name == "flood":
            self.flood = True
        elif name == "disable" and self.robot in ("baxter", "pr2"):
            self._set_enabled(False, "fault switch")
        elif name == "estop" and self.robot in ("baxter", "pr2"):
            self.estop = True
            self._set_enabled(False, "e-stop")
        elif name == "die":
            if self._record is not None:
                self._record.flush()
            os._exit(17)
        elif name == "clear":
            self.publishing, self.flood, self.names_fault, self.frozen_stamp = True, False, "", None
            if self.estop:
                self.estop = False
                self._set_enabled(False, "e-stop released: reset leaves the robot disabled")
        else:
            self._event(f"unknown or inapplicable fault {name!r} for {self.robot} (known: {', '.join(FAULTS)})")

    # --- publishing -------------------------------------------------------------------------------------------

    def _state_message(self):
        import rospy

        q, v, sampled = self.emulator.state()
        stamp = (self.frozen_stamp if self.frozen_stamp is not None else sampled) + self.stamp_offset
        if self.robot == "iiwa":
            msg = self._state_type()
            msg.header.stamp = rospy.Time.from_sec(stamp)
            p = msg.position
            p.a1, p.a2, p.a3, p.a4, p.a5, p.a6, p.a7 = (float(x) for x in q)
            return msg
        positions = self.state_values.copy()
        velocities = np.zeros(len(positions))
        positions[self.arm_index] = q
        velocities[self.arm_index] = v
        names = list(self.state_names)
        if self.names_fault == "names-wrong":
            names[self.arm_index[0]] += "_renamed"
        elif self.names_fault == "names-duplicate":
            names[self.arm_index[1]] = names[self.arm_index[0]]
        elif self.names_fault == "names-shuffle" and self._permutation is not None:
            order = self._permutation
            names, positions, velocities = [names[i] for i in order], positions[order], velocities[order]
        msg = self._state_type()
        msg.header.stamp = rospy.Time.from_sec(stamp)
        msg.name, msg.position, msg.velocity = names, positions.tolist(), velocities.tolist()
        return msg

    def _publish_states(self) -> None:
        next_tick = time.monotonic()
        while not self._stop.is_set():
            if self.publishing:
                try:
                    self._state_pub.publish(self._state_message())
                    self.states_published += 1
                except Exception:  # the node is shutting down
                    if self._stop.is_set():
                        return
                    raise
            next_tick += 1.0 / (self.flood_rate if self.flood else self.state_rate)
            delay = next_tick - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            elif delay < -0.1:
                next_tick = time.monotonic()

    def _publish_assembly(self) -> None:
        while not self._stop.is_set():
            msg = self._assembly_type(ready=self.enabled and not self.estop, enabled=self.enabled,
                                      stopped=self.estop, error=False, estop_button=1 if self.estop else 0,
                                      estop_source=1 if self.estop else 0)
            try:
                self._assembly_pub.publish(msg)
            except Exception:
                if self._stop.is_set():
                    return
                raise
            self._assembly_changed.wait(1.0 / ASSEMBLY_RATE)
            self._assembly_changed.clear()

    def _publish_power(self) -> None:
        """PR2: /power_board/state at POWER_RATE and on every change; motors_halted (latched) on every change."""
        from std_msgs.msg import Bool

        halted = None
        while not self._stop.is_set():
            msg = self._power_type(name="pliant peer power board", run_stop=not self.estop,
                                   wireless_stop=True, master_state=2, circuit_state=[3, 3, 3])
            now_halted = not self.enabled or self.estop
            try:
                self._power_pub.publish(msg)
                if now_halted != halted:
                    self._halted_pub.publish(Bool(now_halted))
                    halted = now_halted
            except Exception:
                if self._stop.is_set():
                    return
                raise
            self._assembly_changed.wait(1.0 / POWER_RATE)
            self._assembly_changed.clear()

    # --- running ----------------------------------------------------------------------------------------------

    def run(self, duration: float | None = None, parent: int | None = None) -> None:
        """Block until ``duration`` s passed, :meth:`stop` was called, SIGTERM / Ctrl-C arrived, or (with
        ``parent``) the process of that pid is no longer this one's parent (it died)."""
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGTERM, signal.SIGINT):
                signal.signal(sig, lambda *_: self._stop.set())
        end = None if duration is None else time.monotonic() + duration
        while not self._stop.is_set():
            left = None if end is None else end - time.monotonic()
            if left is not None and left <= 0:
                break
            self._stop.wait(0.5 if left is None else min(0.5, left))
            if parent is not None and os.getppid() != parent:
                self._event("the parent process is gone: stopping")
                break
        self.stop()

    def stop(self) -> None:
        """Stop publishing and moving, leave the ROS graph, close the record."""
        self._stop.set()
        self._assembly_changed.set()
        for thread in self._threads:
            thread.join(timeout=2.0)
        self._threads = []
        if self.emulator is not None:
            self.emulator.stop()
        for handle in self._handles:
            try:
                (handle.unregister if hasattr(handle, "unregister") else handle.shutdown)()   # topics; services
            except Exception:
                pass
        self._handles = []
        with self._record_lock:
            if self._record is not None and not self._record.closed:
                self._record.close()


# --- reading a record ------------------------------------------------------------------------------------------


def read_record(path: str | Path) -> list[dict]:
    """Every line of a peer's record file (a partly written last line is skipped)."""
    out = []
    for line in Path(path).read_text().splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return out


def command_violations(records: list[dict], limits: JointLimits, *, tolerance: float = 1e-6) -> list[str]:
    """Every received command that broke ``limits``, in words: a joint missing or non-finite, a position outside
    ``[lower + margin, upper - margin]``, a velocity beyond its limit, or a step between consecutive commands larger
    than the step limit.  ``tolerance`` (rad, rad/s) absorbs float32 rounding (the iiwa's messages)."""
    out = []
    previous = None
    slack = tolerance + 1e-6 * np.maximum(np.abs(limits.lower), np.abs(limits.upper))
    for record in records:
        if record.get("kind") != "command":
            continue
        t = record["t"]
        p = np.array([np.nan if x is None else x for x in record["positions"]], dtype=np.float64)
        if not np.all(np.isfinite(p)):
            out.append(f"t={t:.3f}: a joint missing or non-finite: {record['positions']}")
            continue
        bad = np.flatnonzero((p < limits.command_lower - slack) | (p > limits.command_upper + slack))
        if bad.size:
            i = bad[0]
            out.append(f"t={t:.3f}: {limits.names[i]} at {p[i]:.6f} outside "
                       f"[{limits.command_lower[i]:.6f}, {limits.command_upper[i]:.6f}]")
        if record.get("velocities") is not None:
            v = np.array([np.nan if x is None else x for x in record["velocities"]], dtype=np.float64)
            bad = np.flatnonzero(~np.isfinite(v) | (np.abs(v) > limits.velocity * (1 + 1e-6) + tolerance))
            if bad.size:
                i = bad[0]
                out.append(f"t={t:.3f}: {limits.names[i]} velocity {v[i]:.6f} beyond {limits.velocity[i]:.6f}")
        if previous is not None:
            step = np.abs(p - previous)
            bad = np.flatnonzero(step > limits.max_step + 2 * slack)
            if bad.size:
                i = bad[0]
                out.append(f"t={t:.3f}: {limits.names[i]} stepped {step[i]:.6f} > {limits.max_step[i]:.6f}")
        previous = p
    return out


# --- a peer in another process ----------------------------------------------------------------------------------


class PeerProcess:
    """``python -m pliant_ros1.peer ROBOT ...`` as a child process (tests, benchmarks).

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
        """The peer's command line (this Python, ``-m pliant_ros1.peer``, the robot and the options)."""
        args = [sys.executable, "-m", "pliant_ros1.peer", self.robot, "--side", self.side, "--master",
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
            ensure_node(self.master_uri)
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


# --- the command line -------------------------------------------------------------------------------------------


def _option_value(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` with VALUE read as a TOML value when it is one (``[0.5, 1.0]``, ``"proportional"``, ``true``,
    ``2.5``), else as the text itself (``proportional``)."""
    import tomllib

    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    key, value = (part.strip() for part in text.split("=", 1))
    try:
        return key, tomllib.loads(f"value = {value}")["value"]
    except tomllib.TOMLDecodeError:
        return key, value


def add_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The peer's command-line arguments (``python -m pliant_ros1.peer`` and ``pliant ros-peer``)."""
    parser.add_argument("robot", choices=ROBOTS, help="which robot's controller to emulate")
    parser.add_argument("--side", choices=SIDES, default="right", help="the arm (PR2, Baxter; default right)")
    parser.add_argument("--master", default=None,
                        help="ROS master URI (default $ROS_MASTER_URI, else http://127.0.0.1:11311)")
    parser.add_argument("--scene", default=None, help="scene name or file (default: the robot's: baxter-reach, "
                        "iiwa-shelf, the plugin's pr2-arm)")
    parser.add_argument("--simulator", choices=SIMULATORS, default="kinematic",
                        help="what moves the arm (default kinematic; none: an ideal servo, no contact)")
    parser.add_argument("--sim-option", action="append", type=_option_value, default=[], metavar="KEY=VALUE",
                        help="a simulator option (repeatable), e.g. self_collision=true")
    parser.add_argument("--physics-rate", type=float, default=500.0, help="physics ticks per second (default 500)")
    parser.add_argument("--state-rate", type=float, default=None, help="joint states per second (default: the "
                        "robot's: Baxter and PR2 100, iiwa 250)")
    parser.add_argument("--flood-rate", type=float, default=10000.0,
                        help="joint states per second during the flood fault (default 10000)")
    parser.add_argument("--record", default=None, help="append every command received (JSON lines) to this file")
    parser.add_argument("--start", default=None, help="initial joint positions, comma-separated (rad)")
    parser.add_argument("--limits", default=None, help="limits file (default the plugin's for the robot)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the simulator's noise and the shuffles")
    parser.add_argument("--enabled", action="store_true", help="Baxter: start enabled (the real robot starts "
                        "disabled)")
    parser.add_argument("--speed-ratio", type=float, default=0.3, help="Baxter: initial position-mode speed "
                        "ratio (default 0.3, as the real robot)")
    parser.add_argument("--fault-topic", default=DEFAULT_FAULT_TOPIC, help="where fault switches arrive "
                        f"(std_msgs/String; default {DEFAULT_FAULT_TOPIC})")
    parser.add_argument("--duration", type=float, default=None, help="seconds to run (default: until Ctrl-C)")
    parser.add_argument("--exit-with-parent", type=int, default=None, metavar="PID",
                        help="stop when the process PID is no longer this one's parent (PeerProcess passes its own)")
    return parser


def run_from_args(args: argparse.Namespace) -> int:
    """Start a peer from parsed arguments, print the ready line, run until told to stop."""
    start = None if args.start is None else [float(x) for x in args.start.split(",") if x.strip()]
    peer = RobotPeer(args.robot, args.side, master_uri=args.master, scene=args.scene, simulator=args.simulator,
                     simulator_options=dict(args.sim_option), physics_rate=args.physics_rate,
                     state_rate=args.state_rate, record=args.record, start=start, limits=args.limits,
                     seed=args.seed, enabled=args.enabled, speed_ratio=args.speed_ratio,
                     fault_topic=args.fault_topic, flood_rate=args.flood_rate)
    peer.start()
    # this process is the robot's controller and nothing else: its threads (physics, joint states at 100-250 Hz)
    # keep their timing better with the heap of the simulator's setup frozen (later collections walk only what
    # running allocates) and a 1 ms thread switch interval, as the drivers' command stream does (pliant.hardware)
    gc.freeze()
    sys.setswitchinterval(0.001)
    print(f"{READY} {args.robot} {peer.side if args.robot != 'iiwa' else ''} on {peer.master_uri}: state "
          f"{peer.spec.state_topic}, commands {peer.spec.command_topic}, faults {peer.fault_topic}", flush=True)
    peer.run(args.duration, parent=args.exit_with_parent)
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m pliant_ros1.peer``."""
    from pliant.api import PliantError

    parser = add_arguments(argparse.ArgumentParser(prog="python -m pliant_ros1.peer", description=__doc__.split(
        "\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter))
    args = parser.parse_args(argv)
    try:
        code = run_from_args(args)
    except PliantError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    # the peer's topics are unregistered already; rospy's own shutdown would take another 0.6 s
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    sys.exit(main())
