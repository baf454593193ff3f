"""The one execution loop: how a path, a policy or a plan becomes motion in any execution world (thesis 5.4, app. C).

An *execution world* (:class:`ExecutionWorld`) is a simulator or a robot driver: both take a velocity command for
``dt`` seconds and report the configuration reached, so one loop runs a controller -- and a policy -- in either, and
one pipeline setting (``execution.world``) swaps them.  This module is the only place where a world is stepped
during an execution (a driver world's commands pass the safety layer and its watchdogs inside the driver session,
:mod:`pliant.hardware`).

:func:`follow` runs an :class:`~pliant.execution.strategy.ExecutionStrategy` -- what to do next, from what was
observed: a path's next waypoint (:class:`~pliant.execution.strategy.PathStrategy`), a partial policy's next action,
a push plan's next push -- and owns everything else: placing the robot, stepping the world under the controller
(:func:`drive`) or an open-loop command, recording every step (:class:`Recorder`, forwarded to ``on_step`` as an
:class:`ExecutionStep`, for viewers, learners and logs), the time limit, a progress line on a terminal, and the record
(:class:`~pliant.execution.record.ExecutionRecord`, with the strategy's ``details``).  :func:`execute` follows a path.

An execution that raises (a driver's watchdog, a drive fault, a simulator error, Ctrl-C) still has a record of what
happened up to there: inside :func:`capture`, every :class:`Recorder` is kept, and :meth:`Capture.partial` turns the
last one into an :class:`ExecutionRecord` whose outcome is ``failed`` or ``interrupted``, whose ``error`` says what
failed and whose ``details`` are the strategy's so far.  The pipeline runs every execution inside one
(docs/outcomes.md).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Protocol, runtime_checkable

import numpy as np

from pliant.components import Controller
from pliant.errors import ConfigError, DimensionError, SimulationError
from pliant.execution.record import (
    ExecutionDetails,
    ExecutionOutcome,
    ExecutionRecord,
    ExecutionStep,
    PathDetails,
    StepListener,
)
from pliant.execution.strategy import (
    Done,
    Drive,
    ExecutionStrategy,
    Move,
    Observation,
    PathStrategy,
    Place,
    ScriptedStrategy,
    strategy_for,
)
from pliant.progress import ProgressLine
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


#: the recorders of the executions running inside :func:`capture` (``None`` outside one)
_CAPTURED: ContextVar[list[Recorder] | None] = ContextVar("pliant_captured_recorders", default=None)


class Recorder:
    """Collects the steps of one execution (states, times, contacts, object poses) and forwards them to
    ``on_step``; :meth:`record` turns them into an :class:`ExecutionRecord`.

    ``strategy`` (the one followed) supplies the record's ``events`` and ``details``, also for a partial record
    (:meth:`Capture.partial`) of an execution that raised.
    """

    def __init__(self, world: ExecutionWorld, on_step: StepListener | None = None,
                 strategy: ExecutionStrategy | None = None) -> None:
        q = world.configuration()
        self.states = [q.copy()]
        self.times = [0.0]
        self.contacts = [False]
        self.objects = [world.object_poses()]
        self.on_step = on_step
        self.strategy = strategy
        captured = _CAPTURED.get()
        if captured is not None:
            captured.append(self)

    @property
    def time(self) -> float:
        return self.times[-1]

    @property
    def events(self) -> list[str]:
        return list(self.strategy.events) if self.strategy is not None else []

    def details(self) -> ExecutionDetails | None:
        return self.strategy.details() if self.strategy is not None else None

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

    def record(self, outcome: ExecutionOutcome | str, *, events: list[str] | None = None, world: str = "",
               error: str = "") -> ExecutionRecord:
        # a step that raised half-way may have left one list a step longer than the others: keep whole steps
        k = min(len(self.states), len(self.times), len(self.contacts), len(self.objects))
        names = self.objects[0]
        poses = {name: np.array([step[name] for step in self.objects[:k]], dtype=np.float64) for name in names}
        return ExecutionRecord(np.array(self.states[:k]), np.array(self.times[:k]),
                               np.array(self.contacts[:k], dtype=bool), ExecutionOutcome(outcome),
                               events=self.events if events is None else events, objects=poses, world=world,
                               error=error, details=self.details())


class Capture:
    """The recorders of the executions run inside one :func:`capture` block (in the order they began)."""

    def __init__(self) -> None:
        self.recorders: list[Recorder] = []

    def partial(self, outcome: ExecutionOutcome | str, error: str, world_name: str = "",
                dim: int = 0) -> ExecutionRecord:
        """The record of an execution that raised: the steps of the last recorder begun (the execution running when
        it raised), with ``outcome`` (``failed`` / ``interrupted``), ``error`` (what failed), an event saying when and
        the strategy's details so far.  With no recorder (the world failed before the first state was read:
        ``reset``, connecting) the record has no steps: arrays of length 0 (configurations ``(0, dim)``)."""
        if not self.recorders:
            return ExecutionRecord(np.zeros((0, dim)), np.zeros(0), np.zeros(0, dtype=bool),
                                   ExecutionOutcome(outcome), events=[f"t=0.00s: {error}"], world=world_name,
                                   error=error)
        recorder = self.recorders[-1]
        events = [*recorder.events, f"t={recorder.time:.2f}s: {error}"]
        return recorder.record(outcome, events=events, world=world_name, error=error)


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
    """Drive the robot from wherever ``world`` holds it toward ``target`` ``(d,)`` (no reset): the loop's closed-loop
    primitive (a :class:`~pliant.execution.strategy.Drive` directive).

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


def move(world: ExecutionWorld, velocity: np.ndarray, duration: float, period: float, rng: np.random.Generator,
         recorder: Recorder) -> None:
    """Command ``velocity`` ``(t,)`` for ``duration`` s in equal steps of at most ``period`` s (open loop: a
    :class:`~pliant.execution.strategy.Move` directive); every step goes to ``recorder`` with the configuration
    reached as its target."""
    steps = max(1, int(np.ceil(duration / period - 1e-9)))
    h = duration / steps
    command = np.asarray(velocity, dtype=np.float64)
    t = recorder.time
    for _ in range(steps):
        q = world.step(command, h, rng)
        t += h
        recorder.add(world, q, t, command, q)


def place(world: ExecutionWorld, directive: Place) -> None:
    """Put the robot (and the objects a :class:`~pliant.execution.strategy.Place` names) where it says."""
    world.reset(np.asarray(directive.configuration, dtype=np.float64))
    if directive.objects is not None:
        world.set_object_poses(directive.objects)


def follow(world: ExecutionWorld, controller: Controller | None, strategy: ExecutionStrategy,
           rng: np.random.Generator, *, period: float = 0.1, time_limit: float = 60.0,
           on_step: StepListener | None = None, world_name: str = "", progress: bool | None = None
           ) -> ExecutionRecord:
    """Execute ``strategy`` in ``world``: the one execution loop.

    The strategy's first directive places the robot (and objects), then the loop asks it for one directive after
    another with what it observed, and carries each out: :class:`~pliant.execution.strategy.Drive` with
    ``controller`` every ``period`` s (:func:`drive`, for at most what is left of ``time_limit`` s),
    :class:`~pliant.execution.strategy.Move` open loop (:func:`move`), :class:`~pliant.execution.strategy.Place`;
    until :class:`~pliant.execution.strategy.Done`.  Every step goes to ``on_step``; the robot is brought to rest
    at the end.  ``progress``: a progress line (default: on a terminal).  ``controller`` may be ``None`` for a
    strategy that never drives.  Errors end the execution (run it inside :func:`capture` to keep the partial
    record), except a :class:`~pliant.errors.SimulationError` of a directive marked ``recover``, which the
    strategy is told of.
    """
    if not (period > 0 and time_limit > 0):
        raise DimensionError("period and time_limit must be positive seconds", field="period/time_limit",
                             value=(period, time_limit))
    directive = strategy.begin(rng)
    if not isinstance(directive, Place):
        raise ConfigError("a strategy begins by placing the robot (a Place directive)", field="strategy",
                          value=type(directive).__name__)
    if directive.objects is not None and not getattr(world, "can_place_objects", False):
        raise ConfigError("this execution places objects: it needs a world that can place objects (a simulator "
                          "such as pymunk)", field="execution.world", value=world_name or type(world).__name__)
    place(world, directive)
    recorder = Recorder(world, on_step, strategy)
    line = ProgressLine(f"executing in {world_name or 'the world'}", enabled=progress)
    result, error, directives = "placed", None, 0
    try:
        while True:
            line.update(time=recorder.time, steps=len(recorder.times) - 1, directives=directives)
            directive = strategy.next(Observation(result, recorder.time, time_limit, world, error))
            directives += 1
            error = None
            if isinstance(directive, Done):
                outcome = ExecutionOutcome(directive.outcome)
                break
            if isinstance(directive, Drive):
                if controller is None:
                    raise ConfigError("this execution drives toward targets: it needs a controller",
                                      field="controller", value=None)
                limit = time_limit - recorder.time
                if directive.time_limit is not None:
                    limit = min(directive.time_limit, limit)
                result = drive(world, controller, directive.target, rng, recorder, period=period,
                               time_limit=max(0.0, limit))
                continue
            if not isinstance(directive, (Move, Place)):
                raise ConfigError("a strategy's directive must be Place, Drive, Move or Done", field="strategy",
                                  value=type(directive).__name__)
            try:
                if isinstance(directive, Move):
                    step = directive.period if directive.period is not None else period
                    if not (math.isfinite(directive.duration) and directive.duration > 0 and step > 0):
                        raise DimensionError("a move needs a positive duration and period (s)", field="move",
                                             value=(directive.duration, step))
                    move(world, directive.velocity, directive.duration, step, rng, recorder)
                    result = "moved"
                else:
                    place(world, directive)
                    result = "placed"
            except SimulationError as exc:
                if not directive.recover:
                    raise
                result, error = "failed", exc
    finally:
        line.close()
    recorder.settle(world)
    return recorder.record(outcome, world=world_name)


def execute(world: ExecutionWorld, controller: Controller, path: Path, rng: np.random.Generator, *,
            period: float = 0.1, time_limit: float = 60.0, on_step: StepListener | None = None,
            world_name: str = "") -> ExecutionRecord:
    """Follow ``path`` waypoint by waypoint with ``controller`` in ``world`` (placed at the first waypoint): the
    loop (:func:`follow`) with a :class:`~pliant.execution.strategy.PathStrategy`.

    ``period`` is the control period (s); ``time_limit`` the total budget (s); ``on_step`` receives every step.
    """
    return follow(world, controller, PathStrategy(path), rng, period=period, time_limit=time_limit,
                  on_step=on_step, world_name=world_name)


__all__ = ["Capture", "Done", "Drive", "ExecutionDetails", "ExecutionOutcome", "ExecutionRecord", "ExecutionStep",
           "ExecutionStrategy", "ExecutionWorld", "Move", "Observation", "PathDetails", "PathStrategy", "Place",
           "Recorder", "ScriptedStrategy", "StepListener", "capture", "drive", "execute", "follow", "move", "place",
           "strategy_for"]
