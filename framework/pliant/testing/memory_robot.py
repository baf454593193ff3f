"""An in-process emulated robot behind the real driver interface, for testing the core and driver-using code.

:class:`MemoryRobot` is a joint-position servo: a thread at ``physics_rate`` moves every joint toward the latest
command at up to its velocity limit (a first-order servo with gain ``1 / servo_time``) and publishes the joint
state with a time stamp.  It records every command it receives (so a test can check each against the limits),
and has fault switches: ``publishing`` (stale state when false), ``names`` (what it reports), ``enabled``,
``estop``, ``fault``, ``stamp_offset`` (a negative jump makes stamps go backwards), ``repeat_stamp``,
``position_offset`` (rad, added to every reported position: a non-zero value set mid-motion is an encoder jump).
:class:`MemoryDriver` is the driver of such a robot (kind ``driver``; not registered by default: tests create it
directly).  It goes through the same command stream and safety layer as every driver.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pliant.components import Driver, DriverOptions
from pliant.hardware.limits import JointLimits
from pliant.hardware.state import JointState, RobotStatus
from pliant.options import option


class MemoryRobot:
    """An emulated position-controlled arm (see the module docstring); ``start()`` / ``stop()`` its thread."""

    def __init__(self, limits: JointLimits, start: np.ndarray | None = None, *, physics_rate: float = 1000.0,
                 servo_time: float = 0.005, enabled: bool = True) -> None:
        self.limits = limits
        self.positions = np.zeros(limits.dof) if start is None else np.array(start, dtype=np.float64)
        self.velocities = np.zeros(limits.dof)
        self.command: np.ndarray | None = None
        self.commands: list[tuple[float, np.ndarray, np.ndarray]] = []
        self.physics_rate = physics_rate
        self.servo_time = servo_time
        self.names = tuple(limits.names)
        self.publishing = True
        self.enabled = enabled
        self.estop = False
        self.fault = ""
        self.stamp_offset = 0.0
        self.repeat_stamp = False
        self.position_offset = 0.0
        self.state: JointState | None = None
        self.sequence = 0
        self._lock = threading.Lock()
        self._running = False
        self._thread: threading.Thread | None = None

    def receive(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """A command arrives (what the driver's ``write`` puts on the wire)."""
        with self._lock:
            self.commands.append((time.monotonic(), np.array(positions), np.array(velocities)))
            if self.enabled and not self.estop and not self.fault:
                self.command = np.array(positions)

    def start(self) -> MemoryRobot:
        self._running = True
        self._thread = threading.Thread(target=self._run, daemon=True, name="memory-robot")
        self._thread.start()
        return self

    def stop(self) -> None:
        self._running = False
        if self._thread is not None:
            self._thread.join(timeout=2.0)

    def _run(self) -> None:
        dt = 1.0 / self.physics_rate
        stamp = 0.0
        while self._running:
            with self._lock:
                if self.command is not None and self.enabled and not self.estop and not self.fault:
                    velocity = np.clip((self.command - self.positions) / max(self.servo_time, dt),
                                       -self.limits.velocity, self.limits.velocity)
                else:
                    velocity = np.zeros(self.limits.dof)
                self.positions = self.positions + velocity * dt
                self.velocities = velocity
                if not self.repeat_stamp:
                    stamp += dt
                if self.publishing:
                    self.sequence += 1
                    self.state = JointState(self.names, self.positions + self.position_offset, self.velocities.copy(),
                                            stamp + self.stamp_offset, time.monotonic(), self.sequence)
            time.sleep(dt)

    def violations(self) -> list[str]:
        """Every recorded command that broke a limit (position with margin, velocity, step), in words."""
        lim = self.limits
        out = []
        previous = None
        for t, p, v in self.commands:
            if np.any(p < lim.command_lower - 1e-9) or np.any(p > lim.command_upper + 1e-9):
                out.append(f"t={t:.3f}: position {p.tolist()}")
            if np.any(np.abs(v) > lim.velocity * (1 + 1e-6) + 1e-9):
                out.append(f"t={t:.3f}: velocity {v.tolist()}")
            if previous is not None and np.any(np.abs(p - previous) > lim.max_step + 1e-9):
                out.append(f"t={t:.3f}: step {np.abs(p - previous).max():.4g}")
            if not np.all(np.isfinite(p)) or not np.all(np.isfinite(v)):
                out.append(f"t={t:.3f}: non-finite")
            previous = p
        return out


@dataclass(frozen=True)
class MemoryDriverOptions(DriverOptions):
    """Options of :class:`MemoryDriver`."""

    robot_id: int = option(0, "which MemoryRobot (MemoryDriver.robots) this driver talks to", minimum=0)


class MemoryDriver(Driver):
    """The driver of a :class:`MemoryRobot` (registered in :attr:`robots` by ``robot_id``, with its limits file)."""

    Options = MemoryDriverOptions
    robots: dict[int, tuple[MemoryRobot, Path]] = {}

    def _robot(self) -> MemoryRobot:
        return self.robots[self.options.robot_id][0]

    def joint_names(self) -> tuple[str, ...]:
        return tuple(self._robot().limits.names)

    def default_limits_file(self) -> Path:
        return self.robots[self.options.robot_id][1]

    def open(self) -> None:
        self._open = True

    def shutdown(self) -> None:
        self._open = False

    def latest_state(self) -> JointState | None:
        return self._robot().state

    def write(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        self._robot().receive(positions, velocities)

    def robot_status(self) -> RobotStatus:
        robot = self._robot()
        return RobotStatus(enabled=robot.enabled, estop=robot.estop, fault=robot.fault)

    def enable(self) -> None:
        robot = self._robot()
        if not robot.estop and not robot.fault:
            robot.enabled = True
