"""A*'s time budget holds inside a search (issue 31): chunked expansions, checked with a fake clock."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import Pipeline
from pliant.interfaces import PlanningProblem
from pliant.results import Status
from pliant.termination import BudgetExpired, Termination
from pliant_astar import search as search_module
from pliant_astar.search import search


class TickClock:
    """Advances ``tick`` s at every reading."""

    def __init__(self, tick: float = 1.0) -> None:
        self.now, self.tick, self.readings = 0.0, tick, 0

    def __call__(self) -> float:
        self.readings += 1
        self.now += self.tick
        return self.now


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 7))
def test_the_result_does_not_depend_on_the_chunk_size(seed, chunk):
    rng = np.random.default_rng(seed)
    shape = tuple(int(n) for n in rng.integers(2, 7, 3))
    costs = rng.choice([0.0, 1.0, 3.5], size=shape)
    costs[rng.random(shape) < 0.2] = np.nan
    start = tuple(int(rng.integers(0, n)) for n in shape)
    goal = tuple(int(rng.integers(0, n)) for n in shape)
    costs[start] = costs[goal] = 0.0
    p = float(rng.random())
    whole = search(costs, start, goal, p, chunk=10**9)
    chunked = search(costs, start, goal, p, chunk=chunk)
    assert whole[1] == chunked[1] and whole[2] == chunked[2]
    assert (whole[0] is None) == (chunked[0] is None)
    if whole[0] is not None:
        assert np.array_equal(whole[0], chunked[0])


def test_a_search_stops_at_the_first_chunk_past_the_budget():
    costs = np.zeros((12, 12, 12))
    clock = TickClock()
    budget = Termination(max_time=3.0, clock=clock)
    budget.start()                                     # reading 1 (construction read 0)
    with pytest.raises(BudgetExpired), budget.interruptible():
        search(costs, (0, 0, 0), (11, 11, 11), 0.0, chunk=1)
    # readings at the checkpoints after chunks 1, 2, 3; the third is past the budget: 3 expansions, not 12^3
    assert clock.readings == 2 + 3


def test_the_planner_returns_timeout_when_the_budget_ends_mid_search(monkeypatch):
    pipe = Pipeline("triple-wall", cost="voxel", planner={"name": "astar"})
    ctx = pipe.build()
    problem = PlanningProblem.from_context(ctx)
    planner = ctx.extras["planner"]
    solved = planner.plan(problem, np.random.default_rng(0))
    assert solved.status is Status.SOLVED and solved.statistics["expanded"] > 1000
    monkeypatch.setattr(search_module, "CHUNK", 100)
    clock = TickClock()
    cut = planner.plan(problem, np.random.default_rng(0), Termination(max_time=5.0, clock=clock))
    assert cut.status is Status.TIMEOUT and cut.path is None
    assert clock.readings <= 2 + 5                     # construction, start, then one reading per chunk
    budget = cut.statistics["budget"]
    assert {k: budget[k] for k in ("max_time", "max_iterations")} == {"max_time": 5.0, "max_iterations": None}
    assert budget["binding"] == "time" and budget["source"] == "termination"   # the clock stopped it, and says so
    # the time cap that never fires changes nothing
    again = planner.plan(problem, np.random.default_rng(0), Termination(max_time=1e12, clock=TickClock()))
    assert again.cost == solved.cost and np.array_equal(again.path.configurations, solved.path.configurations)


def test_a_pareto_sweep_cut_mid_search_keeps_the_finished_values(monkeypatch):
    pipe = Pipeline.from_file("triple-wall-pareto", overrides=["planner.values=5"])
    ctx = pipe.build()
    problem = PlanningProblem.from_context(ctx)
    planner = ctx.extras["planner"]
    full = planner.plan(problem, np.random.default_rng(0))
    assert full.statistics["values_done"] == 5
    monkeypatch.setattr(search_module, "CHUNK", 1000)     # a clock reading every 1000 expansions
    per_value = [run[0] for run in full.statistics["sweep"]]
    cut = planner.plan(problem, np.random.default_rng(0), Termination(max_time=12.0, clock=TickClock()))
    done = cut.statistics["values_done"]
    assert 1 <= done < 5 and cut.status is Status.APPROXIMATE
    assert cut.statistics["sweep"] == full.statistics["sweep"][:done]
    assert [run[0] for run in cut.statistics["sweep"]] == per_value[:done]
