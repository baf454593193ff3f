"""Ground truth of thesis 6.5's tables: executions in a dynamic simulator with friction.

The thesis executed each task 100 times per cell on a real KUKA iiwa under Cartesian impedance control.  Here the
robot is the task's dynamic simulator (pybullet for the pegs, pymunk for se2-through-passage) with the
cell's actuation noise (eq. 6.14-6.15), driven by the contact motion controller (thesis app. C, ``contact``
plugin) through :func:`pliant.execution.loop.execute`, from start configurations drawn uniformly in the
``epsilon_reached`` ball around the first waypoint (collision-free), exactly as the metrics draw theirs.  An
execution succeeds when the controller reaches the second waypoint within ``epsilon_reached`` (weighted
distance: the robot's space is built with the task's translation weight, :attr:`.MetricTask.translation_weight`);
it fails when the controller gives up (stuck, app. C) or the time limit passes.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from pliant_reachability.tasks import TASKS

#: the contact controller's gain (1/s): the kinematic simulator's kp = 1 per 0.1 s step
CONTROLLER_GAIN = 10.0


@lru_cache(maxsize=4)
def _worlds(task_name: str, alpha: float, epsilon: float):
    from pliant import api
    from pliant.api import Context

    task = TASKS[task_name]
    context = Context(scene=api.load_scene(task.scene))
    context.robot = api.registry.create("robot", "rigid", context, translation_weight=task.translation_weight)
    context.simulator = api.registry.create("simulator", "kinematic", context, **task.simulator_options(alpha))
    world = api.registry.create("simulator", task.world, context, **task.world_settings(alpha))
    controller = api.registry.create("controller", "contact", context, gain=CONTROLLER_GAIN, tolerance=epsilon)
    metric = api.registry.create("metric", "simulation", context, epsilon_reached=epsilon,
                                    translation_weight=task.translation_weight)
    return world, controller, metric


def ground_truth(task_name: str, epsilon: float, alpha: float, executions: int, seed: int,
                 time_limit: float = 30.0) -> dict:
    """``executions`` dynamic executions of the task's waypoint pair in cell ``(epsilon, alpha)`` (``epsilon``:
    weighted distance, ``alpha``: eq. 6.14's noise factor), each at most ``time_limit`` s of simulated time, from
    starts and noise drawn with ``seed``; the fraction that succeed (``p_exec``), and the outcomes (thesis 6.5's
    ground truth)."""
    import time

    from pliant.api import Path
    from pliant.api import execute_path as execute

    task = TASKS[task_name]
    world, controller, metric = _worlds(task_name, alpha, epsilon)
    a, b = (np.asarray(w, dtype=np.float64) for w in task.waypoints)
    rng = np.random.default_rng(seed)
    volumes = metric.volumes(a, b)
    starts = metric.starts(volumes, rng, executions)
    outcomes = []
    started = time.perf_counter()
    for q in starts:
        record = execute(world, controller, Path(np.array([q, b])), rng, period=1.0 / task.simulator["frequency"],
                         time_limit=time_limit, world_name=task.world)
        final = volumes.coordinates(record.configurations[-1][None]) if len(record.configurations) else None
        reached = record.outcome == "reached" or (
            final is not None and volumes.distance_to_target(final)[0] <= epsilon)
        outcomes.append("reached" if reached else record.outcome)
    counts = {o: outcomes.count(o) for o in sorted(set(outcomes))}
    return {"task": task_name, "method": "ground truth", "world": task.world, "epsilon": epsilon, "alpha": alpha,
            "seed": seed, "p_exec": counts.get("reached", 0) / len(outcomes), "executions": len(outcomes),
            "outcomes": counts, "seconds": time.perf_counter() - started, "simulated_steps": 0.0}
