"""Tasks for testing executors (importable on every node of a cluster, as task functions must be)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from pliant.termination import Termination


def anytime(seed: int, seconds: float, marker: str | None = None, step: float = 0.01) -> dict:
    """An anytime loop like a planner's: for up to ``seconds`` it lowers a best cost drawn from ``seed``, publishing
    ``iterations`` and ``best_cost`` through its :class:`~pliant.termination.Termination`; a cancelled task (the
    executor terminates it) ends at its next check.  ``marker``: a file written with ``interrupted`` or ``done`` when
    the loop ends.  The record (seed and best cost after the loop) depends on the seed and the iterations run."""
    rng = np.random.default_rng(seed)
    stop = Termination(max_time=seconds)
    best, iteration = float("inf"), 0
    with stop.watch():
        while not stop.should_stop(iteration, best, solved=np.isfinite(best)):
            best = min(best, float(rng.random()) * 100.0)
            iteration += 1
            stop.publish(nodes=iteration)
            time.sleep(step)
    if marker:
        Path(marker).write_text("interrupted" if stop.interrupted else "done")
    return {"seed": seed, "best_cost": best, "iterations": iteration, "interrupted": stop.interrupted}


def fails_for(seed: int, failing: tuple[int, ...] = ()) -> dict:
    """A task that raises :class:`~pliant.errors.SimulationError` (naming the seed) when ``seed`` is in ``failing``,
    else returns ``{"seed": seed}``: a task error for the executors' tests."""
    from pliant.errors import SimulationError

    if seed in failing:
        raise SimulationError("the task's simulator refused its start", field="seed", value=seed)
    return {"seed": seed}
