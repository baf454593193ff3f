"""The driver kind: the transport to a real robot, and the user side (move_to, stream, follow) that always
goes through the core's safety layer and command stream (:mod:`pliant.hardware`).
"""

from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pliant.components.base import Component
from pliant.components.context import Context
from pliant.errors import (
    DriverError,
    JointMismatch,
    LimitViolation,
)
from pliant.hardware.limits import JointLimits
from pliant.hardware.state import JointState, RobotStatus
from pliant.options import option
from pliant.results import Path


@dataclass(frozen=True)
class DriverOptions:
    """Options every driver shares (driver plugins extend this dataclass)."""

    limits: str | None = option(None, "limits file (TOML, pliant.hardware.limits); default the plugin's own for "
                                "its robot")
    command_rate: float | None = option(None, "commands per second (Hz); default the limits file's",
                                        minimum=1.0, maximum=10000.0)
    speed_scale: float = option(1.0, "fraction of the velocity limits used (acceleration scales with its square, "
                                "jerk with its cube)", minimum=1e-3, maximum=1.0)
    state_timeout: float | None = option(None, "stale-state watchdog deadline (s); default the limits file's",
                                         minimum=1e-3)
    max_state_rate: float | None = option(None, "joint-state messages per second beyond which the robot floods "
                                          "(a fault); default the limits file's", minimum=1.0)
    connect_timeout: float = option(5.0, "seconds to wait for the robot's first state when connecting",
                                    minimum=0.01)
    reach_tolerance: float = option(0.01, "move_to / follow: largest joint error (rad) that counts as arrived",
                                    minimum=1e-6)
    move_timeout: float = option(60.0, "move_to / follow: seconds to wait for arrival beyond the planned "
                                 "duration", minimum=0.0)


class Driver(Component):
    """A real (or emulated) robot, commanded through the core's safety layer (DESIGN rule 9).

    **What users call** (implemented here, in the core): ``with driver: ...`` (connect, and on leaving for any
    reason stop within the limits and disconnect), :meth:`move_to`, :meth:`follow` (a timed path),
    :meth:`stream` (a target that may change every cycle; ruckig blends, no stop), :meth:`stop`,
    :meth:`state`, :meth:`check`.  A driver is also an *execution world*: :meth:`reset`, :meth:`step`,
    :meth:`configuration` are the protocol :func:`pliant.execution.loop.execute` drives simulators through, so a
    controller or a policy runs closed-loop on the robot's measured joint states.

    **What a driver plugin implements** (the transport, nothing else): :meth:`joint_names`,
    :meth:`default_limits_file`, :meth:`open`, :meth:`shutdown`, :meth:`latest_state`, :meth:`write` and,
    where the robot has them, :meth:`robot_status` and :meth:`enable`.  Only the core's command stream calls
    :meth:`write`, and only with commands the safety layer passed.
    """

    kind = "driver"
    Options = DriverOptions

    # --- the transport a plugin implements ----------------------------------------------------------------

    @abstractmethod
    def joint_names(self) -> tuple[str, ...]:
        """The commanded joints, in command order (the robot's URDF names)."""

    @abstractmethod
    def default_limits_file(self) -> Any:
        """The plugin's limits file for its robot (a path), used unless the ``limits`` option names another."""

    @abstractmethod
    def open(self) -> None:
        """Open the connection; raise :class:`~pliant.errors.ConnectionLost` (one line: what is unreachable)."""

    @abstractmethod
    def shutdown(self) -> None:
        """Close the connection and release everything :meth:`open` took; safe to call twice."""

    @abstractmethod
    def latest_state(self) -> JointState | None:
        """The newest joint state received (non-blocking), ``None`` before the first.  May raise a
        :class:`~pliant.errors.DriverError` (the stream treats it as any fault: a controlled stop)."""

    @abstractmethod
    def write(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Put one command on the wire: positions ``(d,)`` and velocities ``(d,)`` in :meth:`joint_names` order.

        Called only by the core's command stream, at the command rate, after the safety checks.
        """

    def robot_status(self) -> RobotStatus:
        """Whether the robot is enabled, e-stopped, faulted or lost; the default is a robot that is always ready."""
        return RobotStatus()

    def enable(self) -> None:
        """Enable the robot's motors where the robot needs it (Baxter, CiA 402 drives); default nothing."""

    # --- what users call ----------------------------------------------------------------------------------

    @property
    def limits(self) -> JointLimits:
        """The limits in force (the limits file, at the ``command_rate`` and ``speed_scale`` options)."""
        if getattr(self, "_limits", None) is None:
            from pliant.hardware.limits import load_limits

            o = self.options
            limits = load_limits(o.limits if o.limits is not None else self.default_limits_file())
            limits = limits.select(self.joint_names())
            if o.command_rate is not None:
                limits = limits.with_rate(o.command_rate)
            if o.state_timeout is not None:
                limits = replace(limits, state_timeout=o.state_timeout)
            if o.max_state_rate is not None:
                limits = replace(limits, max_state_rate=o.max_state_rate)
            self._limits = limits.scaled(o.speed_scale) if o.speed_scale < 1 else limits
        return self._limits

    @property
    def session(self):
        """The running :class:`~pliant.hardware.stream.CommandStream` (connect first)."""
        stream = getattr(self, "_stream", None)
        if stream is None:
            raise DriverError("the driver is not connected; use `with driver:` or call connect()",
                              field="driver", value=type(self).__name__)
        return stream

    def bind(self, context: Context) -> None:
        """Check that the pipeline's robot commands the same joints, in the same order."""
        super().bind(context)
        robot = context.robot
        description = robot.urdf_description() if robot is not None else None
        if description is not None and tuple(description.joint_names) != tuple(self.joint_names()):
            raise JointMismatch(f"the pipeline's robot plans joints {list(description.joint_names)} but this "
                                f"driver commands {list(self.joint_names())}", field="driver")

    def connect(self) -> None:
        """Open the connection, wait for a fresh state, check the robot is ready and start streaming."""
        from pliant.hardware.stream import CommandStream

        if getattr(self, "_stream", None) is not None:
            return
        self.open()
        try:
            stream = CommandStream(self, self.limits, connect_timeout=self.options.connect_timeout,
                                   reach_tolerance=self.options.reach_tolerance,
                                   move_timeout=self.options.move_timeout)
            stream.start()
        except BaseException:
            self.shutdown()
            raise
        self._stream = stream

    def close(self) -> None:
        """Stop within the limits (if moving) and disconnect; safe to call twice."""
        stream = getattr(self, "_stream", None)
        self._stream = None
        try:
            if stream is not None:
                stream.close()
        finally:
            self.shutdown()

    def __enter__(self) -> Driver:
        self.connect()
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def state(self) -> np.ndarray:
        """The measured joint positions ``(d,)`` (rad), in :meth:`joint_names` order."""
        return self.session.measured().positions

    def measured(self):
        """The newest checked measurement: ``positions`` ``(d,)`` rad, ``velocities`` ``(d,)`` rad/s (estimated from
        successive states where the robot reports none) and ``time`` (:func:`time.monotonic`, s)."""
        return self.session.measured()

    def move_to(self, q: np.ndarray, *, wait: bool = True) -> np.ndarray:
        """Move to ``q`` ``(d,)`` and (with ``wait``) return the measured positions once there."""
        return self.session.move_to(q, wait=wait)

    def follow(self, path: Path, *, wait: bool = True) -> np.ndarray:
        """Follow a timed path (``path.times`` in s, ``(k,)``); ruckig keeps it within the limits."""
        return self.session.follow(path, wait=wait)

    def send(self, path: Path) -> None:
        """Execute a timed path and wait until the robot arrives (:meth:`follow`)."""
        self.follow(path)

    def stream(self, target: np.ndarray, velocity: np.ndarray | None = None, *, hold: float | None = None) -> None:
        """Set the streamed target ``(d,)`` (optionally with a target velocity ``(d,)``); returns at once.

        A new target mid-motion blends into the current motion (online ruckig).  With a non-zero velocity the
        target expires after ``hold`` s (default four command periods): then the robot stops.
        """
        self.session.stream(target, velocity, hold=hold)

    def stop(self, *, wait: bool = True) -> np.ndarray:
        """Decelerate to rest within the limits; returns the measured positions."""
        return self.session.stop(wait=wait)

    def check(self, *, enable: bool = False) -> dict[str, Any]:
        """Report state, status, limits and rates, raising the first problem found as a one-line
        :class:`~pliant.errors.DriverError`.  Not connected: look at the robot without commanding it (and enable it
        only with ``enable``); connected: report the running stream (with the measured command rate)."""
        if getattr(self, "_stream", None) is not None:
            return self._stream.report()
        from pliant.hardware.stream import inspect_robot

        return inspect_robot(self, self.limits, connect_timeout=self.options.connect_timeout, enable=enable)

    # --- the execution protocol (the same as a simulator's) -----------------------------------------------

    def reset(self, q: np.ndarray) -> None:
        """Move to ``q`` (a robot cannot be placed; it drives there within its limits).

        A start on a position limit (baxter-reach starts with ``right_s1`` at its URDF limit) is driven to within
        the position margin, the closest configuration a command may hold; a start further out is refused
        (:class:`~pliant.errors.LimitViolation`)."""
        limits = self.limits
        q = np.asarray(q, dtype=np.float64)
        inside = np.clip(q, limits.command_lower, limits.command_upper)
        outside = np.abs(q - inside) > limits.position_margin + 1e-9
        if np.any(outside):
            i = int(np.argmax(outside))
            raise LimitViolation(f"start {q[i]:.6g} rad lies beyond the position limits",
                                 joint=limits.names[i], value=float(q[i]),
                                 limit=[float(limits.lower[i]), float(limits.upper[i])])
        self.move_to(inside)

    def configuration(self) -> np.ndarray:
        return self.state()

    def step(self, velocity: np.ndarray, dt: float, rng: np.random.Generator | None = None) -> np.ndarray:
        """Command ``velocity`` ``(d,)`` (rad/s) for ``dt`` s of real time; return the measured ``(d,)`` after."""
        return self.session.step(velocity, dt)

    def settle(self) -> np.ndarray:
        """End of an execution: decelerate to rest within the limits; returns the measured rest configuration."""
        return self.stop()

    def in_contact(self) -> bool:
        """Drivers do not sense contact; the contact controller notices it from the measured motion."""
        return False

    def object_poses(self) -> dict[str, np.ndarray]:
        return {}
