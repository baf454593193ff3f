"""What planners return: paths, policies and :class:`PlanResult`, with file round trips.

A result is data (DESIGN rule 6): a status, the path or policy, its cost, statistics and the seed,
never a bare ``None``.  Results save to JSON (``.json``) and load back unchanged.
"""

from __future__ import annotations

import enum
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path as FilePath
from typing import Any, ClassVar

import numpy as np

from pliant.errors import ConfigError


class Status(enum.Enum):
    """Outcome of a planning query."""

    SOLVED = "solved"                  #: a path/policy that reaches the goal
    APPROXIMATE = "approximate"        #: the best path found ends near, not at, the goal
    TIMEOUT = "timeout"                #: termination came before any solution
    INVALID_START = "invalid start"    #: the start is out of bounds or infeasible
    INVALID_GOAL = "invalid goal"      #: the goal is out of bounds or infeasible
    INFEASIBLE = "infeasible"          #: the planner proved (or its search exhausted) no solution
    INVALID_PATH = "invalid path"      #: the planner's path failed the core's validity check (pliant.planning.validity)

    @property
    def success(self) -> bool:
        return self in (Status.SOLVED, Status.APPROXIMATE)


class Outcome(enum.StrEnum):
    """How a pipeline run ended (DESIGN rule 13), each with one exit status of ``pliant run`` (docs/outcomes.md).

    A ``str`` enum: ``Outcome.STUCK == "stuck"``, and it is written to ``run.json`` and ``report.md`` by value.
    """

    PLANNED = "planned"            #: every stage ran; the plan reached the goal; nothing was asked to execute it
    REACHED = "reached"            #: planned, and executed to the goal
    NOT_PLANNED = "not planned"    #: the planner returned no solution (its status says why); nothing was executed
    STUCK = "stuck"                #: planned; the execution ended short of the goal (controller stuck, time or action
    #:                                limit, a policy ending off the goal)
    FAILED = "failed"              #: planned; the execution raised (a watchdog, a driver fault, a simulator error)
    ERROR = "error"                #: stopped by an error before executing: bad input, or a component refused it
    INTERRUPTED = "interrupted"    #: stopped by Ctrl-C (or a cancel); what was planned so far is on file

    @property
    def exit_status(self) -> int:
        """The exit status of ``pliant run`` for this outcome: 0 planned / reached, 1 not planned, 3 stuck /
        failed, 2 error (bad input), 130 interrupted."""
        return EXIT_STATUS[self]

    @property
    def success(self) -> bool:
        """Planned, and executed to the goal where an execution was asked for."""
        return self in (Outcome.PLANNED, Outcome.REACHED)


#: the exit status of each outcome (``pliant run``, ``python -m pliant_ros1.demo``)
EXIT_STATUS = {Outcome.PLANNED: 0, Outcome.REACHED: 0, Outcome.NOT_PLANNED: 1, Outcome.ERROR: 2,
               Outcome.STUCK: 3, Outcome.FAILED: 3, Outcome.INTERRUPTED: 130}


@dataclass
class Path:
    """A sequence of configurations ``(k, d)`` with optional times ``(k,)`` in seconds.

    ``space_kind`` records the space the coordinates belong to (``"se3"``...), so that a loaded path
    is not misread.
    """

    configurations: np.ndarray
    times: np.ndarray | None = None
    space_kind: str = ""

    def __post_init__(self) -> None:
        self.configurations = np.atleast_2d(np.asarray(self.configurations, dtype=np.float64))
        if self.times is not None:
            self.times = np.asarray(self.times, dtype=np.float64)
            if self.times.shape != (len(self.configurations),):
                raise ConfigError("times must have one entry per configuration", field="times",
                                  value=list(self.times.shape))

    def __len__(self) -> int:
        return len(self.configurations)

    def to_dict(self) -> dict:
        return {"configurations": self.configurations.tolist(),
                "times": None if self.times is None else self.times.tolist(), "space_kind": self.space_kind}

    @classmethod
    def from_dict(cls, data: dict) -> Path:
        return cls(np.asarray(data["configurations"], dtype=np.float64),
                   None if data.get("times") is None else np.asarray(data["times"]), data.get("space_kind", ""))


class Policy:
    """Base class of policies (e.g. the partial policies of thesis ch. 5).

    Subclasses set a unique ``kind`` and implement :meth:`to_dict` / :meth:`from_dict`; they are
    found again by ``kind`` when a result is loaded.  A kind that can be executed names its execution strategy in
    :attr:`follower`.
    """

    kind: ClassVar[str] = ""
    _kinds: ClassVar[dict[str, type[Policy]]] = {}
    #: called once when a file names an unknown kind: imports the installed planners' modules, where policy kinds
    #: are defined (set by :mod:`pliant.registry` when it is imported; results stay data, importing no registry)
    kind_loader: ClassVar[Callable[[], None] | None] = None
    #: how a policy of this kind is executed: ``"module:factory"``, a function ``factory(policy, context, settings)``
    #: returning the :class:`~pliant.execution.strategy.ExecutionStrategy` the one execution loop follows
    #: (:func:`pliant.execution.strategy.strategy_for`); empty: the kind cannot be executed.  A result stays data:
    #: it names its strategy, and nothing here imports or runs it.
    follower: ClassVar[str] = ""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if cls.kind:
            Policy._kinds[cls.kind] = cls

    def to_dict(self) -> dict:
        raise NotImplementedError

    @classmethod
    def from_dict(cls, data: dict) -> Policy:
        if not isinstance(data, dict):
            raise ConfigError("a policy must be a table", field="policy", value=type(data).__name__)
        kind = data.get("kind")
        if kind not in Policy._kinds and Policy.kind_loader is not None:
            Policy.kind_loader()
        if kind not in Policy._kinds:
            raise ConfigError(f"unknown policy kind (known: {', '.join(sorted(Policy._kinds)) or 'none'}; is the "
                              "plugin that defines it installed?)", field="policy.kind", value=kind)
        return Policy._kinds[kind].from_dict(data)

    def save(self, path: str | FilePath) -> None:
        """Write the policy as JSON (parent directories are created)."""
        _write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | FilePath) -> Policy:
        """Read a policy written by :meth:`save` (of ``cls``'s kind, or any kind when called on the base)."""
        data = _read_json(path, "policy")
        try:
            return cls.from_dict(data)
        except ConfigError as exc:
            raise ConfigError(exc.message, source=str(path), field=exc.field,
                              **({"value": exc.value} if exc.has_value else {})) from None


@dataclass
class PlanResult:
    """The outcome of :meth:`pliant.interfaces.Planner.plan`.

    status: see :class:`Status`.
    path: the solution (or best approximate) path, else ``None``.
    policy: for planners that return policies.
    cost: the planner's objective value of ``path`` (NaN when there is none).
    statistics: counters and timings (``iterations``, ``nodes``, ``time``, ``time_to_first`` in
        seconds, ``cost_history`` as ``[[t, cost], ...]``...).
    seed: the seed of the run the planner's generator came from, for reproduction.
    streams: the run's stream layout (:mod:`pliant.seeds`): stage -> ``[seed, *spawn_key]``, e.g.
        ``{"planning": [0, 1], "metrics": [0, 2]}``; the planner drew from ``streams["planning"]``.  ``None`` for a
        result made outside a pipeline.
    """

    status: Status
    path: Path | None = None
    policy: Policy | None = None
    cost: float = math.nan
    statistics: dict[str, Any] = field(default_factory=dict)
    seed: int | None = None
    planner: str = ""
    options: dict[str, Any] = field(default_factory=dict)
    message: str = ""
    streams: dict[str, list[int]] | None = None

    @property
    def solved(self) -> bool:
        return self.status.success

    @classmethod
    def invalid_endpoint(cls, status: Status, planner: str, options: dict | None = None,
                         statistics: dict | None = None) -> PlanResult:
        """The result of a query whose start or goal failed validity (``status`` is INVALID_START or
        INVALID_GOAL, as :meth:`PlanningProblem.checked_endpoints` returns it)."""
        which = {Status.INVALID_START: "start", Status.INVALID_GOAL: "goal"}.get(status)
        if which is None:
            raise ConfigError("not an endpoint status", field="status", value=status.value)
        return cls(status, planner=planner, options=dict(options or {}), statistics=dict(statistics or {}),
                   message=f"the {which} configuration is not valid")

    def to_dict(self) -> dict:
        return {"status": self.status.value, "path": None if self.path is None else self.path.to_dict(),
                "policy": None if self.policy is None else self.policy.to_dict(),
                "cost": None if math.isnan(self.cost) else self.cost, "statistics": jsonable(self.statistics),
                "seed": self.seed, "planner": self.planner, "options": jsonable(self.options),
                "message": self.message, **({"streams": self.streams} if self.streams is not None else {})}

    @classmethod
    def from_dict(cls, data: dict) -> PlanResult:
        try:
            status = Status(data["status"])
        except (KeyError, ValueError):
            raise ConfigError("unknown or missing status", field="status", value=data.get("status")) from None
        return cls(status=status, path=None if data.get("path") is None else Path.from_dict(data["path"]),
                   policy=None if data.get("policy") is None else Policy.from_dict(data["policy"]),
                   cost=math.nan if data.get("cost") is None else float(data["cost"]),
                   statistics=dict(data.get("statistics") or {}), seed=data.get("seed"),
                   planner=data.get("planner", ""), options=dict(data.get("options") or {}),
                   message=data.get("message", ""), streams=data.get("streams"))

    def save(self, path: str | FilePath) -> None:
        """Write the result as JSON (parent directories are created)."""
        _write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | FilePath) -> PlanResult:
        """Read a result written by :meth:`save`."""
        return cls.from_dict(_read_json(path, "result"))


def jsonable(value: Any) -> Any:
    """``value`` with numpy arrays and scalars, tuples and enums turned into JSON types (dict keys as strings); a
    non-finite float becomes ``None`` (results are strict JSON)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, enum.Enum):
        return value.value
    return value


def _write_json(path: str | FilePath, data: dict) -> None:
    """Write ``data`` as indented strict JSON, atomically (:func:`pliant.files.write_json`), creating parent
    directories."""
    from pliant.files import write_json

    write_json(path, jsonable(data))


def _read_json(path: str | FilePath, what: str) -> dict:
    """The JSON in ``path``; :class:`ConfigError` naming the file when it cannot be read or parsed."""
    try:
        return json.loads(FilePath(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ConfigError(f"cannot read {what} file: {exc}", source=str(path), field="<file>") from None
