"""Robot peers: one ROS node per robot that behaves as that robot's controller, for testing the drivers.

::

    python -m pliant_ros1.testing baxter --side right --master http://127.0.0.1:11311 --record commands.jsonl
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

The arm moves in a pliant simulator (:mod:`pliant_ros1.testing.emulator`, default ``kinematic`` at 500 Hz in the robot's
default scene), so the joint states are physical.  Every command received is appended to the ``--record`` file
(JSON lines, flushed at once): ``{"kind": "command", "t": monotonic s, "positions": [...] (the arm's joints in
command order, null for a joint the message did not name), "velocities": [...] or null, "names": [...],
"accepted": bool}``; the arm's state at 50 Hz (``"kind": "state"``) and every fault switch (``"kind": "event"``)
go there too, so a test can check every command against the limits file
(:func:`~pliant_ros1.testing.record.command_violations`).

**Fault switches**: publish a ``std_msgs/String`` on ``/pliant_peer/fault`` (``--fault-topic``), e.g.
``rostopic pub -1 /pliant_peer/fault std_msgs/String stale``;
:meth:`~pliant_ros1.testing.process.PeerProcess.fault` does it from Python.

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
stops the peer cleanly; ``--exit-with-parent PID`` also stops it when that process dies
(:class:`~pliant_ros1.testing.process.PeerProcess` passes its own pid, so a crashed test leaves no peer behind).
"""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from pliant.api import JointLimits, load_limits

from pliant_ros1.robots import ROBOTS, joint_limits_from_urdf, ros_robot, state_joints, urdf_path
from pliant_ros1.testing.emulator import SIMULATORS, ArmEmulator, build_simulator

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
