"""When anytime algorithms stop: time, iterations, a callback, or Ctrl-C (DESIGN rule 8)."""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field


@dataclass
class Termination:
    """A stopping rule shared by every anytime planner.

    max_time: wall-clock budget in seconds (``None`` for no limit).
    max_iterations: iteration budget (``None`` for no limit).
    callback: called as ``callback(iteration, best_cost)``; returning True stops the run.
    stop_on_first: stop as soon as a first solution is found.

    Use :meth:`watch` around the loop so that Ctrl-C sets :attr:`interrupted` instead of raising; the
    planner then returns its best result so far.
    """

    max_time: float | None = None
    max_iterations: int | None = None
    callback: Callable[[int, float], bool] | None = None
    stop_on_first: bool = False
    interrupted: bool = False
    _start: float = field(default=0.0, repr=False)

    def start(self) -> None:
        self._start = time.perf_counter()
        self.interrupted = False

    @property
    def elapsed(self) -> float:
        """Seconds since :meth:`start`."""
        return time.perf_counter() - self._start

    def should_stop(self, iteration: int, best_cost: float = float("nan"), solved: bool = False) -> bool:
        """Whether the loop should stop before ``iteration``."""
        if self.interrupted:
            return True
        if self.stop_on_first and solved:
            return True
        if self.max_iterations is not None and iteration >= self.max_iterations:
            return True
        if self.max_time is not None and self.elapsed >= self.max_time:
            return True
        return bool(self.callback and self.callback(iteration, best_cost))

    @contextmanager
    def watch(self):
        """Start the clock and turn SIGINT into :attr:`interrupted` for the duration (main thread only)."""
        self.start()
        if threading.current_thread() is not threading.main_thread():
            yield self
            return

        def handler(signum, frame):
            self.interrupted = True

        previous = signal.signal(signal.SIGINT, handler)
        try:
            yield self
        finally:
            signal.signal(signal.SIGINT, previous)
