"""When anytime algorithms and experiments stop (DESIGN rule 8), after OMPL's ``PlannerTerminationCondition``.

A stop condition is a :class:`Condition`.  The one every planner builds from its options is :class:`Termination`
(a time budget, an iteration budget, a cost reached, a callback, the first solution -- any of them stops it); the
helpers :func:`time_limit`, :func:`iteration_limit`, :func:`cost_reached`, :func:`first_solution` and :func:`when`
make one-rule conditions, and :func:`any_of` / :func:`all_of` (or ``a | b`` / ``a & b``) combine conditions::

    stop = any_of(time_limit(60.0), cost_reached(0.5))            # whichever comes first
    stop = all_of(iteration_limit(1000), time_limit(5.0))          # both budgets spent
    result = planner.plan(problem, rng, stop)

Every condition has a :meth:`Condition.terminate` that is safe to call from any thread (a viewer, an executor
cancelling a task, a signal handler): the loop polling :meth:`Condition.should_stop` stops at its next check, and
:attr:`Condition.interrupted` tells the planner it was stopped from outside.  :meth:`Condition.watch` also turns
Ctrl-C into ``terminate()`` while the loop runs (main thread only), so the planner returns its best result so far.

Progress values: ``should_stop(iteration, best_cost, solved)`` publishes ``iterations``, ``best_cost`` and
``solved``; a planner may :meth:`Condition.publish` more (``nodes=...``).  :meth:`Condition.progress` returns a
snapshot from any thread.  Inside a task run by an executor (:mod:`pliant.experiments.executor`), every published value
also goes to that task's progress, which the executor collects (live on a Ray cluster, and with the task's record), and
the executor can cancel the task: every condition the task polls then terminates (:func:`task_progress`).

Stopping inside long work: ``should_stop`` is polled between iterations, but one iteration may be long (a belief
planner's forward simulation of many particles, a search kernel's expansions).  Inside ``with
condition.interruptible():`` such work calls :func:`checkpoint` (a simulator once per control step, a chunked search
between chunks), which raises :class:`BudgetExpired` as soon as the condition has :meth:`Condition.expired`: its time
budget is spent or it was terminated (iteration, cost and callback rules are only checked by ``should_stop``).  The
planner catches it, drops the unfinished iteration and returns its best result so far.  Outside such a block
:func:`checkpoint` does nothing (and reads no clock), so work done without a time cap is unchanged.

Clocks: every condition reads ``time.perf_counter`` unless given another (``Termination(max_time=5, clock=fake)``),
so tests can expire a budget at a chosen point without depending on wall time.
"""

from __future__ import annotations

import math
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from pliant.errors import ConfigError, PliantError

#: the progress values of the task an executor is running in this process, and the event by which the executor
#: cancels it (see :func:`task_progress`)
_task_sink: dict | None = None
_task_cancel: threading.Event | None = None
_task_lock = threading.Lock()

#: per thread: the conditions whose :meth:`Condition.interruptible` block is running (innermost last)
_active = threading.local()


class BudgetExpired(PliantError):
    """Raised by :func:`checkpoint` inside :meth:`Condition.interruptible` once the condition has expired (time budget
    spent, or terminated).  ``condition``: the condition that expired.  A planner catches it around its long inner
    work and returns its best result so far; it never escapes a built-in planner."""

    def __init__(self, message: str, *, condition: Condition | None = None, **kwargs) -> None:
        super().__init__(message, **kwargs)
        self.condition = condition


class Condition:
    """Base of every stop condition: a clock, a thread-safe :meth:`terminate`, published progress values, and
    composition (``|`` = any of, ``&`` = all of).  Subclasses implement :meth:`_rule`."""

    def _init_condition(self, clock: Callable[[], float] | None = None) -> None:
        self._now = clock or time.perf_counter
        self._event = threading.Event()
        self._lock = threading.Lock()
        self._values: dict = {}
        self._start = self._now()
        self._stopped_by: str | None = None

    # -- what subclasses decide --------------------------------------------------------------------------------
    def _rule(self, iteration: int, best_cost: float, solved: bool) -> bool:
        """Whether the condition's own rule holds (not counting :meth:`terminate`)."""
        return False

    def _children(self) -> tuple[Condition, ...]:
        return ()

    def _time_rule(self) -> bool:
        """Whether the condition's own time budget is spent (the rule :meth:`expired` checks)."""
        return False

    # -- the clock -----------------------------------------------------------------------------------------------
    def start(self) -> None:
        """Start the clock (of this condition and every condition it combines) and clear a previous ``terminate``."""
        self._start = self._now()
        self._event.clear()
        self._stopped_by = None
        for child in self._children():
            child.start()

    @property
    def elapsed(self) -> float:
        """Seconds since :meth:`start`."""
        return self._now() - self._start

    # -- stopping ----------------------------------------------------------------------------------------------
    def terminate(self) -> None:
        """Stop the loop at its next :meth:`should_stop`; safe to call from any thread (and from a signal handler)."""
        self._event.set()

    @property
    def interrupted(self) -> bool:
        """Whether :meth:`terminate` was called (Ctrl-C inside :meth:`watch`, or another thread): the run was stopped
        from outside rather than by its budget."""
        return self._event.is_set()

    @interrupted.setter
    def interrupted(self, value: bool) -> None:
        if value:
            self._event.set()
        else:
            self._event.clear()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until :meth:`terminate` is called or ``timeout`` seconds pass; returns :attr:`interrupted`."""
        self._event.wait(timeout)
        return self.interrupted

    def should_stop(self, iteration: int, best_cost: float = float("nan"), solved: bool = False) -> bool:
        """Whether the loop should stop before ``iteration``, with the best cost so far (NaN: none) and whether a
        solution exists; also publishes them as progress values (``iterations``, ``best_cost``, ``solved``)."""
        self.publish(iterations=iteration, best_cost=best_cost, solved=solved)
        if _task_cancel is not None and _task_cancel.is_set():       # the executor cancelled the task
            self._event.set()
        return self._holds(iteration, best_cost, solved)

    def _holds(self, iteration: int, best_cost: float, solved: bool) -> bool:
        if self._event.is_set():
            self._stopped_by = self._stopped_by or "interrupted"
            return True
        return self._rule(iteration, best_cost, solved)

    def expired(self) -> bool:
        """Whether the condition holds whatever the loop's progress: :meth:`terminate` was called (or the executor
        cancelled the task), or its time budget is spent.  What long inner work checks (:func:`checkpoint`)."""
        if _task_cancel is not None and _task_cancel.is_set():
            self._event.set()
        if self._event.is_set():
            self._stopped_by = self._stopped_by or "interrupted"
            return True
        if self._time_rule():
            self._stopped_by = self._stopped_by or "time"
            return True
        return False

    def note_stop(self, reason: str) -> None:
        """Record what stopped the loop when the planner stopped it by a rule of its own derived from this condition
        (TS-RRT's time share of the cap: ``"time"``); the first reason recorded is kept."""
        self._stopped_by = self._stopped_by or reason

    @property
    def stopped_by(self) -> str | None:
        """What stopped the loop, once it stopped: ``"iterations"`` (the work budget), ``"time"`` (the wall-clock
        budget: the result then depends on the machine and its load), ``"solution"`` (the first solution),
        ``"cost"``, ``"callback"`` or ``"interrupted"``; ``None`` while it has not stopped the loop (a search that ended
        on its own)."""
        if self._stopped_by is not None:
            return self._stopped_by
        for child in self._children():
            if child.stopped_by is not None:
                return child.stopped_by
        return None

    @contextmanager
    def interruptible(self) -> Iterator[Condition]:
        """Let long work inside the block stop early: there :func:`checkpoint` raises :class:`BudgetExpired` once
        this condition has :meth:`expired`.  The caller catches it and drops the unfinished work (see the module
        docstring); blocks nest, and every condition of the enclosing blocks (in this thread) is checked."""
        stack = getattr(_active, "conditions", None)
        if stack is None:
            stack = _active.conditions = []
        stack.append(self)
        try:
            yield self
        finally:
            stack.pop()

    # -- progress ----------------------------------------------------------------------------------------------
    def publish(self, **values) -> None:
        """Publish named progress values (``nodes=812, best_cost=3.1``); readable from any thread by
        :meth:`progress` and collected by the executor running the task."""
        with self._lock:
            self._values.update(values)
        if _task_sink is not None:
            with _task_lock:
                _task_sink.update(values)

    def progress(self) -> dict:
        """A snapshot of the published progress values and the elapsed time (s)."""
        with self._lock:
            return {**self._values, "elapsed": self.elapsed}

    # -- Ctrl-C ------------------------------------------------------------------------------------------------
    @contextmanager
    def watch(self) -> Iterator[Condition]:
        """Start the clock and turn SIGINT and SIGTERM into :meth:`terminate` for the duration (main thread only;
        elsewhere only the clock starts -- stop such a loop with :meth:`terminate`)."""
        self.start()
        if threading.current_thread() is not threading.main_thread():
            yield self
            return

        def handler(signum, frame):
            _note_interrupt(signum)
            self.terminate()

        previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield self
        finally:
            for s, h in previous.items():
                signal.signal(s, h)

    # -- composition -------------------------------------------------------------------------------------------
    def __or__(self, other: Condition) -> AnyOf:
        return any_of(self, other)

    def __and__(self, other: Condition) -> AllOf:
        return all_of(self, other)


@dataclass(eq=False)
class Termination(Condition):
    """The stopping rule every anytime planner builds from its options: any rule that is set stops the run.

    max_time: wall-clock budget in seconds (``None`` for no limit).
    max_iterations: iteration budget (``None`` for no limit).
    callback: called as ``callback(iteration, best_cost)``; returning True stops the run.
    stop_on_first: stop as soon as a first solution is found.
    cost_reached: stop once the best cost is at most this value (``None``: never; NaN costs never reach it).
    clock: the clock the time budget is measured on (seconds; default ``time.perf_counter``); tests inject a fake
    one so that a budget expires at a chosen point.

    Use :meth:`watch` around the loop so that Ctrl-C calls :meth:`terminate` (:attr:`interrupted` becomes True)
    instead of raising; the planner then returns its best result so far.  Combine with other conditions by
    :func:`any_of` / :func:`all_of`.
    """

    max_time: float | None = None
    max_iterations: int | None = None
    callback: Callable[[int, float], bool] | None = None
    stop_on_first: bool = False
    cost_reached: float | None = None
    clock: Callable[[], float] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        self._init_condition(self.clock)
        for name in ("max_time", "max_iterations", "cost_reached"):
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
                raise ConfigError("must be a number or None", field=f"termination.{name}", value=value)
            if name != "cost_reached" and value < 0:
                raise ConfigError("must be >= 0", field=f"termination.{name}", value=value)

    def _rule(self, iteration: int, best_cost: float, solved: bool) -> bool:
        reason = None
        if self.stop_on_first and solved:
            reason = "solution"
        elif self.max_iterations is not None and iteration >= self.max_iterations:
            reason = "iterations"
        elif self.max_time is not None and self.elapsed >= self.max_time:
            reason = "time"
        elif self.cost_reached is not None and best_cost <= self.cost_reached:      # False for NaN
            reason = "cost"
        elif self.callback and self.callback(iteration, best_cost):
            reason = "callback"
        if reason is not None:
            self._stopped_by = self._stopped_by or reason
        return reason is not None

    def _time_rule(self) -> bool:
        return self.max_time is not None and self.elapsed >= self.max_time


class _Combined(Condition):
    def __init__(self, conditions: tuple[Condition, ...], kind: str) -> None:
        if not conditions:
            raise ConfigError("needs at least one condition", field=f"termination.{kind}", value=())
        for k, c in enumerate(conditions):
            if not isinstance(c, Condition):
                raise ConfigError("must be a pliant.termination.Condition", field=f"termination.{kind}[{k}]",
                                  value=c)
        self.conditions = tuple(conditions)
        self._init_condition()

    def _children(self) -> tuple[Condition, ...]:
        return self.conditions

    def expired(self) -> bool:
        """Terminated itself, or (any of / all of) its conditions expired."""
        return super().expired() or self._join(c.expired() for c in self.conditions)

    def publish(self, **values) -> None:
        """Publish on this condition and on every condition it combines (so each one's :meth:`progress` shows it)."""
        super().publish(**values)
        for child in self.conditions:
            with child._lock:
                child._values.update(values)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(map(repr, self.conditions))})"


class AnyOf(_Combined):
    """Stops when any of its conditions holds (OMPL's ``plannerOrTerminationCondition``); made by :func:`any_of`."""

    _join = staticmethod(any)

    def _rule(self, iteration: int, best_cost: float, solved: bool) -> bool:
        return any(c._holds(iteration, best_cost, solved) for c in self.conditions)

    @property
    def interrupted(self) -> bool:
        """Terminated itself, or any of its conditions was."""
        return self._event.is_set() or any(c.interrupted for c in self.conditions)

    @interrupted.setter
    def interrupted(self, value: bool) -> None:
        Condition.interrupted.fset(self, value)


class AllOf(_Combined):
    """Stops when all of its conditions hold (OMPL's ``plannerAndTerminationCondition``); made by :func:`all_of`.
    Its own :meth:`terminate` stops it at once."""

    _join = staticmethod(all)

    def _rule(self, iteration: int, best_cost: float, solved: bool) -> bool:
        return all(c._holds(iteration, best_cost, solved) for c in self.conditions)

    @property
    def interrupted(self) -> bool:
        """Terminated itself, or all of its conditions were."""
        return self._event.is_set() or all(c.interrupted for c in self.conditions)

    @interrupted.setter
    def interrupted(self, value: bool) -> None:
        Condition.interrupted.fset(self, value)


def any_of(*conditions: Condition) -> AnyOf:
    """A condition that holds as soon as any of ``conditions`` does."""
    return AnyOf(conditions, "any_of")


def all_of(*conditions: Condition) -> AllOf:
    """A condition that holds once all of ``conditions`` do."""
    return AllOf(conditions, "all_of")


def time_limit(seconds: float) -> Termination:
    """Stop after ``seconds`` of wall-clock time."""
    return Termination(max_time=seconds)


def iteration_limit(iterations: int) -> Termination:
    """Stop before iteration ``iterations``."""
    return Termination(max_iterations=iterations)


def cost_reached(cost: float) -> Termination:
    """Stop once the best cost is at most ``cost`` (OMPL's ``exactSolnPlannerTerminationCondition`` for a cost)."""
    return Termination(cost_reached=cost)


def first_solution() -> Termination:
    """Stop as soon as a first solution exists."""
    return Termination(stop_on_first=True)


def when(callback: Callable[[int, float], bool]) -> Termination:
    """Stop when ``callback(iteration, best_cost)`` returns True."""
    return Termination(callback=callback)


def never() -> Termination:
    """A condition that holds only when terminated (Ctrl-C inside :meth:`Condition.watch`, or :meth:`terminate`)."""
    return Termination()


def time_left(max_time: float | None, started: float) -> float | None:
    """What is left of a budget of ``max_time`` s (``None``: no limit) since ``started`` (a ``time.perf_counter()``
    value), at least 0: planners build their :class:`Termination` from it after their setup (models, grids, caches),
    so that ``max_time`` bounds the whole ``plan`` call and not only the loop that :meth:`Condition.watch` times."""
    if max_time is None:
        return None
    return max(0.0, max_time - (time.perf_counter() - started))


def budget(condition: Condition | None) -> dict:
    """``{"max_time": s or None, "max_iterations": n or None}``: the budgets that stop ``condition`` (of any of its
    conditions, the tightest; of all of them, the loosest -- ``None`` when one of them has none)."""
    if condition is None:
        return {"max_time": None, "max_iterations": None}
    if isinstance(condition, _Combined):
        parts = [budget(c) for c in condition.conditions]
        out = {}
        for key in ("max_time", "max_iterations"):
            values = [p[key] for p in parts]
            if isinstance(condition, AnyOf):
                values = [v for v in values if v is not None]
                out[key] = min(values) if values else None
            else:
                out[key] = None if None in values else max(values)
        return out
    return {"max_time": getattr(condition, "max_time", None), "max_iterations": getattr(condition, "max_iterations",
                                                                                          None)}


#: the keys of a pipeline's ``[planning]`` table (and of :class:`Budget`)
BUDGET_KEYS = ("max_time", "max_iterations", "stop_on_first")


class BudgetDeprecationWarning(FutureWarning):
    """A planner was given a budget option (``max_time``, ``max_iterations``): the budget belongs to the request now
    (``planning.max_iterations``: the pipeline's ``[planning]`` table, or :attr:`PlanningProblem.budget`).  Shown to
    users by default; the old spelling keeps working for one release."""


@dataclass(frozen=True)
class Budget:
    """The budget of a planning request (a pipeline's ``[planning]`` table, :attr:`PlanningProblem.budget`): it
    bounds the whole ``plan`` call, whatever the planner does inside (set-up, search, post-processing).

    max_iterations: the work budget, in the planner's own unit (its ``PlannerSpecs.work_unit``: RRT*'s samples, a
    belief planner's or TS-RRT's tree extensions); what a result depends on, so that a seed gives the same result on
    any machine under any load.
    max_time: wall-clock seconds, a safety cap (``None``: none).  When it is what stops the planner, the result
    depends on the machine and says so (``statistics["budget"]["binding"] == "time"``).
    stop_on_first: stop at the first solution (``None``: the planner's own default).

    A field left ``None`` is not set: :meth:`merged` fills it from a budget of lower precedence.
    """

    max_time: float | None = None
    max_iterations: int | None = None
    stop_on_first: bool | None = None

    def __post_init__(self) -> None:
        for name in ("max_time", "max_iterations"):
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value) or value < 0:
                raise ConfigError("must be a number >= 0 or omitted", field=f"planning.{name}", value=value)
            if name == "max_iterations" and (not float(value).is_integer() or value < 1):
                raise ConfigError("must be a positive integer", field="planning.max_iterations", value=value)
        if self.max_iterations is not None:
            object.__setattr__(self, "max_iterations", int(self.max_iterations))
        if self.stop_on_first is not None and not isinstance(self.stop_on_first, bool):
            raise ConfigError("must be true or false", field="planning.stop_on_first", value=self.stop_on_first)

    @classmethod
    def from_table(cls, table, source: str | None = None) -> Budget:
        """A budget from a ``[planning]`` table (``None``: an empty budget); unknown keys and bad values raise a
        :class:`~pliant.errors.ConfigError` naming ``planning.<key>``."""
        if table is None:
            return cls()
        if isinstance(table, Budget):
            return table
        if not isinstance(table, dict):
            raise ConfigError(f"must be a table with {', '.join(BUDGET_KEYS)}", source=source, field="planning",
                              value=table)
        unknown = sorted(set(table) - set(BUDGET_KEYS))
        if unknown:
            raise ConfigError(f"unknown field (fields: {', '.join(BUDGET_KEYS)})", source=source,
                              field=f"planning.{unknown[0]}", value=table[unknown[0]])
        try:
            return cls(**table)
        except ConfigError as exc:
            if source is None or exc.source is not None:
                raise
            raise ConfigError(exc.message, source=source, field=exc.field,
                              **({"value": exc.value} if exc.has_value else {})) from None

    def merged(self, over: Budget | None) -> Budget:
        """This budget with every field ``over`` sets replacing this one's."""
        if over is None:
            return self
        return Budget(**{k: getattr(over, k) if getattr(over, k) is not None else getattr(self, k)
                         for k in BUDGET_KEYS})

    def termination(self, started: float | None = None, *, stop_on_first: bool = False, **rules) -> Termination:
        """The :class:`Termination` of this budget for a ``plan`` call that started at ``started`` (a
        ``time.perf_counter()`` value: the time spent since comes off ``max_time``); ``stop_on_first`` is used when
        the budget leaves it unset; ``rules``: more :class:`Termination` fields (``cost_reached=...``)."""
        cap = self.max_time if started is None else time_left(self.max_time, started)
        first = stop_on_first if self.stop_on_first is None else self.stop_on_first
        return Termination(max_time=cap, max_iterations=self.max_iterations, stop_on_first=first, **rules)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in BUDGET_KEYS}


def budget_deprecation(options, owner: str = "planner") -> Budget:
    """The budget a component's options still set under the old spelling (``max_time`` / ``max_iterations`` other
    than ``None``), with one :class:`BudgetDeprecationWarning` naming the new spelling (``planning.max_iterations``);
    an empty :class:`Budget` when they set none."""
    found = {k: getattr(options, k, None) for k in ("max_time", "max_iterations")}
    found = {k: v for k, v in found.items() if v is not None}
    if not found:
        return Budget()
    import warnings

    names = " and ".join(f"'{owner}.{k}'" for k in found)
    new = " and ".join(f"'planning.{k}'" for k in found)
    verb = "are" if len(found) > 1 else "is"
    warnings.warn(f"{names} {verb} deprecated: the budget belongs to the planning request, use {new} (a [planning] "
                  "table in the pipeline file, --set planning.max_iterations=N, or PlanningProblem.budget)",
                  BudgetDeprecationWarning, stacklevel=3)
    return Budget(**found)


#: what interrupted this process's work last (:func:`interrupted_by`)
_interrupted = ["Ctrl-C"]


def _note_interrupt(signum: int) -> None:
    _interrupted[0] = "SIGTERM" if signum == signal.SIGTERM else "Ctrl-C"


def interrupted_by() -> str:
    """What interrupted the work under way: ``"Ctrl-C"`` (SIGINT, or a ``KeyboardInterrupt`` raised any other way)
    or ``"SIGTERM"``, for the messages and records that say why a run stopped."""
    return _interrupted[0]


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM (``kill``, a service manager, a cluster's scheduler) stops the work inside as Ctrl-C does: a
    ``KeyboardInterrupt`` (robots brake, experiments keep their finished tasks, anytime planners inside
    :meth:`Condition.watch` return their best result), and :func:`interrupted_by` says ``"SIGTERM"``.  Needed
    beyond politeness: a command started in the background by a script (``pliant experiment ... &``) inherits
    SIGINT *ignored*, so SIGTERM is the only polite way to stop it.  A second SIGTERM ends the process at once.
    Main thread only (elsewhere it does nothing); the previous handler is restored on leaving; pool workers restore
    the default themselves (:func:`pliant.experiments.executor.worker_init`)."""
    _interrupted[0] = "Ctrl-C"
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        _note_interrupt(signum)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def checkpoint() -> None:
    """Raise :class:`BudgetExpired` if a condition whose :meth:`Condition.interruptible` block encloses this call (in
    this thread) has expired; otherwise do nothing.  Long inner work (a simulator's control steps, a search's chunks)
    calls it so that a planner's time budget holds inside one extension.  Outside such blocks it only reads a
    thread-local list."""
    stack = getattr(_active, "conditions", None)
    if not stack:
        return
    for condition in stack:
        if condition.expired():
            limit = budget(condition)["max_time"]
            raise BudgetExpired("the planning budget expired inside an extension" if not condition.interrupted
                                else "planning was interrupted inside an extension",
                                field="termination.max_time", value=limit, condition=condition)


@contextmanager
def task_progress(cancel: threading.Event | None = None) -> Iterator[dict]:
    """Collect the progress values every condition publishes in this process while the block runs (the executor
    wraps each task in it); yields the dict they are written to (read it after the block, or from another thread).

    ``cancel``: an event the executor sets to cancel the task: every condition polled in the block then terminates
    (:attr:`Condition.interrupted` becomes True), so an anytime planner returns its best result so far."""
    global _task_sink, _task_cancel
    sink: dict = {}
    with _task_lock:
        previous = _task_sink, _task_cancel
        _task_sink, _task_cancel = sink, cancel
    try:
        yield sink
    finally:
        with _task_lock:
            _task_sink, _task_cancel = previous


def snapshot(values: dict) -> dict:
    """A copy of a task's progress values (:func:`task_progress`), safe while conditions publish from other threads."""
    with _task_lock:
        return dict(values)
