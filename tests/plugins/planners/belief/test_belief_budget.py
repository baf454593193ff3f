"""The belief planner's time budget holds inside an extension (issue 31): with a fake clock, no wall time."""

from __future__ import annotations

import numpy as np
from pliant import Pipeline
from pliant.interfaces import PlanningProblem
from pliant.results import Status
from pliant.termination import Termination


class TickClock:
    """A clock that advances ``tick`` s at every reading, so a budget expires after a known number of readings."""

    def __init__(self, tick: float = 1.0) -> None:
        self.now, self.tick, self.readings = 0.0, tick, 0

    def __call__(self) -> float:
        self.readings += 1
        self.now += self.tick
        return self.now


def maze(**planner):
    pipe = Pipeline("se2-maze", simulator={"name": "kinematic", "kp": 0.5, "angular_velocity_limit": 0.125},
                    planner={"name": "belief", "max_time": None, "particles": 8, **planner})
    ctx = pipe.build()
    return PlanningProblem.from_context(ctx), ctx.extras["planner"]


def tree_of(planner) -> list[tuple]:
    return [(n.parent, n.action_id, n.particles.round(12).tobytes()) for n in planner.tree.nodes]


def test_a_budget_expiring_inside_a_simulation_stops_there_and_keeps_the_tree_of_the_finished_extensions():
    problem, planner = maze()
    full = planner.plan(problem, np.random.default_rng(3), Termination(max_iterations=6))
    reference = tree_of(planner)
    # the kinematic simulator reads the clock once per control step (about 40 per simulation here): 150 readings
    # end the budget inside the third or fourth simulation, well before the sixth iteration
    clock = TickClock()
    budget = Termination(max_time=150.0, clock=clock)
    clock.readings = 0
    cut = planner.plan(problem, np.random.default_rng(3), budget)
    stats = cut.statistics
    assert stats["extension_cut"] and not stats["interrupted"]
    # stopped at the first control step past the budget: no clock reading (no control step) after it
    assert clock.readings == 1 + 150                    # the reading of watch()'s start, then 150 ticks
    # consistent: the nodes are exactly the first ones of the uncut run (same random numbers up to the cut), every
    # parent exists, and the simulated particles count only finished simulations
    nodes = tree_of(planner)
    assert 1 <= len(nodes) < len(reference) and nodes == reference[: len(nodes)]
    assert all(-1 <= parent < k for k, (parent, _, _) in enumerate(nodes))
    assert stats["particles_simulated"] % 8 == 0 and stats["particles_simulated"] < full.statistics[
        "particles_simulated"]
    assert cut.status is Status.TIMEOUT and cut.path is None
    budget = cut.statistics["budget"]
    assert {k: budget[k] for k in ("max_time", "max_iterations")} == {"max_time": 150.0, "max_iterations": None}
    assert budget["binding"] == "time" and budget["source"] == "termination"   # the clock stopped it, and says so


def test_a_time_cap_that_never_fires_changes_nothing():
    problem, planner = maze()
    planner.plan(problem, np.random.default_rng(5), Termination(max_iterations=5))
    plain = tree_of(planner)
    capped = planner.plan(problem, np.random.default_rng(5),
                          Termination(max_iterations=5, max_time=1e12, clock=TickClock()))
    assert tree_of(planner) == plain and not capped.statistics["extension_cut"]
