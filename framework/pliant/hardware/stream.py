"""The command stream: one thread per connected driver that sends a checked, smoothed command every period.

:class:`CommandStream` is what :class:`~pliant.interfaces.Driver`'s public methods talk to.  Its thread wakes at
the command rate (absolute-time schedule; sleep, then a short spin for the last 1.5 ms or quarter period) and, every
cycle:

1. reads the newest joint state and checks it (:meth:`SafetyLayer.read_state`: names, order, stamps, the
   stale-state watchdog, floods) and the robot's status (disabled, e-stop, fault);
2. updates the target: a streamed target that carries a velocity expires after its ``hold`` time (then the robot
   stops), a followed path is sampled one period ahead;
3. advances the ruckig reference one period (:class:`OnlineSmoother`);
4. checks the command (:meth:`SafetyLayer.check_command`) and only then calls the driver's ``write``.

Streaming never pauses: Baxter, for one, holds position when commands arrive slower than 5 Hz, so the stream
keeps sending (the hold position when at rest).  Any refusal or fault is recorded as the stream's error and turns
the stream into a controlled stop: ruckig brakes the reference to rest within the velocity, acceleration and
jerk limits, every braking command still checked; a command that fails its check is never sent (the stream
then stops sending and the robot's own command timeout holds it).  The error is raised to the caller at its
next call (``move_to``, ``follow``, ``stream``, ``step``, ``stop``) and the stream refuses motion until the driver
reconnects.  Timing of every write is kept (:attr:`CommandStream.log`) for the benchmarks.

**The session protects its own timing** (:class:`RealTimeGuard`, process-wide while any stream runs): the stream,
the driver's receive threads and its watchdogs share the process with the planner and the controller, so at
start the heap is frozen (:func:`gc.freeze`: later collections walk only what is allocated while streaming,
instead of a planner's whole heap -- pauses of 0.2-0.9 s were measured without, longer than the 0.1 s state
watchdogs) and the interpreter's thread switch interval is lowered to :data:`SWITCH_INTERVAL` (a
thread waiting for the GIL gets it within a millisecond instead of five); both are restored when the last stream
closes.  Collector pauses while streaming are timed (:attr:`RealTimeGuard.longest_pause`, in :meth:`report`).
"""

from __future__ import annotations

import gc
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from pliant.errors import ConnectionLost, DriverError, LimitViolation, PliantError, StepTooLarge
from pliant.hardware.limits import JointLimits
from pliant.hardware.safety import SafetyLayer
from pliant.hardware.smoothing import OnlineSmoother

#: the last part of each period spent spinning instead of sleeping, for a steady command period (s): a sleeping
#: thread may wake up late by a millisecond on a busy machine; at most a quarter of the period
SPIN = 0.0015
#: a robot whose measured joint speeds are all below this (rad/s) has stopped
SETTLED = 1e-3
#: the longest a stop waits for the measured robot to come to rest after the command has (s)
SETTLE_TIME = 1.0
#: commands kept in :attr:`CommandStream.log` (about 10 minutes at 100 Hz)
LOG_LENGTH = 60000
#: the interpreter's thread switch interval while a stream runs (s; Python's default is 0.005)
SWITCH_INTERVAL = 0.001


class RealTimeGuard:
    """What a command stream does to the process to keep its timing, while any stream of the process runs.

    The first :meth:`acquire` freezes the heap (:func:`gc.freeze`, constant time), lowers the thread switch
    interval to :data:`SWITCH_INTERVAL` and starts timing collector pauses; the last :meth:`release` puts the
    switch interval back and unfreezes the heap -- unless it was frozen before the first acquire (by the caller,
    who then owns it).  The collector stays on: garbage made while streaming cannot pile up, and a collection only
    walks what was allocated since the freeze.  No full collection precedes the freeze: on a planner's heap it is
    itself the pause to avoid (0.2-0.9 s), and the driver's own threads (a CAN master's heartbeat, a ROS node's
    receive threads) already run when the stream starts; garbage frozen with the heap is freed after the release.
    Thread-safe; one instance per process (:data:`REALTIME`).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._users = 0
        self._switch: float | None = None
        self._unfreeze = False
        self._started: float | None = None
        #: collector pauses while streaming: how many, their total and the longest (s), since the first acquire
        self.pauses = 0
        self.pause_total = 0.0
        self.longest_pause = 0.0
        #: how many objects the freeze of the first acquire moved out of the collector's reach
        self.frozen = 0

    @property
    def active(self) -> bool:
        """Whether a stream holds the guard."""
        return self._users > 0

    def acquire(self) -> None:
        """Enter real-time mode (the first caller does the work)."""
        with self._lock:
            self._users += 1
            if self._users > 1:
                return
            self._unfreeze = gc.get_freeze_count() == 0
            gc.freeze()
            self.frozen = gc.get_freeze_count()
            self._switch = sys.getswitchinterval()
            sys.setswitchinterval(min(self._switch, SWITCH_INTERVAL))
            self.pauses, self.pause_total, self.longest_pause = 0, 0.0, 0.0
            gc.callbacks.append(self._on_gc)

    def release(self) -> None:
        """Leave real-time mode (the last caller restores the process)."""
        with self._lock:
            if self._users == 0:
                return
            self._users -= 1
            if self._users:
                return
            if self._on_gc in gc.callbacks:
                gc.callbacks.remove(self._on_gc)
            if self._switch is not None:
                sys.setswitchinterval(self._switch)
                self._switch = None
            if self._unfreeze:
                gc.unfreeze()

    def _on_gc(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._started = time.perf_counter()
        elif self._started is not None:
            pause = time.perf_counter() - self._started
            self._started = None
            self.pauses += 1
            self.pause_total += pause
            self.longest_pause = max(self.longest_pause, pause)

    def report(self) -> dict[str, float]:
        """Collector figures while streaming: ``gc_pauses`` (count), ``gc_pause_total`` and ``gc_longest_pause`` (s),
        ``gc_frozen`` (objects frozen)."""
        return {"gc_pauses": self.pauses, "gc_pause_total": self.pause_total, "gc_longest_pause": self.longest_pause,
                "gc_frozen": self.frozen}


#: the process's one :class:`RealTimeGuard`
REALTIME = RealTimeGuard()


@dataclass(frozen=True)
class Measured:
    """The robot's measured joint state in command order: positions ``(d,)`` rad, velocities ``(d,)`` rad/s,
    ``time`` (:func:`time.monotonic` of the newest state)."""

    positions: np.ndarray
    velocities: np.ndarray
    time: float


class CommandStream:
    """Streams commands for ``driver`` under ``limits``; see the module docstring.

    connect_timeout: seconds to wait for the first state and for the robot to enable.  reach_tolerance: largest
    joint error (rad) at which ``move_to`` / ``follow`` have arrived.  move_timeout: seconds beyond the planned
    duration before an arrival is declared failed.
    """

    def __init__(self, driver: Any, limits: JointLimits, *, connect_timeout: float = 5.0,
                 reach_tolerance: float = 0.01, move_timeout: float = 60.0) -> None:
        self.driver = driver
        self.limits = limits
        self.safety = SafetyLayer(limits)
        self.smoother = OnlineSmoother(limits)
        self.connect_timeout = connect_timeout
        self.reach_tolerance = reach_tolerance
        self.move_timeout = move_timeout
        #: largest lead (rad) of the reference over the measured position that :meth:`step` lets grow
        self.max_lead = 0.05
        self.error: DriverError | None = None
        #: ``(monotonic time of the write, positions, velocities)`` of every command sent
        self.log: deque[tuple[float, np.ndarray, np.ndarray]] = deque(maxlen=LOG_LENGTH)
        #: ``(monotonic time, positions)`` of every measured state the stream used
        self.measured_log: deque[tuple[float, np.ndarray]] = deque(maxlen=LOG_LENGTH)
        self.overruns = 0
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._measured: Measured | None = None
        self._expires: float | None = None
        self._streamed: tuple[np.ndarray, float] | None = None
        self._path: tuple[float, np.ndarray, np.ndarray] | None = None
        #: monotonic time of the cycle whose command finished the smoother's trajectory (None while moving)
        self._settled_at: float | None = None
        self._closing = False
        self._writing = True
        self._thread: threading.Thread | None = None
        self._cycles = 0
        self._last_step: float | None = None
        self._guarded = False

    # --- start and stop --------------------------------------------------------------------------------------

    def start(self) -> None:
        """Wait for a fresh state, make sure the robot is enabled, then start the thread (holding position).

        The process enters real-time mode first (:data:`REALTIME`: the heap collected and frozen, a short thread
        switch interval) and leaves it when the stream closes, or here if starting fails."""
        if not self._guarded:
            REALTIME.acquire()
            self._guarded = True
        try:
            self._start()
        except BaseException:
            self._unguard()
            raise

    def _unguard(self) -> None:
        if self._guarded:
            self._guarded = False
            REALTIME.release()

    def _start(self) -> None:
        deadline = time.monotonic() + self.connect_timeout
        state = None
        while time.monotonic() < deadline:
            state = self.driver.latest_state()
            if state is not None:
                break
            time.sleep(0.005)
        if state is None:
            raise ConnectionLost(f"no joint state from the robot within {self.connect_timeout:g} s",
                                 field="driver", value=type(self.driver).__name__)
        positions, velocities = self.safety.read_state(state, time.monotonic())
        status = self.driver.robot_status()
        if not status.enabled and not status.estop and not status.fault:
            self.driver.enable()
            while time.monotonic() < deadline and not (status := self.driver.robot_status()).enabled:
                time.sleep(0.01)
        self.safety.check_status(status)
        positions, velocities = self.safety.read_state(self.driver.latest_state(), time.monotonic())
        self._measured = Measured(positions, velocities, self.safety.fresh_at or time.monotonic())
        self.smoother.reset(positions)
        self.safety.begin(positions)
        self._thread = threading.Thread(target=self._run, name=f"pliant-{type(self.driver).__name__}", daemon=True)
        self._thread.start()

    def close(self, timeout: float = 10.0) -> None:
        """Stop within the limits (when moving and able to), then end the thread (and leave real-time mode)."""
        if self._thread is None:
            self._unguard()
            return
        try:
            with self._lock:
                self.smoother.brake("close")
            # after a fault too: the brake is already under way and must finish while commands can still be sent
            self._wait(lambda: self.smoother.at_rest or not self._writing, timeout, raise_error=False)
        finally:
            self._closing = True
            self._thread.join(timeout=2.0)
            self._thread = None
            self._unguard()

    # --- the thread ------------------------------------------------------------------------------------------

    def _run(self) -> None:
        period = self.limits.period
        spin = min(SPIN, period / 4)
        next_tick = time.monotonic()
        while not self._closing:
            self._cycle()
            next_tick += period
            now = time.monotonic()
            if now > next_tick:           # a late cycle: keep the rate from here on instead of bursting
                self.overruns += 1
                next_tick = now
                continue
            if next_tick - now > spin:
                time.sleep(next_tick - now - spin)
            while time.monotonic() < next_tick:
                pass

    def _cycle(self) -> None:
        now = time.monotonic()
        try:
            positions, velocities = self.safety.read_state(self.driver.latest_state(), now)
            measured = Measured(positions, velocities, self.safety.fresh_at or now)
            self.measured_log.append((now, positions))
            with self._lock:
                self._measured = measured    # kept current while braking after a status fault too
            self.safety.check_status(self.driver.robot_status())
        except DriverError as exc:
            self._fault(exc)
        except Exception as exc:  # a transport bug must still stop the robot
            self._fault(DriverError(f"reading the robot failed: {type(exc).__name__}: {exc}"))
        with self._wake:
            try:
                self._advance_target(now)
                command = self.smoother.update()
                self.safety.check_command(*command)
                if not self.smoother.finished:
                    self._settled_at = None
                elif self._settled_at is None:
                    self._settled_at = now
            except DriverError as exc:
                self._fault(exc)
                self._writing = False
                self._wake.notify_all()
                return
            self._cycles += 1
            self._wake.notify_all()
        if not self._writing:
            return
        try:
            self.driver.write(command[0], command[1])
        except Exception as exc:  # the wire is gone: nothing more can be sent
            self._writing = False
            self._fault(exc if isinstance(exc, DriverError) else
                        ConnectionLost(f"writing a command failed: {type(exc).__name__}: {exc}"))
            return
        self.log.append((time.monotonic(), command[0], command[1]))

    def _advance_target(self, now: float) -> None:
        smoother = self.smoother
        if smoother.braking:
            return
        if self._path is not None:
            start, times, positions = self._path
            t = now - start + self.limits.period
            if t >= times[-1]:
                smoother.set_target(positions[-1])
                self._path = None
            else:
                k = int(np.searchsorted(times, t, side="right")) - 1
                s = (t - times[k]) / (times[k + 1] - times[k])
                velocity = (positions[k + 1] - positions[k]) / (times[k + 1] - times[k])
                target = positions[k] + s * (positions[k + 1] - positions[k])
                smoother.set_target(target, np.clip(velocity, -self.limits.velocity, self.limits.velocity))
        elif self._expires is not None and now > self._expires:
            self._expires = None
            smoother.brake("stream target expired")

    def _fault(self, exc: DriverError) -> None:
        if self.error is None:
            self.error = exc
        self._path = None
        self._expires = None
        self.smoother.brake(f"fault: {type(exc).__name__}")

    # --- what callers use ------------------------------------------------------------------------------------

    def _check(self) -> None:
        if self.error is not None:
            raise self.error
        if self._thread is None:
            raise DriverError("the driver is not connected", field="driver")

    def _refuse(self, exc: PliantError) -> None:
        """A refused request: record it (the robot stops) and raise it to the caller."""
        with self._lock:
            self._fault(exc)
        raise exc

    def _wait(self, done, timeout: float, raise_error: bool = True) -> None:
        deadline = time.monotonic() + timeout
        with self._wake:
            while not done():
                if raise_error and self.error is not None:
                    raise self.error
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._thread is None or not self._thread.is_alive():
                    break
                self._wake.wait(min(remaining, 0.05))
        if raise_error and self.error is not None:
            raise self.error

    def measured(self) -> Measured:
        """The newest checked measurement."""
        self._check()
        with self._lock:
            return self._measured

    def stream(self, target, velocity=None, *, hold: float | None = None) -> None:
        """Aim at ``target`` ``(d,)`` (with ``velocity`` ``(d,)``); a non-zero velocity expires after ``hold`` s
        (default four command periods) and the robot then stops.

        A streamed target may move each cycle by at most the step limit (``max_step`` per command period since the
        previous streamed target; the first from the current reference): a larger jump is a fault of whoever
        streams (``StepTooLarge``), not a motion to make.  :meth:`move_to` is for going far.
        """
        self._check()
        now = time.monotonic()
        try:
            position, velocity = self.safety.check_target(target, velocity)
            with self._lock:
                previous, since = self._streamed if self._streamed is not None else (self.smoother.position, now)
            allowed = self.limits.max_step * (1.0 + (now - since) / self.limits.period)
            jump = np.abs(position - previous)
            if np.any(jump > allowed):
                i = int(np.argmax(jump - allowed))
                raise StepTooLarge(f"streamed target jumps {jump[i]:.4g} rad from the previous one",
                                   joint=self.limits.names[i], value=float(position[i]), limit=float(allowed[i]))
        except DriverError as exc:
            self._refuse(exc)
        self._aim(position, velocity, hold)
        self._streamed = (position, now)

    def _aim(self, position: np.ndarray, velocity: np.ndarray, hold: float | None) -> None:
        with self._lock:
            self._path = None
            self._settled_at = None
            self.smoother.set_target(position, velocity)
            self._expires = time.monotonic() + (4 * self.limits.period if hold is None else hold) \
                if np.any(velocity) else None
            self._streamed = None

    def move_to(self, q, *, wait: bool = True) -> np.ndarray:
        """Go to ``q`` and (with ``wait``) return the measured positions once within ``reach_tolerance``."""
        self._check()
        try:
            target, velocity = self.safety.check_target(q)
        except DriverError as exc:
            self._refuse(exc)
        self._aim(target, velocity, None)
        if not wait:
            return self.measured().positions
        with self._lock:
            timeout = self.smoother.duration() + self.move_timeout
        self._wait(lambda: self.smoother.finished and self._arrived(target), timeout)
        if not self._arrived(target):
            error = np.abs(self._measured.positions - target)
            i = int(np.argmax(error))
            self._refuse(DriverError(f"did not arrive within {timeout:.1f} s: error {error[i]:.4f} rad",
                                     joint=self.limits.names[i], value=float(self._measured.positions[i]),
                                     limit=self.reach_tolerance))
        return self.measured().positions

    def _arrived(self, target: np.ndarray) -> bool:
        """Within ``reach_tolerance`` of ``target`` by a state that arrived after the cycle whose command finished
        the trajectory began (microseconds before that command is written): an older state, from a robot that has
        just gone quiet, could read as arrived without the robot having followed."""
        measured, settled = self._measured, self._settled_at
        return (measured is not None and settled is not None and measured.time > settled
                and bool(np.all(np.abs(measured.positions - target) <= self.reach_tolerance)))

    def follow(self, path, *, wait: bool = True) -> np.ndarray:
        """Follow a timed path (``path.times`` strictly increasing, s); returns the measured positions at the end."""
        self._check()
        times = None if path.times is None else np.asarray(path.times, dtype=np.float64)
        positions = np.atleast_2d(np.asarray(path.configurations, dtype=np.float64))
        if times is None or len(times) != len(positions) or len(times) < 2 or np.any(np.diff(times) <= 0):
            raise LimitViolation("a followed path needs at least two waypoints with strictly increasing times (s)",
                                 field="path.times", value=None if times is None else times.tolist()[:10])
        for k, waypoint in enumerate(positions):
            try:
                self.safety.check_target(waypoint)
            except DriverError as exc:
                exc.field = f"path.configurations[{k}]"
                self._refuse(exc)
        with self._lock:
            self._expires = None
            self._streamed = None
            self._settled_at = None
            self._path = (time.monotonic() - times[0], times, positions)
        if not wait:
            return self.measured().positions
        target = positions[-1]
        timeout = float(times[-1] - times[0]) + self.move_timeout
        self._wait(lambda: self._path is None and self.smoother.finished and self._arrived(target), timeout)
        if not self._arrived(target):
            self._refuse(DriverError(f"did not reach the path's end within {timeout:.1f} s", field="path"))
        return self.measured().positions

    def stop(self, *, wait: bool = True) -> np.ndarray:
        """Brake to rest within the limits (a stop is always allowed, even after a fault); with ``wait``, return
        the measured positions once the command is at rest and the robot has followed it (up to 1 s)."""
        with self._lock:
            self._path = None
            self._expires = None
            self.smoother.brake("stop")
        if wait:
            self._wait(lambda: self.smoother.at_rest or not self._writing, 30.0, raise_error=False)
            # then let the robot's own servo catch up with the last command (its measured velocity dies down)
            self._wait(lambda: self._measured is None or np.all(np.abs(self._measured.velocities) < SETTLED),
                       SETTLE_TIME, raise_error=False)
        with self._lock:
            return self._measured.positions if self._measured is not None else self.smoother.position

    def step(self, velocity, dt: float) -> np.ndarray:
        """The execution protocol: command ``velocity`` ``(d,)`` (rad/s) for ``dt`` s of real time.

        ruckig reaches the velocity (jerk-limited) and holds it for ``2 dt`` plus one period, so a controller
        that stops calling stops the robot.  A joint whose reference already leads the measured position by
        ``max_lead`` (rad) in the commanded direction gets no further (a robot held by a contact is not pulled
        by a runaway reference), and a joint whose stop would pass its position limit is stopped at it, as a
        simulator's joint limit would.  Returns when ``dt`` has passed since the previous call, with the measured
        positions.
        """
        self._check()
        velocity = np.asarray(velocity, dtype=np.float64)
        if velocity.shape != (self.limits.dof,) or not np.all(np.isfinite(velocity)) or not dt > 0:
            self._refuse(LimitViolation("a step needs a finite velocity per joint and a positive dt",
                                        field="step", value=[np.asarray(velocity).tolist(), dt]))
        lim = self.limits
        q = self.measured().positions
        velocity = np.clip(velocity, -lim.velocity, lim.velocity)
        with self._lock:
            reference = self.smoother.position.copy()
            self._path = None
            lead = (reference - q) * np.sign(velocity)
            stop = velocity ** 2 / (2 * lim.acceleration) + np.abs(velocity) * lim.acceleration / lim.jerk
            ahead = reference + np.sign(velocity) * stop
            blocked = (lead > self.max_lead) | (ahead > lim.command_upper) | (ahead < lim.command_lower)
            self.smoother.set_velocity(np.where(blocked, 0.0, velocity))
            self._streamed = None
            self._expires = time.monotonic() + 2 * dt + lim.period
        now = time.monotonic()
        wake = (self._last_step + dt) if self._last_step is not None and self._last_step + dt > now else now + dt
        time.sleep(max(0.0, wake - time.monotonic()))
        self._last_step = wake
        return self.measured().positions

    def report(self) -> dict[str, Any]:
        """State, status, limits and rates for ``pliant robot check``; raises the stream's error if any."""
        self._check()
        status = self.driver.robot_status()
        measured = self.measured()
        writes = [t for t, _, _ in list(self.log)[-200:]]
        states = [t for t, _ in list(self.measured_log)[-200:]]
        rate = (len(writes) - 1) / (writes[-1] - writes[0]) if len(writes) > 2 else float("nan")
        state_rate = (len(states) - 1) / (states[-1] - states[0]) if len(states) > 2 else float("nan")
        return {"joints": list(self.limits.names), "positions": measured.positions.tolist(),
                "velocities": measured.velocities.tolist(), "enabled": status.enabled, "estop": status.estop,
                "fault": status.fault, "lost": status.lost, "detail": status.detail,
                "command_rate": self.limits.command_rate,
                "measured_command_rate": rate, "measured_state_rate": state_rate,
                "command_timeout": self.limits.command_timeout, "state_timeout": self.limits.state_timeout,
                "limits": self.limits.describe(), "sources": list(self.limits.sources), **self.timing()}

    def timing(self) -> dict[str, float]:
        """How well the stream kept its period: ``overruns`` (late cycles), ``longest_write_gap`` (s, between two
        writes, of the last :data:`LOG_LENGTH`) and the collector figures of :meth:`RealTimeGuard.report`."""
        writes = np.array([t for t, _, _ in list(self.log)])
        gap = float(np.max(np.diff(writes))) if len(writes) > 1 else float("nan")
        return {"overruns": self.overruns, "longest_write_gap": gap, **REALTIME.report()}


def inspect_robot(driver: Any, limits: JointLimits, *, connect_timeout: float = 5.0,
                  duration: float = 0.5, enable: bool = False) -> dict[str, Any]:
    """Look at a robot without commanding it (``pliant robot check NAME``): open the connection, wait for its
    joint states, check them (names, order, stamps, freshness) for ``duration`` s and the robot's status, and
    report state, status, limits and rates.  With ``enable``, enable a disabled robot first (its motors hold; no
    command is sent).  Raises the first problem as a one-line :class:`~pliant.errors.DriverError` (master
    unreachable, robot disabled, joint names differ...).
    """
    safety = SafetyLayer(limits)
    driver.open()
    try:
        deadline = time.monotonic() + connect_timeout
        while driver.latest_state() is None:
            if time.monotonic() > deadline:
                raise ConnectionLost(f"connected, but no joint state arrived within {connect_timeout:g} s",
                                     field="driver", value=type(driver).__name__)
            time.sleep(0.005)
        if enable and not driver.robot_status().enabled:
            driver.enable()
            while not driver.robot_status().enabled and time.monotonic() < deadline:
                time.sleep(0.01)
        first = driver.latest_state()
        start = time.monotonic()
        positions, velocities = safety.read_state(first, start)
        while time.monotonic() - start < duration:
            time.sleep(limits.period)
            positions, velocities = safety.read_state(driver.latest_state(), time.monotonic())
        last = driver.latest_state()
        elapsed = max(last.received - first.received, 1e-9)
        status = driver.robot_status()
        report = {"joints": list(limits.names), "positions": positions.tolist(), "velocities": velocities.tolist(),
                  "enabled": status.enabled, "estop": status.estop, "fault": status.fault, "lost": status.lost,
                  "detail": status.detail, "command_rate": limits.command_rate,
                  "measured_state_rate": (last.sequence - first.sequence) / elapsed,
                  "command_timeout": limits.command_timeout, "state_timeout": limits.state_timeout,
                  "limits": limits.describe(), "sources": list(limits.sources)}
        try:
            safety.check_status(status)
        except DriverError as exc:
            exc.report = report          # what could be read is still worth printing
            raise
        return report
    finally:
        driver.shutdown()


__all__ = ["REALTIME", "CommandStream", "Measured", "RealTimeGuard", "inspect_robot"]
