"""Executing a path with a controller in any execution world, step by step (thesis 5.4, app. C).

An *execution world* (:class:`ExecutionWorld`) is a simulator or a robot driver: both take a velocity command for
``dt`` seconds and report the configuration reached, so one loop runs a controller — and a policy — in either, and
one pipeline setting (``execution.world``) swaps them.  This module is the only place where controller commands
become motion.

:func:`execute` resets the world at the path's first configuration (a simulator places the robot; a driver moves
there within its limits), then for each waypoint asks the controller for velocity commands at the control period
until the controller reports the waypoint reached, gives up (stuck), or the time limit passes.  :func:`drive` is
one such motion toward one target without a reset, the primitive that policy execution (thesis 5.3.5) builds on.
Everything is recorded in one typed :class:`ExecutionRecord`, and an ``on_step`` callback receives every step as
it happens (:class:`ExecutionStep`), for viewers, learners and logs.

An execution that raises (a driver's watchdog, a drive fault, a simulator error, Ctrl-C) still has a record of what
happened up to there: inside :func:`capture`, every :class:`Recorder` (the one :func:`execute` uses, and the ones a
policy's own execution builds on :func:`drive`) is kept, and :meth:`Capture.partial` turns the last one into an
:class:`ExecutionRecord` whose outcome is ``failed`` or ``interrupted`` and whose ``error`` says what failed.  The
pipeline runs every execution inside one (docs/outcomes.md).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from pliant.components import Controller
from pliant.errors import DimensionError
from pliant.results import Path


@runtime_checkable
class ExecutionWorld(Protocol):
    """What executions run in: :class:`~pliant.interfaces.Simulator` and :class:`~pliant.interfaces.Driver`.

    ``reset(q)`` puts the robot at ``q`` ``(d,)`` (placing it, or driving there); ``step(velocity, dt, rng)`` applies
    a tangent velocity ``(t,)`` for ``dt`` s and returns the configuration ``(d,)`` reached; ``configuration()``,
    ``in_contact()`` (during the last step) and ``object_poses()`` (movable objects by name) report; ``settle()``
    brings the robot to rest at the end of an execution and returns where it rests (a simulated robot stops at
    once; a real one decelerates within its limits, so it may travel on a little).
    """

    def reset(self, q: np.ndarray) -> None: ...

    def step(self, velocity: np.ndarray, dt: float, rng: np.random.Generator) -> np.ndarray: ...

    def configuration(self) -> np.ndarray: ...

    def in_contact(self) -> bool: ...

    def object_poses(self) -> dict[str, np.ndarray]: ...

    def settle(self) -> np.ndarray: ...


@dataclass(frozen=True)
class ExecutionStep:
    """One control step, as handed to ``on_step``: ``time`` (s since the execution began), the ``configuration``
    ``(d,)`` reached, the ``command`` ``(t,)`` applied, the ``target`` ``(d,)`` driven toward, ``contact`` during the
    step and the movable objects' ``objects`` poses."""

    time: float
    configuration: np.ndarray
    command: np.ndarray
    target: np.ndarray
    contact: bool
    objects: dict[str, np.ndarray]


StepListener = Callable[[ExecutionStep], None]


@dataclass
class ExecutionRecord:
    """What happened during an execution of a path or a policy.

    configurations: ``(k, d)`` states after every control step (the first is the start).
    times: ``(k,)`` seconds.  contacts: ``(k,)`` whether the robot touched anything in that step.
    outcome: for a path ``reached`` (the last waypoint), ``stuck`` (the controller gave up) or ``timeout``; for a
    policy ``success``, ``failure``, ``timeout`` or ``action limit``; for an execution that raised (a partial record,
    :meth:`Capture.partial`) ``failed`` or ``interrupted`` (Ctrl-C).
    waypoints_reached: how many waypoints (after the start) were reached (paths).
    objects: the movable objects' poses ``(k, p)`` by name (:meth:`Simulator.object_poses`: ``(x, y, theta)`` in
    planar scenes, else position and quaternion); empty for worlds that hold objects fixed.
    actions / adaptations / final_node: a policy's actions performed, its probability changes and the last node
    reached (empty / ``None`` for paths; the policy's plugin documents the entries).
    world: the name of the world executed in (``pybullet``, ``baxter-ros``...).
    error: what failed, for an execution that raised (``"StaleState: ... the newest joint state is 0.109 s old"``);
    empty otherwise.
    """

    configurations: np.ndarray
    times: np.ndarray
    contacts: np.ndarray
    outcome: str
    waypoints_reached: int = 0
    events: list[str] = field(default_factory=list)
    objects: dict[str, np.ndarray] = field(default_factory=dict)
    actions: list[dict] = field(default_factory=list)
    adaptations: list[dict] = field(default_factory=list)
    final_node: int | None = None
    world: str = ""
    error: str = ""

    @property
    def success(self) -> bool:
        return self.outcome in ("reached", "success")

    def to_dict(self) -> dict:
        """JSON-ready description (arrays as lists)."""
        actions = [{k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in a.items()} for a in self.actions]
        return {"configurations": self.configurations.tolist(), "times": self.times.tolist(),
                "contacts": self.contacts.tolist(), "outcome": self.outcome,
                "waypoints_reached": self.waypoints_reached, "events": list(self.events),
                "objects": {name: poses.tolist() for name, poses in self.objects.items()},
                "actions": actions, "adaptations": list(self.adaptations), "final_node": self.final_node,
                "world": self.world, "error": self.error}


#: the recorders of the executions running inside :func:`capture` (``None`` outside one)
_CAPTURED: ContextVar[list[Recorder] | None] = ContextVar("pliant_captured_recorders", default=None)


class Recorder:
    """Collects the steps of one execution (states, times, contacts, object poses) and forwards them to
    ``on_step``; :meth:`record` turns them into an :class:`ExecutionRecord`.

    ``waypoints_reached`` and ``events`` are kept up to date by :func:`execute` as it goes, so that a partial record
    (:meth:`Capture.partial`) says how far an execution that raised had come.
    """

    def __init__(self, world: ExecutionWorld, on_step: StepListener | None = None) -> None:
        q = world.configuration()
        self.states = [q.copy()]
        self.times = [0.0]
        self.contacts = [False]
        self.objects = [world.object_poses()]
        self.on_step = on_step
        self.waypoints_reached = 0
        self.events: list[str] = []
        captured = _CAPTURED.get()
        if captured is not None:
            captured.append(self)

    @property
    def time(self) -> float:
        return self.times[-1]

    def add(self, world: ExecutionWorld, q: np.ndarray, t: float, command: np.ndarray, target: np.ndarray) -> None:
        contact = bool(world.in_contact())
        poses = world.object_poses()
        self.states.append(q.copy())
        self.times.append(t)
        self.contacts.append(contact)
        self.objects.append(poses)
        if self.on_step is not None:
            self.on_step(ExecutionStep(t, q.copy(), np.asarray(command, dtype=np.float64).copy(), target, contact,
                                       poses))

    def settle(self, world: ExecutionWorld) -> None:
        """End the execution: bring the robot to rest and, if it moved on while stopping, record where it rests."""
        q = np.asarray(world.settle(), dtype=np.float64)
        if not np.array_equal(q, self.states[-1]):
            self.add(world, q, self.time, np.zeros_like(q), q)

    def record(self, outcome: str, **fields) -> ExecutionRecord:
        # a step that raised half-way may have left one list a step longer than the others: keep whole steps
        k = min(len(self.states), len(self.times), len(self.contacts), len(self.objects))
        names = self.objects[0]
        poses = {name: np.array([step[name] for step in self.objects[:k]], dtype=np.float64) for name in names}
        return ExecutionRecord(np.array(self.states[:k]), np.array(self.times[:k]),
                               np.array(self.contacts[:k], dtype=bool), outcome, objects=poses, **fields)


class Capture:
    """The recorders of the executions run inside one :func:`capture` block (in the order they began)."""

    def __init__(self) -> None:
        self.recorders: list[Recorder] = []

    def partial(self, outcome: str, error: str, world_name: str = "", dim: int = 0) -> ExecutionRecord:
        """The record of an execution that raised: the steps of the last recorder begun (the execution running when
        it raised), with ``outcome`` (``failed`` / ``interrupted``), ``error`` (what failed) and an event saying
        when.  With no recorder (the world failed before the first state was read: ``reset``, connecting) the record
        has no steps: arrays of length 0 (configurations ``(0, dim)``)."""
        if not self.recorders:
            return ExecutionRecord(np.zeros((0, dim)), np.zeros(0), np.zeros(0, dtype=bool), outcome,
                                   events=[f"t=0.00s: {error}"], world=world_name, error=error)
        recorder = self.recorders[-1]
        events = [*recorder.events, f"t={recorder.time:.2f}s: {error}"]
        return recorder.record(outcome, waypoints_reached=recorder.waypoints_reached, events=events,
                               world=world_name, error=error)


@contextmanager
def capture() -> Iterator[Capture]:
    """Keep every :class:`Recorder` begun inside the block (in this thread or task), so that an execution that raises
    still leaves a record: ``with capture() as run: ...`` then ``run.partial("failed", str(exc))``."""
    collected = Capture()
    token = _CAPTURED.set(collected.recorders)
    try:
        yield collected
    finally:
        _CAPTURED.reset(token)


def drive(world: ExecutionWorld, controller: Controller, target: np.ndarray, rng: np.random.Generator,
          recorder: Recorder, *, period: float = 0.1, time_limit: float = 60.0) -> str:
    """Drive the robot from wherever ``world`` holds it toward ``target`` ``(d,)`` (no reset).

    The controller is reset, then commands velocities every ``period`` s until it reports the target reached,
    gives up (``gave_up``: stuck, thesis app. C) or ``time_limit`` s have passed.  Every step goes to ``recorder``
    (times continue from its last).  Returns the outcome ``reached`` / ``stuck`` / ``timeout``.
    """
    if not (period > 0 and time_limit >= 0):
        raise DimensionError("period must be positive and time_limit non-negative (s)", field="period/time_limit",
                             value=(period, time_limit))
    target = np.asarray(target, dtype=np.float64)
    controller.reset()
    q = world.configuration()
    t = recorder.time
    deadline = t + time_limit
    while True:
        if controller.reached(q, target):
            return "reached"
        if getattr(controller, "gave_up", False):
            return "stuck"
        if t >= deadline - 1e-12:
            return "timeout"
        velocity = controller.command(q, target, period)
        q = world.step(velocity, period, rng)
        t += period
        recorder.add(world, q, t, velocity, target)


def execute(world: ExecutionWorld, controller: Controller, path: Path, rng: np.random.Generator, *,
            period: float = 0.1, time_limit: float = 60.0, on_step: StepListener | None = None,
            world_name: str = "") -> ExecutionRecord:
    """Follow ``path`` waypoint by waypoint with ``controller`` in ``world`` (reset at the first waypoint).

    ``period`` is the control period (s); ``time_limit`` the total budget (s); ``on_step`` receives every step.
    Each waypoint is one :func:`drive`.
    """
    if not (period > 0 and time_limit > 0):
        raise DimensionError("period and time_limit must be positive seconds", field="period/time_limit",
                             value=(period, time_limit))
    waypoints = np.atleast_2d(path.configurations)
    world.reset(waypoints[0])
    recorder = Recorder(world, on_step)
    events = recorder.events
    reached = 0
    outcome = "timeout"
    for index, target in enumerate(waypoints[1:], start=1):
        result = drive(world, controller, target, rng, recorder, period=period,
                       time_limit=max(0.0, time_limit - recorder.time))
        if result == "reached":
            reached = recorder.waypoints_reached = index
            continue
        if result == "stuck":
            outcome = "stuck"
            events.append(f"t={recorder.time:.2f}s: stuck before waypoint {index}")
        break
    else:
        outcome = "reached"
    if outcome == "timeout" and reached != len(waypoints) - 1:
        events.append(f"t={recorder.time:.2f}s: time limit before waypoint {reached + 1}")
    recorder.settle(world)
    return recorder.record(outcome, waypoints_reached=reached, events=list(events), world=world_name)
