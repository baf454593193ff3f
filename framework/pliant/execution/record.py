"""What an execution leaves: one typed :class:`ExecutionRecord` with an :class:`ExecutionOutcome`, for a path, a policy
or a push plan alike (:mod:`pliant.execution.loop`).

The record holds what every execution has -- the trajectory (``configurations`` ``(k, d)``, ``times`` ``(k,)``,
``contacts`` ``(k,)``), the movable objects' poses, the ``events``, the ``world`` and, for an execution that raised,
the ``error`` -- and, in ``details``, what the strategy that was followed adds (:class:`ExecutionDetails`): a path's
:class:`PathDetails` (waypoints reached), a partial policy's actions and adaptations, a push plan's pushes and
replannings (defined by the plugins that supply those strategies).
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import ClassVar

import numpy as np

from pliant.results import jsonable


class ExecutionOutcome(enum.StrEnum):
    """How an execution ended.  A ``str`` enum: ``ExecutionOutcome.STUCK == "stuck"``; files hold the value.

    A path ends ``reached`` / ``stuck`` / ``timeout``; a policy or a push plan ``success`` / ``failure`` /
    ``timeout`` / ``action limit`` (a push plan also ``above tolerance``: completed, its result outside its
    tolerance); an execution that raised ``failed`` (a watchdog, a drive fault, a simulator error) or
    ``interrupted`` (Ctrl-C) -- its partial record keeps the steps executed (:func:`~pliant.execution.loop.capture`).
    """

    REACHED = "reached"              #: a path: the last waypoint was reached
    SUCCESS = "success"              #: a policy or plan: it ended at its goal
    STUCK = "stuck"                  #: the controller gave up (the robot did not move)
    TIMEOUT = "timeout"              #: the execution's time limit passed
    FAILURE = "failure"              #: a policy or plan ended off its goal (it reports failure, or gave up)
    ACTION_LIMIT = "action limit"    #: a policy or plan performed its most actions
    ABOVE_TOLERANCE = "above tolerance"  #: a plan completed, but its result is outside its tolerance (a push plan's
    #:                                     final cost above (1 + tolerance) x the plan's); not a success
    FAILED = "failed"                #: the execution raised (its record is partial; ``error`` says what failed)
    INTERRUPTED = "interrupted"      #: Ctrl-C (its record is partial)

    @property
    def success(self) -> bool:
        return self in (ExecutionOutcome.REACHED, ExecutionOutcome.SUCCESS)


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
class ExecutionDetails:
    """What a strategy adds to its execution's record (base class).  Subclasses are dataclasses with a unique
    ``kind``; :meth:`to_dict` writes their fields (arrays as lists) and :meth:`summary` the report's rows."""

    kind: ClassVar[str] = ""

    def to_dict(self) -> dict:
        return {"kind": self.kind, **{f.name: jsonable(getattr(self, f.name)) for f in fields(self)}}

    def summary(self) -> list[tuple[str, str]]:
        """Rows for a run's summary table (``pliant run``'s output and report.md)."""
        return []


@dataclass
class PathDetails(ExecutionDetails):
    """A path's execution: ``waypoints_reached`` (after the start)."""

    kind: ClassVar[str] = "path"
    waypoints_reached: int = 0

    def summary(self) -> list[tuple[str, str]]:
        return [("waypoints reached", str(self.waypoints_reached))]


@dataclass
class ExecutionRecord:
    """What happened during an execution (of a path, a policy, a plan: one loop, :func:`pliant.execution.loop.follow`).

    configurations: ``(k, d)`` states after every control step (the first is the start).
    times: ``(k,)`` seconds.  contacts: ``(k,)`` whether the robot touched anything in that step.
    outcome: an :class:`ExecutionOutcome`.
    events: what happened on the way, as ``"t=1.20s: ..."`` lines.
    objects: the movable objects' poses ``(k, p)`` by name (:meth:`Simulator.object_poses`: ``(x, y, theta)`` in
    planar scenes, else position and quaternion); empty for worlds that hold objects fixed.
    world: the name of the world executed in (``pybullet``, ``baxter-ros``...).
    error: what failed, for an execution that raised (``"StaleState: ... the newest joint state is 0.109 s old"``);
    empty otherwise.
    details: what the strategy followed adds (:class:`PathDetails` for a path; a plugin's for its policies and
    plans), ``None`` when the execution raised before the strategy began.
    """

    configurations: np.ndarray
    times: np.ndarray
    contacts: np.ndarray
    outcome: ExecutionOutcome
    events: list[str] = field(default_factory=list)
    objects: dict[str, np.ndarray] = field(default_factory=dict)
    world: str = ""
    error: str = ""
    details: ExecutionDetails | None = None

    def __post_init__(self) -> None:
        self.outcome = ExecutionOutcome(self.outcome)

    @property
    def success(self) -> bool:
        return self.outcome.success

    def to_dict(self) -> dict:
        """JSON-ready description (arrays as lists; ``details`` as its own table with its ``kind``)."""
        return {"configurations": self.configurations.tolist(), "times": self.times.tolist(),
                "contacts": self.contacts.tolist(), "outcome": self.outcome.value, "events": list(self.events),
                "objects": {name: poses.tolist() for name, poses in self.objects.items()},
                "world": self.world, "error": self.error,
                "details": None if self.details is None else self.details.to_dict()}
