"""The driver's ROS 2 node, in a child process of its own (``python -m pliant_ros2.bridge CONFIG``).

Started by :class:`pliant_ros2.driver.Ros2ControlDriver` with :func:`pliant_ros2.environment.ros2_environment` (the
reasons are in that module): rclpy, Fast DDS and the ROS 2 message packages live only here.  The two processes speak
JSON lines over the child's stdin and stdout.

From the driver (stdin): ``{"op": "p", "p": [...]}`` one position command (``std_msgs/Float64MultiArray`` on the
forward controller's ``commands`` topic, in the controller's joint order); ``{"op": "t", "points": [[t, [p...],
[v...]], ...]}`` a ``trajectory_msgs/JointTrajectory`` for the trajectory controller (no points: hold where you
are); ``{"op": "graph"}`` a look at the ROS graph; ``{"op": "quit"}`` (or the end of stdin): leave.

To the driver (stdout): ``{"k": "ready"}``; ``{"k": "s", "n": names, "p": positions, "v": velocities or null, "t":
header stamp (s)}`` for every ``sensor_msgs/JointState``; ``{"k": "c", ...}`` how many subscribers the command topics
have and how many publishers the state topic has, whenever that changes; ``{"k": "g", ...}`` the graph;
``{"k": "e", "m": message}`` an error.

Shutdown joins the executor thread before ``rclpy.shutdown`` (shutting down under a spinning executor aborts).
"""

from __future__ import annotations

import json
import sys
import threading
import time

#: history depth of the command publishers: a second of commands at 100 Hz, so that a burst (this process or the
#: controller's starved for a moment) is delivered whole instead of losing its oldest commands
COMMAND_DEPTH = 100


def qos(kind: str, depth: int = 10):
    """``reliable`` or ``best_effort`` QoS (volatile, keep last ``depth``)."""
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    reliability = ReliabilityPolicy.RELIABLE if kind == "reliable" else ReliabilityPolicy.BEST_EFFORT
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=reliability)


def stamp_seconds(stamp) -> float:
    """A ROS 2 time stamp (``builtin_interfaces/Time``) in seconds."""
    return stamp.sec + 1e-9 * stamp.nanosec


def graph(node, topics: list[str]) -> dict:
    """The graph as this node sees it: every topic with its types, publisher and subscriber counts; the nodes."""
    out = {"topics": {}, "nodes": sorted(f"{ns.rstrip('/')}/{n}" for n, ns in node.get_node_names_and_namespaces())}
    for name, types in node.get_topic_names_and_types():
        out["topics"][name] = {"types": list(types), "publishers": node.count_publishers(name),
                               "subscribers": node.count_subscribers(name)}
    for name in topics:
        out["topics"].setdefault(name, {"types": [], "publishers": 0, "subscribers": 0})
    return out


class Bridge:
    """The node: subscriptions, publishers, the executor thread and the JSON-lines link to the driver."""

    def __init__(self, config: dict) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray
        from trajectory_msgs.msg import JointTrajectory

        self.config = config
        self._out = threading.Lock()
        self.context = rclpy.Context()
        rclpy.init(args=["--ros-args", "--disable-external-lib-logs"], context=self.context,
                   signal_handler_options=SignalHandlerOptions.NO)        # no log files
        self.node = rclpy.create_node(config.get("node", "pliant_ros2_driver"), context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.node.create_subscription(JointState, config["state_topic"], self._on_state, qos(config["state_qos"]))
        self.commands = self.node.create_publisher(Float64MultiArray, config["command_topic"],
                                                   qos(config["command_qos"], COMMAND_DEPTH))
        self.trajectories = self.node.create_publisher(JointTrajectory, config["trajectory_topic"],
                                                       qos(config["command_qos"], COMMAND_DEPTH))
        self._counts = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name="pliant-ros2-spin", daemon=True)

    def send(self, message: dict) -> None:
        line = json.dumps(message, separators=(",", ":"))
        with self._out:
            sys.stdout.write(line + "\n")
            sys.stdout.flush()

    def _on_state(self, msg) -> None:
        n = len(msg.name)
        self.send({"k": "s", "n": list(msg.name), "p": list(msg.position),
                   "v": list(msg.velocity) if len(msg.velocity) == n else None, "t": stamp_seconds(msg.header.stamp)})

    def _spin(self) -> None:
        next_count = 0.0
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.02)
            now = time.monotonic()
            if now >= next_count:
                next_count = now + 0.05
                counts = {"k": "c", "command": self.commands.get_subscription_count(),
                          "trajectory": self.trajectories.get_subscription_count(),
                          "state": self.node.count_publishers(self.config["state_topic"])}
                if counts != self._counts:
                    self._counts = counts
                    self.send(counts)

    def command(self, positions: list[float]) -> None:
        from std_msgs.msg import Float64MultiArray

        self.commands.publish(Float64MultiArray(data=[float(x) for x in positions]))

    def trajectory(self, points: list) -> None:
        from builtin_interfaces.msg import Duration
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

        msg = JointTrajectory()
        msg.joint_names = list(self.config["joints"])      # header.stamp zero: start now
        for t, p, v in points:
            sec = int(t)
            since = Duration(sec=sec, nanosec=min(round((t - sec) * 1e9), 999_999_999))
            msg.points.append(JointTrajectoryPoint(positions=[float(x) for x in p],
                                                   velocities=[float(x) for x in v] if v else [],
                                                   time_from_start=since))
        self.trajectories.publish(msg)

    def run(self) -> None:
        self._thread.start()
        self.send({"k": "ready"})
        topics = [self.config["state_topic"], self.config["command_topic"], self.config["trajectory_topic"]]
        try:
            for line in sys.stdin:
                if not line.strip():
                    continue
                try:
                    request = json.loads(line)
                    op = request.get("op")
                    if op == "p":
                        self.command(request["p"])
                    elif op == "t":
                        self.trajectory(request["points"])
                    elif op == "graph":
                        self.send({"k": "g", **graph(self.node, topics)})
                    elif op == "quit":
                        break
                except Exception as exc:  # report, keep serving: the driver decides
                    self.send({"k": "e", "m": f"{type(exc).__name__}: {exc}"})
        finally:
            self.close()

    def close(self) -> None:
        import rclpy

        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        try:
            self.executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
        finally:
            rclpy.shutdown(context=self.context)


def main(argv: list[str] | None = None) -> int:
    """``python -m pliant_ros2.bridge CONFIG``: start the node with the JSON ``CONFIG`` and serve the driver over stdin
    and stdout until it leaves; returns 1, after an error line, when ROS 2 fails to start."""
    argv = sys.argv[1:] if argv is None else argv
    config = json.loads(argv[0])
    try:
        bridge = Bridge(config)
    except Exception as exc:
        sys.stdout.write(json.dumps({"k": "e", "m": f"ROS 2 failed to start: {type(exc).__name__}: {exc}"}) + "\n")
        sys.stdout.flush()
        return 1
    bridge.run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
