"""An emulated ros2_control arm: a ROS 2 node with the topics of a ``forward_command_controller``, a
``joint_trajectory_controller`` and a ``joint_state_broadcaster`` (runs in the ROS 2 environment: no pliant import).

The arm: each joint a first-order position servo (time constant ``tau``) toward the active command, stepped at the
controller manager's ``rate``; states published every step, stamped with the wall-clock time of the step (not of
the publication, which a loaded machine delays), in the controllers' joint order.  The forward controller takes
``std_msgs/Float64MultiArray`` on ``/<ns>/<forward>/commands`` (a message of the wrong length is ignored, as
ros2_control does); the trajectory controller takes ``trajectory_msgs/JointTrajectory`` on
``/<ns>/<trajectory>/joint_trajectory`` (joint names matched by name, time from receipt, cubic between points with
velocities, linear without; no points: hold).  Both subscribe reliably, as ros2_control's do.

Fault switches (one word per line on stdin, or :meth:`ControlPeer.fault`): ``stale`` (states stop),
``names-wrong`` (states name other joints), ``jump`` (states jump by 0.5 rad), ``deactivate`` (the forward controller
unsubscribes: nothing consumes the commands), ``freeze`` (the arm stops following commands), ``die`` (the process
exits at once), ``clear``.

Every command received, every trajectory, the arm's state at 50 Hz and every fault go to a JSON-lines record
(``t``: :func:`time.monotonic`, comparable across processes of one machine).
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time

import numpy as np

READY = "pliant ros2 peer ready"
FAULTS = ("stale", "names-wrong", "jump", "deactivate", "freeze", "die", "clear")


class ControlPeer:
    """The node and its emulated arm (see the module docstring)."""

    def __init__(self, joints, start, *, namespace: str = "", forward: str = "forward_position_controller",
                 trajectory: str = "joint_trajectory_controller", state_topic: str = "joint_states",
                 rate: float = 100.0, tau: float = 0.02, record: str | None = None) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rclpy.signals import SignalHandlerOptions
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray
        from trajectory_msgs.msg import JointTrajectory

        def name(*parts):
            return "/" + "/".join(p.strip("/") for p in (namespace, *parts) if p.strip("/"))

        self.joints = list(joints)
        self.position = np.array(start, dtype=np.float64)
        self.velocity = np.zeros_like(self.position)
        self.command = self.position.copy()
        self.rate, self.tau = rate, tau
        self.trajectory_plan = None
        self.faults: set[str] = set()
        self._record = open(record, "a", buffering=1) if record else None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.context = rclpy.Context()
        rclpy.init(args=["--ros-args", "--disable-external-lib-logs"], context=self.context,
                   signal_handler_options=SignalHandlerOptions.NO)        # no log files
        self.node = rclpy.create_node("pliant_ros2_peer", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        # depth 100: a burst of commands after a stall is recorded whole (what the driver sent), not its newest 10
        reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        self.topics = {"command": name(forward, "commands"), "trajectory": name(trajectory, "joint_trajectory"),
                       "state": name(state_topic)}
        self._forward = self.node.create_subscription(Float64MultiArray, self.topics["command"], self._on_command,
                                                      reliable)
        self.node.create_subscription(JointTrajectory, self.topics["trajectory"], self._on_trajectory, reliable)
        self.states = self.node.create_publisher(JointState, self.topics["state"], reliable)
        self._JointState = JointState

    # --- the controllers ------------------------------------------------------------------------------------

    def _log(self, **record) -> None:
        if self._record is not None:
            self._record.write(json.dumps({"t": time.monotonic(), **record}) + "\n")

    def _on_command(self, msg) -> None:
        data = list(msg.data)
        self._log(kind="command", positions=data)
        if len(data) != len(self.joints):
            return                                      # ros2_control: "command size does not match", ignored
        with self._lock:
            self.trajectory_plan = None
            self.command = np.array(data, dtype=np.float64)

    def _on_trajectory(self, msg) -> None:
        now = time.monotonic()
        points = [(p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec, list(p.positions), list(p.velocities))
                  for p in msg.points]
        self._log(kind="trajectory", names=list(msg.joint_names), points=points)
        with self._lock:
            if not points:
                self.trajectory_plan = None
                self.command = self.position.copy()     # an empty trajectory: hold
                return
            if sorted(msg.joint_names) != sorted(self.joints):
                return                                  # the JTC rejects a trajectory for other joints
            order = [list(msg.joint_names).index(j) for j in self.joints]
            times = np.array([0.0] + [t for t, _, _ in points])
            q = np.array([self.position] + [np.array(p)[order] for _, p, _ in points])
            have_v = all(len(v) == len(self.joints) for _, _, v in points)
            v = np.array([self.velocity] + [np.array(x)[order] for _, _, x in points]) if have_v else None
            for _, p, _ in points:                      # every point received counts as a command (the record)
                self._log(kind="command", positions=np.array(p)[order].tolist(), source="trajectory")
            self.trajectory_plan = (now, times, q, v)

    def _sample(self, now: float) -> None:
        start, times, q, v = self.trajectory_plan
        t = now - start
        if t >= times[-1]:
            self.command = q[-1].copy()
            self.trajectory_plan = None
            return
        k = max(0, int(np.searchsorted(times, t, side="right")) - 1)
        h = times[k + 1] - times[k]
        s = (t - times[k]) / h
        if v is None:
            self.command = q[k] + s * (q[k + 1] - q[k])
        else:                                           # cubic Hermite
            h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
            self.command = h00 * q[k] + h10 * h * v[k] + h01 * q[k + 1] + h11 * h * v[k + 1]

    # --- the arm and the broadcaster --------------------------------------------------------------------------

    def tick(self, now: float, dt: float) -> None:
        with self._lock:
            if self.trajectory_plan is not None:
                self._sample(now)
            previous = self.position.copy()
            if "freeze" not in self.faults:
                alpha = 1.0 - np.exp(-dt / self.tau) if self.tau > 0 else 1.0
                self.position = self.position + alpha * (self.command - self.position)
            self.velocity = (self.position - previous) / dt
            position, velocity = self.position.copy(), self.velocity.copy()
        if "stale" in self.faults:
            return
        msg = self._JointState()
        wall = time.time() - (time.monotonic() - now)     # stamped when sampled, as the broadcaster's update() is
        msg.header.stamp.sec = int(wall)
        msg.header.stamp.nanosec = int((wall - int(wall)) * 1e9)
        msg.name = [f"{j}_wrong" for j in self.joints] if "names-wrong" in self.faults else list(self.joints)
        msg.position = (position + 0.5 if "jump" in self.faults else position).tolist()
        msg.velocity = velocity.tolist()
        self.states.publish(msg)

    def fault(self, name: str) -> None:
        """Switch a fault on (``clear``: all off)."""
        if name not in FAULTS:
            raise ValueError(f"unknown fault {name!r} ({', '.join(FAULTS)})")
        self._log(kind="fault", fault=name)
        if name == "die":
            os._exit(3)
        if name == "clear":
            self.faults.clear()
            return
        self.faults.add(name)
        if name == "deactivate" and self._forward is not None:
            self.node.destroy_subscription(self._forward)
            self._forward = None

    def run(self) -> None:
        """Step the arm at ``rate`` and serve the topics until :meth:`stop`."""
        period = 1.0 / self.rate
        next_tick = time.monotonic()
        next_record = 0.0
        last = next_tick
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_tick:
                self.tick(now, max(now - last, 1e-4))
                last = now
                next_tick += period
                if next_tick < now:
                    next_tick = now + period
                if now >= next_record:
                    next_record = now + 0.02
                    self._log(kind="state", positions=self.position.tolist(), velocities=self.velocity.tolist())
            self.executor.spin_once(timeout_sec=max(0.0, min(next_tick - time.monotonic(), 0.01)))

    def stop(self) -> None:
        self._stop.set()

    def close(self) -> None:
        import rclpy

        try:
            self.executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
        finally:
            rclpy.shutdown(context=self.context)
            if self._record is not None:
                self._record.close()


def serve(peer: ControlPeer, *, exit_with_parent: int | None = None) -> None:
    """Run ``peer`` in this thread until Ctrl-C, ``quit`` on stdin, or (``exit_with_parent``) the parent process
    gone; fault switches arrive on stdin, one per line.  The end of stdin ends only the reading (a peer started in the
    background with no stdin keeps running)."""

    def read_faults():
        for line in sys.stdin:
            word = line.strip()
            if word == "quit":
                peer.stop()
                return
            if word:
                try:
                    peer.fault(word)
                except ValueError as exc:
                    print(f"error: {exc}", flush=True)

    def watch_parent():
        while not peer._stop.is_set():
            if os.getppid() != exit_with_parent:
                peer.stop()
            time.sleep(0.2)

    threading.Thread(target=read_faults, daemon=True).start()
    if exit_with_parent:
        threading.Thread(target=watch_parent, daemon=True).start()
    print(f"{READY}: joints {' '.join(peer.joints)}; {peer.topics['command']}, {peer.topics['trajectory']}, "
          f"{peer.topics['state']}", flush=True)
    try:
        peer.run()
    finally:
        peer.close()
