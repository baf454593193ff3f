"""The transport every ROS 1 driver shares: the process's node, the master watchdog, state and command topics.

:class:`RosDriver` implements the :class:`~pliant.interfaces.Driver` transport contract for a robot whose joint
states arrive on one topic and whose commands go out on another; the robots' modules (:mod:`pliant_ros1.pr2`,
:mod:`pliant_ros1.baxter`, :mod:`pliant_ros1.iiwa`) say which topics and how a command is serialised.  Smoothing,
limits, watchdogs, joint-name mapping, time-stamp checks and stops are pliant's core (``pliant.hardware``), not
here.

* :meth:`RosDriver.open` checks that the master answers (one-line :class:`~pliant.errors.ConnectionLost` naming
  it otherwise), makes this process a ROS node of it (once per process: :mod:`pliant_ros1.node`), subscribes to
  the joint states, advertises the command topic and waits (up to ``connect_timeout``) until the robot's controller
  subscribes to it.
* While connected, a watchdog thread asks the master for its pid every ``master_check_period`` s.  A master that
  stops answering (or restarts) is reported as ``lost`` by :meth:`RosDriver.robot_status`: the core's stream then
  raises ``ConnectionLost`` and brakes the arm to rest within its limits over the connections that still work
  (topics flow peer to peer, without the master), and the error reaches the caller.
* :meth:`RosDriver.latest_state` is the newest joint-state message as received (names, positions, velocities,
  ``header.stamp`` in s, arrival time, a message counter), never blocking.
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np
from pliant.api import ConnectionLost, Driver, DriverOptions, JointState, RobotStatus, option

from pliant_ros1.robots import RosRobot, ros_robot

#: the master every driver talks to unless told otherwise
DEFAULT_MASTER_URI = "http://127.0.0.1:11311"


def default_master_uri() -> str:
    """``ROS_MASTER_URI`` from the environment, else ``http://127.0.0.1:11311``."""
    return os.environ.get("ROS_MASTER_URI") or DEFAULT_MASTER_URI


@dataclass(frozen=True)
class RosDriverOptions(DriverOptions):
    """Options every ROS 1 driver shares (plus :class:`pliant.interfaces.DriverOptions`)."""

    master_uri: str = option(None, "ROS master URI (default: $ROS_MASTER_URI, else http://127.0.0.1:11311)",
                             default_factory=default_master_uri)
    master_timeout: float = option(0.5, "seconds the ROS master may take to answer one check; connecting, three "
                                   "checks without an answer or a refused connection and the master is lost",
                                   minimum=0.01, maximum=60.0)
    master_grace: float = option(3.0, "seconds a connected ROS master may stay silent (three checks at least) "
                                 "before it is lost; a refused connection is lost at once", minimum=0.0,
                                 maximum=600.0)
    master_check_period: float = option(0.1, "seconds between two checks of the ROS master while connected",
                                        minimum=0.01, maximum=10.0)


class RosDriver(Driver):
    """Base of the ROS 1 drivers (see the module docstring); subclasses set :attr:`robot` and implement
    :meth:`_connect` (extra topics), :meth:`_command` (one command message) and, where the robot has them,
    :meth:`_status` and :meth:`enable`."""

    Options = RosDriverOptions
    #: ``pr2``, ``baxter`` or ``iiwa``
    robot: ClassVar[str] = ""

    def __init__(self, options: Any = None, **kwargs: Any) -> None:
        super().__init__(options, **kwargs)
        self._spec: RosRobot | None = None
        self._connected = False
        self._state: JointState | None = None
        self._count = 0
        self._watch = None
        self._subscribers: list = []
        self._publishers: list = []
        self._command_pub = None
        self._io = threading.Lock()

    # --- what the robot is ---------------------------------------------------------------------------------

    @property
    def spec(self) -> RosRobot:
        """The robot's topics, joints and limits file (:mod:`pliant_ros1.robots`)."""
        if self._spec is None:
            self._spec = ros_robot(self.robot, getattr(self.options, "side", "right"))
        return self._spec

    def joint_names(self) -> tuple[str, ...]:
        """The arm's joints in command order, as its URDF names them."""
        return self.spec.joints

    def default_limits_file(self):
        """The plugin's limits file of this arm (``pliant_ros1/limits/``)."""
        return self.spec.limits_file

    # --- the transport -------------------------------------------------------------------------------------

    def open(self) -> None:
        """Connect (see the module docstring); raises :class:`ConnectionLost` in one line naming what is
        unreachable."""
        from pliant_ros1.node import MASTER_PATIENCE, MasterWatch, ensure_node, wait_for

        if self._connected:
            return
        o = self.options
        ensure_node(o.master_uri, timeout=o.master_timeout, attempts=MASTER_PATIENCE)
        self._state, self._count = None, 0
        try:
            self._watch = MasterWatch(o.master_uri, o.master_check_period, o.master_timeout,
                                      grace=o.master_grace).start()
            self._connect()
            self._command_pub = self._command_publisher()
            if not wait_for(lambda: self._command_pub.get_num_connections() > 0, o.connect_timeout):
                raise ConnectionLost(f"nothing subscribes to {self._command_pub.resolved_name} within "
                                     f"{o.connect_timeout:g} s (is the robot's controller running on "
                                     f"{o.master_uri}?)")
        except BaseException:
            self.shutdown()
            raise
        self._connected = True

    def shutdown(self) -> None:
        """Unsubscribe, unadvertise and stop the master watchdog (the node itself lives on); safe to call twice."""
        self._connected = False
        watch, self._watch = self._watch, None
        if watch is not None:
            watch.stop()
        handles = self._subscribers + self._publishers
        self._subscribers, self._publishers, self._command_pub = [], [], None
        if handles:
            # unregistering talks to the master; a dead remote master must not hang the caller
            worker = threading.Thread(target=_unregister, args=(handles,), daemon=True,
                                      name="pliant-ros-unregister")
            worker.start()
            worker.join(timeout=2.0)

    def latest_state(self) -> JointState | None:
        """The newest joint state received (non-blocking), ``None`` before the first."""
        return self._state

    def write(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Publish one command (positions ``(d,)`` rad, velocities ``(d,)`` rad/s, in :meth:`joint_names` order)."""
        publisher = self._command_pub
        if publisher is None:
            raise ConnectionLost("the driver is not connected")
        publisher.publish(self._command(np.asarray(positions, dtype=np.float64),
                                        np.asarray(velocities, dtype=np.float64)))

    def robot_status(self) -> RobotStatus:
        """The robot's status; ``lost`` says why once the ROS master stopped answering (the core then raises
        :class:`ConnectionLost` and brakes)."""
        status = self._status() if self._connected else RobotStatus(enabled=False, detail="not connected")
        watch = self._watch
        if watch is not None and watch.error is not None:
            status = replace(status, lost=watch.error)
        return status

    # --- for subclasses --------------------------------------------------------------------------------------

    def _connect(self) -> None:
        """Subscribe to the joint states (and, in subclasses, whatever else the robot needs)."""
        from sensor_msgs.msg import JointState as JointStateMsg

        self._subscribe(self.spec.state_topic, JointStateMsg, self._on_joint_state)

    def _command_publisher(self):
        raise NotImplementedError

    def _command(self, positions: np.ndarray, velocities: np.ndarray):
        raise NotImplementedError

    def _status(self) -> RobotStatus:
        return RobotStatus()

    def _subscribe(self, topic: str, message_type: type, callback) -> None:
        import rospy

        self._subscribers.append(rospy.Subscriber(topic, message_type, callback, queue_size=None,
                                                  tcp_nodelay=True))

    def _advertise(self, topic: str, message_type: type, *, latch: bool = False):
        import rospy

        publisher = rospy.Publisher(topic, message_type, queue_size=10, latch=latch)
        self._publishers.append(publisher)
        return publisher

    def _received(self, names: tuple[str, ...], positions, velocities, stamp: float) -> None:
        """Record one state message (called from rospy's receiving thread)."""
        self._count += 1
        self._state = JointState(names, np.asarray(positions, dtype=np.float64),
                                 None if velocities is None else np.asarray(velocities, dtype=np.float64),
                                 float(stamp), time.monotonic(), self._count)

    def _on_joint_state(self, msg) -> None:
        """A ``sensor_msgs/JointState``: names as sent; velocities only when there is one per name."""
        names = tuple(msg.name)
        velocities = msg.velocity if len(msg.velocity) == len(names) else None
        self._received(names, msg.position, velocities, msg.header.stamp.to_sec())


def _unregister(handles: list) -> None:
    for handle in handles:
        try:
            handle.unregister()
        except Exception:  # the master may be gone; the connections close either way
            pass
