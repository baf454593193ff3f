"""Warm-up before planning: one-off loading happens when the pipeline is built, not inside a time budget.

The first call of a numba kernel in a process loads it from numba's cache (and the first kernel also numba's own
registries); a first import of scipy's spatial or cluster packages takes a second more.  On the 2-core machine of
the budget benchmark (benchmarks/bench_budgets.py) such loading took 1-5 s of a planner's first ``plan`` call, none
of it interruptible -- more than a short ``max_time`` itself.  A planner's ``bind`` (run when the pipeline is built)
calls :func:`warm_up`, which makes the calls planning makes first, once, on the scene's start: validity of a state
and of a short motion (the collision checker's kernels), the puncture check's sweep kernel, the cost model's cost
and gradient, and, when asked, one control
period of the simulator.  Nothing is planned and no generator of the run is used, so results do not change.
"""

from __future__ import annotations

import time

import numpy as np

from pliant.errors import PliantError


def warm_up(context, *, simulate: bool = False) -> float:
    """Evaluate validity (states and a one-voxel motion), cost and gradient at the scene's start, and with
    ``simulate`` one control period of the simulator from there; returns the seconds spent.  Errors are left to
    planning, which reports them (a pipeline without a scene or robot warms nothing)."""
    from pliant.components import PlanningProblem
    from pliant.geometry import topology_kernels

    t0 = time.perf_counter()
    if getattr(context, "scene", None) is None or getattr(context, "robot", None) is None:
        return 0.0
    try:
        problem = PlanningProblem.from_context(context)
        space = problem.space
        start = space.check(problem.start, field="start")
        goal = space.check(problem.goal, field="goal")
        length = float(space.distance(start, goal))
        step = problem.scene.resolution
        near = space.interpolate(start, goal, min(1.0, step / length)) if length > 0 else start
        problem.is_valid(start[None])
        problem.motions_valid(start[None], np.asarray(near)[None])
        # the puncture check's sweep (T-RRT, RRT*): its compiled kernel, on two points of a one-voxel grid
        topology_kernels.swept_cells(np.zeros((2, 1, 3)), np.ones(3, dtype=np.int64), 0.0)
        cost = problem.cost
        if cost is not None:
            cost.cost(start[None])
            if getattr(cost, "has_gradient", False):
                cost.gradient(start[None])
        simulator = problem.simulator
        if simulate and simulator is not None:
            # a warm-up (loads and compiles the kernels); its draws influence no result
            simulator.simulate(start[None], np.asarray(near), np.random.default_rng(0), 0.1)
    except PliantError:
        pass
    return time.perf_counter() - t0
