"""A position-controlled arm moved by a pliant simulator in real time: the physics behind the robot peers.

pliant's core has no reusable robot emulator yet (``pliant.hardware.emulator`` does not exist), so this one lives
in the plugin.  :class:`ArmEmulator` is a joint position servo.  Each new position command starts a linear ramp of
the servo's reference from where the reference is to the command, over the time since the previous command (or
the duration the command states, as a PR2 trajectory point's ``time_from_start``; at most ``MAX_RAMP`` s): as a
robot's joint controller interpolates between commands that arrive at a lower rate than its own loop.  A thread
at ``physics_rate`` (Hz, real time) turns the reference into a joint velocity ``(reference - q) / dt``, capped at
the limits file's velocity limits times the robot's ``speed_ratio``, and lets the simulator move the arm by it
(``Simulator.step``), so the measured joint states are physical: smooth, one command period behind, stopped by
obstacles in the scene (the ``kinematic`` and ``pybullet`` simulators resolve contact), never jumping.  Without a
simulator it integrates the velocity.  Without a command -- none received yet, a ``command_timeout`` passed, the
robot disabled -- it holds still.

:func:`build_simulator` builds the pipeline pieces the same way a pipeline does, through the registry (the
``pinocchio`` robot model, then the named simulator) -- never by importing another plugin.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from pliant.api import JointLimits

#: simulators the peer can use (``none``: integrate the velocity, no contact)
SIMULATORS = ("kinematic", "pybullet", "none")
#: the longest ramp of the servo's reference toward a new command (s)
MAX_RAMP = 0.1


def build_simulator(scene_name: str, group: str, name: str, limits: JointLimits, physics_rate: float,
                    options: dict[str, Any] | None = None):
    """``(simulator, scene)``: the scene, the ``pinocchio`` robot with joint ``group`` and simulator ``name``
    stepping at ``physics_rate`` (Hz) with the limits' velocities; ``options`` override the simulator's options.
    Checks that the robot model plans the limits' joints, in order."""
    from pliant import api
    from pliant.api import ConfigError, Context

    scene = api.load_scene(scene_name)
    context = Context(scene)
    context.robot = api.registry.create("robot", "pinocchio", context, group=group)
    joints = tuple(context.robot.urdf_description().joint_names)
    if joints != tuple(limits.names):
        raise ConfigError(f"the scene's robot plans joints {list(joints)}, the peer commands {list(limits.names)}",
                          field="scene", value=scene_name)
    if name == "none":
        return None, scene
    settings: dict[str, Any] = {"frequency": physics_rate, "joint_velocity_limits": tuple(limits.velocity.tolist())}
    if name == "pybullet":
        settings["physics_rate"] = physics_rate
    if name == "kinematic":
        settings["self_collision"] = False
    settings.update(options or {})
    simulator = context.simulator = api.registry.create("simulator", name, context, **settings)
    # warm up (compiled kernels load or compile on the first steps), so that real time starts on time
    rng = np.random.default_rng(0)     # a warm-up of +-1e-3 steps, reset after: influences no result
    start = np.clip(np.asarray(scene.start, dtype=np.float64), limits.command_lower, limits.command_upper)
    simulator.reset(start)
    for sign in (1.0, -1.0):
        simulator.step(sign * 1e-3 * limits.velocity, 1.0 / physics_rate, rng)
    simulator.reset(start)
    return simulator, scene


class ArmEmulator:
    """The arm of a robot peer (see the module docstring).

    limits: the arm's limits (velocity caps the motion).  start: the initial joint positions ``(d,)`` rad.
    simulator: a bound :class:`~pliant.interfaces.Simulator` of the arm, or None (ideal servo).  physics_rate:
    ticks per second (Hz).  command_timeout: seconds after the last command when the arm holds (None: keep going
    to the last command).  speed_ratio: fraction of the velocity limits the servo may use.  on_tick: called with
    ``(time, positions, velocities)`` after every tick (from the physics thread).  on_error: called with the
    exception if a tick fails (the physics thread then ends: a controller whose servo loop died).
    """

    def __init__(self, limits: JointLimits, start, *, simulator=None, physics_rate: float = 500.0,
                 command_timeout: float | None = None, speed_ratio: float = 1.0, seed: int = 0,
                 on_tick: Callable[[float, np.ndarray, np.ndarray], None] | None = None,
                 on_error: Callable[[BaseException], None] | None = None) -> None:
        self.limits = limits
        self.simulator = simulator
        self.physics_rate = float(physics_rate)
        self.command_timeout = command_timeout
        self.speed_ratio = float(speed_ratio)
        self.on_tick = on_tick
        self.on_error = on_error
        self.error: BaseException | None = None
        self.active = True                     # False: disabled or e-stopped, the arm holds
        self.rng = np.random.default_rng(seed)
        self._q = np.array(start, dtype=np.float64)
        self._v = np.zeros_like(self._q)
        self._sampled = time.time()
        if simulator is not None:
            simulator.reset(self._q)
            self._q = np.asarray(simulator.configuration(), dtype=np.float64)
        self._target: np.ndarray | None = None          # the newest command, rad
        self._ramp: tuple[np.ndarray, np.ndarray, float, float] | None = None   # (from, to, start s, duration s)
        self._commanded_at = 0.0
        self._lock = threading.Lock()
        self._running = False
        self._thread: threading.Thread | None = None
        self.ticks = 0
        self.overruns = 0

    def command(self, positions, duration: float | None = None) -> None:
        """A new position command ``(d,)`` rad (NaN entries keep the previous command of that joint), reached over
        ``duration`` s (default: the time since the previous command, at most ``MAX_RAMP``; the first command after
        a hold is reached as fast as the velocity limits allow)."""
        positions = np.asarray(positions, dtype=np.float64)
        now = time.monotonic()
        with self._lock:
            reference = self._reference(now)
            if reference is None:
                reference, since = self._q.copy(), 0.0
            else:
                since = now - self._commanded_at
            base = self._target if self._target is not None else reference
            self._target = np.where(np.isnan(positions), base, positions)
            ramp = min(max(since if duration is None else duration, 0.0), MAX_RAMP)
            self._ramp = (reference, self._target, now, ramp)
            self._commanded_at = now

    def _reference(self, now: float) -> np.ndarray | None:
        """The servo's reference at ``now`` (None: no command, hold); call with the lock held."""
        if self._ramp is None:
            return None
        start, end, t0, duration = self._ramp
        if duration <= 0.0 or now >= t0 + duration:
            return end
        return start + (end - start) * ((now - t0) / duration)

    def hold(self) -> None:
        """Forget the command: the arm holds where it is."""
        with self._lock:
            self._ramp = self._target = None

    def state(self) -> tuple[np.ndarray, np.ndarray, float]:
        """The arm's positions ``(d,)`` rad and velocities ``(d,)`` rad/s at the newest tick, and the wall-clock time
        of that tick (:func:`time.time`, s): what a real controller stamps its joint states with."""
        with self._lock:
            return self._q.copy(), self._v.copy(), self._sampled

    def start(self) -> ArmEmulator:
        """Start the physics thread (``physics_rate`` ticks per second of real time)."""
        self._running = True
        self._thread = threading.Thread(target=self._run, name="pliant-peer-physics", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the physics thread (the arm stays where it is)."""
        self._running = False
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    def _run(self) -> None:
        period = 1.0 / self.physics_rate
        last = time.monotonic()
        next_tick = last + period
        while self._running:
            delay = next_tick - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            now = time.monotonic()
            dt = min(max(now - last, 0.5 * period), 4.0 * period)
            last = now
            next_tick += period
            if now > next_tick + period:          # late: keep the rate from here on instead of bursting
                self.overruns += 1
                next_tick = now + period
            try:
                self.tick(dt, now)
            except BaseException as exc:  # the servo loop died: say so, do not pretend to hold
                self.error = exc
                self._running = False
                if self.on_error is not None:
                    self.on_error(exc)
                return

    def tick(self, dt: float, now: float | None = None) -> np.ndarray:
        """One physics step of ``dt`` s; returns the new positions."""
        now = time.monotonic() if now is None else now
        with self._lock:
            if self._ramp is not None and self.command_timeout is not None and \
                    now - self._commanded_at > self.command_timeout:
                self._ramp = self._target = None         # the robot's own timeout: hold
            command = self._reference(now)
            q = self._q
        if command is None or not self.active:
            velocity = np.zeros_like(q)
        else:
            cap = self.limits.velocity * self.speed_ratio
            velocity = np.clip((command - q) / dt, -cap, cap)
        if self.simulator is not None:
            new = np.asarray(self.simulator.step(velocity, dt, self.rng), dtype=np.float64)
        else:
            new = q + velocity * dt
        with self._lock:
            self._v = (new - q) / dt
            self._q = new
            self._sampled = time.time()
            self.ticks += 1
            v = self._v.copy()
        if self.on_tick is not None:
            self.on_tick(now, new.copy(), v)
        return new
