"""What the execution loop follows: a *strategy* that says, from what was observed, what to do next.

The loop (:func:`pliant.execution.loop.follow`) owns the world: it places the robot, steps the world under the
controller, records every step, enforces the time limit and keeps the record when something raises.  A strategy owns
only the decisions, one *directive* at a time:

- :class:`Place` -- put the robot (and, in a simulator that can place objects, the movable objects) somewhere; the
  first directive of every strategy (:meth:`ExecutionStrategy.begin`);
- :class:`Drive` -- drive toward a target configuration with the controller, until it is reached, the controller
  gives up (stuck) or the directive's time runs out (closed loop: a path's waypoint, a policy's action);
- :class:`Move` -- command a velocity for a duration, open loop (a push primitive of a push plan);
- :class:`Done` -- end, with an outcome.

After each directive the loop hands the strategy an :class:`Observation`: the configuration reached, the time, the
objects' poses, how the directive ended.  A path (:class:`PathStrategy`, here), a partial policy (``pliant_belief``)
and a push plan (``pliant_tsrrt``) are strategies; a plugin makes its policy kind executable by naming a strategy
factory in :attr:`pliant.results.Policy.follower` (``"module:function"``, called as ``factory(policy, context,
settings)`` with the pipeline's ``[execution]`` settings), which :func:`strategy_for` resolves.

:class:`ScriptedStrategy` lets a strategy be written as one generator that yields directives and receives
observations (an error a directive was allowed to survive is thrown into it).
"""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass, field
from importlib import import_module
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from pliant.errors import ConfigError
from pliant.execution.record import ExecutionDetails, ExecutionOutcome, PathDetails

if TYPE_CHECKING:
    from pliant.results import Path, PlanResult


@dataclass(frozen=True)
class Place:
    """Put the robot at ``configuration`` ``(d,)`` (a simulator places it; a driver moves there within its limits)
    and, when given, the movable ``objects`` at their poses (by name; only a world that can place objects).
    ``recover``: a :class:`~pliant.errors.SimulationError` of the placement (the robot placed into an obstacle) is
    reported to the strategy (:attr:`Observation.error`) instead of ending the execution."""

    configuration: np.ndarray
    objects: dict[str, np.ndarray] | None = None
    recover: bool = False


@dataclass(frozen=True)
class Drive:
    """Drive toward ``target`` ``(d,)`` with the controller (:func:`pliant.execution.loop.drive`), for at most
    ``time_limit`` s (``None``: what is left of the execution's time limit, which caps it anyway)."""

    target: np.ndarray
    time_limit: float | None = None


@dataclass(frozen=True)
class Move:
    """Command ``velocity`` ``(t,)`` for ``duration`` s, open loop, in equal steps of at most ``period`` s (``None``:
    the execution's control period).  Not cut by the execution's time limit (the strategy decides how many it
    asks for).  ``recover`` as :class:`Place`."""

    velocity: np.ndarray
    duration: float
    period: float | None = None
    recover: bool = False


@dataclass(frozen=True)
class Done:
    """End the execution with ``outcome`` (an :class:`~pliant.execution.record.ExecutionOutcome` or its value)."""

    outcome: ExecutionOutcome | str


Directive = Place | Drive | Move | Done


@dataclass
class Observation:
    """What the loop saw after a directive: ``result`` (``"placed"``, ``"moved"``; a drive's ``"reached"`` /
    ``"stuck"`` / ``"timeout"``; ``"failed"`` with ``error`` for a directive allowed to fail), the ``time`` (s) since
    the execution began, its ``time_limit`` (s), and -- read from the world when first asked -- the ``configuration``
    reached and the movable ``objects``' poses."""

    result: str
    time: float
    time_limit: float
    _world: Any = field(repr=False)       # read from, never stepped: the loop is the only one that steps it
    error: Exception | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def configuration(self) -> np.ndarray:
        if "q" not in self._cache:
            self._cache["q"] = np.asarray(self._world.configuration(), dtype=np.float64)
        return self._cache["q"]

    @property
    def objects(self) -> dict[str, np.ndarray]:
        if "objects" not in self._cache:
            self._cache["objects"] = dict(self._world.object_poses())
        return self._cache["objects"]


@runtime_checkable
class ExecutionStrategy(Protocol):
    """What :func:`pliant.execution.loop.follow` follows: ``begin(rng)`` returns the first directive (a
    :class:`Place`), ``next(observation)`` each following one, until a :class:`Done`; ``events`` (``"t=1.20s:
    ..."`` lines) and ``details()`` (an :class:`~pliant.execution.record.ExecutionDetails`) go into the record,
    also the partial record of an execution that raised."""

    events: list[str]

    def begin(self, rng: np.random.Generator) -> Place: ...

    def next(self, observation: Observation) -> Directive: ...

    def details(self) -> ExecutionDetails: ...


class ScriptedStrategy:
    """A strategy written as one generator, :meth:`script`: it yields directives (a :class:`Place` first), receives
    the :class:`Observation` of each, and returns the outcome.  A directive's error reported by the loop (``recover``)
    is raised inside the generator at its ``yield``; :attr:`last` is the latest observation."""

    def __init__(self) -> None:
        self.events: list[str] = []
        self.last: Observation | None = None
        self._script: Generator[Directive, Observation, ExecutionOutcome | str] | None = None

    def script(self, rng: np.random.Generator) -> Generator[Directive, Observation, ExecutionOutcome | str]:
        raise NotImplementedError

    def begin(self, rng: np.random.Generator) -> Place:
        self._script = self.script(rng)
        first = next(self._script)
        if not isinstance(first, Place):
            raise ConfigError("a strategy begins by placing the robot", field="strategy",
                              value=type(first).__name__)
        return first

    def next(self, observation: Observation) -> Directive:
        self.last = observation
        try:
            if observation.error is not None:
                return self._script.throw(observation.error)
            return self._script.send(observation)
        except StopIteration as stop:
            return Done(stop.value)

    def details(self) -> ExecutionDetails:
        return ExecutionDetails()


class PathStrategy(ScriptedStrategy):
    """Follow ``path`` waypoint by waypoint: place the robot at the first, then drive to each of the others; ends
    ``reached`` (the last), ``stuck`` (the controller gave up) or ``timeout`` (the execution's time limit)."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.waypoints = np.atleast_2d(path.configurations)
        self.reached = 0

    def script(self, rng):
        yield Place(self.waypoints[0])
        for index, target in enumerate(self.waypoints[1:], start=1):
            seen = yield Drive(target)
            if seen.result == "reached":
                self.reached = index
                continue
            if seen.result == "stuck":
                self.events.append(f"t={seen.time:.2f}s: stuck before waypoint {index}")
                return ExecutionOutcome.STUCK
            self.events.append(f"t={seen.time:.2f}s: time limit before waypoint {index}")
            return ExecutionOutcome.TIMEOUT
        return ExecutionOutcome.REACHED

    def details(self) -> PathDetails:
        return PathDetails(waypoints_reached=self.reached)


class TrajectoryStrategy(ScriptedStrategy):
    """Follow a time-parameterised trajectory (:class:`pliant.planning.trajectory.Trajectory`): place the robot at
    its start, then each control ``period`` command the velocity that brings the observed configuration to the
    trajectory's position at the end of the period (its reference velocity plus the correction of the lag, within
    the trajectory's velocity limits), and finally drive to the last knot.  ``space``: the configuration space
    (``difference`` gives the tangent velocity).  Ends ``reached``, ``stuck`` or ``timeout`` as
    :class:`PathStrategy`."""

    def __init__(self, trajectory: Any, period: float, space: Any = None) -> None:
        super().__init__()
        self.trajectory = trajectory
        self.period = float(period)
        self.space = space
        self.reached = 0

    def script(self, rng):
        trajectory = self.trajectory
        seen = yield Place(trajectory.knots[0])
        t, end = 0.0, trajectory.duration
        while t < end - 1e-12:
            h = min(self.period, end - t)
            target = trajectory.state([t + h])[0][0]
            here = seen.configuration
            delta = self.space.difference(target, here) if self.space is not None else target - here
            velocity = np.clip(np.asarray(delta, dtype=np.float64) / h, -trajectory.velocity, trajectory.velocity)
            seen = yield Move(velocity, h)
            t += h
        seen = yield Drive(trajectory.knots[-1])
        if seen.result == "reached":
            self.reached = len(trajectory.knots) - 1
            return ExecutionOutcome.REACHED
        self.events.append(f"t={seen.time:.2f}s: {seen.result} before the trajectory's end")
        return ExecutionOutcome.STUCK if seen.result == "stuck" else ExecutionOutcome.TIMEOUT

    def details(self) -> PathDetails:
        return PathDetails(waypoints_reached=self.reached)


def strategy_for(result: PlanResult, context: Any = None, settings: dict | None = None) -> ExecutionStrategy:
    """The strategy that executes ``result``: its policy's (the factory its kind names in
    :attr:`~pliant.results.Policy.follower`, given the pipeline's ``context`` and ``[execution]`` ``settings``), else
    a :class:`PathStrategy` over its path."""
    policy = result.policy
    if policy is None:
        if result.path is None:
            raise ConfigError("the result has neither a path nor a policy to execute", field="result.path", value=None)
        return PathStrategy(result.path)
    factory = policy_strategy_factory(policy)
    return factory(policy, context, dict(settings or {}))


def policy_strategy_factory(policy) -> Any:
    """The strategy factory named by ``policy``'s kind (:attr:`~pliant.results.Policy.follower`)."""
    spec = getattr(type(policy), "follower", "")
    if not spec:
        raise ConfigError(f"policies of kind '{policy.kind}' cannot be executed", field="policy.kind",
                          value=policy.kind)
    module, _, name = spec.partition(":")
    try:
        return getattr(import_module(module), name)
    except (ImportError, AttributeError) as exc:
        raise ConfigError(f"the execution strategy of policies of kind '{policy.kind}' cannot be loaded: {exc}",
                          field="policy.follower", value=spec) from None
