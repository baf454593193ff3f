"""One evaluation of one method in one cell of a thesis 6.5 task: the unit of the tables and the benchmark."""

from __future__ import annotations

import time
from functools import lru_cache

import numpy as np

from pliant_reachability.tasks import TASKS, MetricTask


@lru_cache(maxsize=8)
def _context(task_name: str, alpha: float):
    from pliant import api
    from pliant.api import Context

    task = TASKS[task_name]
    context = Context(scene=api.load_scene(task.scene))
    context.robot = api.registry.create("robot", "rigid", context)
    context.simulator = api.registry.create("simulator", "kinematic", context, **task.simulator_options(alpha))
    return context


def task_density(task: MetricTask, epsilon: float = 0.125, alpha: float = 0.0625) -> float:
    """Samples per unit weighted measure that put ``task.largest_volume_samples`` in the largest reachable volume
    of the cell ``(epsilon, alpha)`` (thesis 6.5: the lowest cell), kept for every cell."""
    from pliant import api
    metric = api.registry.create("metric", "reachable-volume", _context(task.name, alpha),
                                    epsilon_reached=epsilon)
    a, b = (np.asarray(w, dtype=np.float64) for w in task.waypoints)
    return task.largest_volume_samples / float(np.max(metric.volumes(a, b).measures()))


def evaluate(task_name: str, method: str, epsilon: float, alpha: float, seed: int, density: float,
             simulations: int | None = None, **options) -> dict:
    """``method``'s scores of the task's waypoint pair in cell ``(epsilon, alpha)`` with ``rng`` seeded ``seed``."""
    from pliant import api
    from pliant.api import Path, PlanningProblem

    task = TASKS[task_name]
    context = _context(task_name, alpha)
    metric = api.registry.create("metric", method, context, epsilon_reached=epsilon, density=density,
                                    simulations=simulations or task.simulations, **{**task.metric_options, **options})
    path = Path(np.asarray(task.waypoints, dtype=np.float64))
    problem = PlanningProblem.from_context(context)
    started = time.perf_counter()
    scores = metric.evaluate(path, problem, np.random.default_rng(seed))
    return {"task": task_name, "method": method, "epsilon": epsilon, "alpha": alpha, "seed": seed, **scores,
            "seconds": time.perf_counter() - started}
