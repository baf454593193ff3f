"""Budgets inside long work (issue 31): clocks, expiry, checkpoints, and the budget every PlanResult records."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from pliant import Pipeline
from pliant.interfaces import PlanningProblem
from pliant.termination import (
    BudgetExpired,
    Termination,
    all_of,
    any_of,
    budget,
    checkpoint,
    iteration_limit,
    task_progress,
    time_limit,
)


class ManualClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_an_injected_clock_drives_the_time_budget():
    clock = ManualClock()
    t = Termination(max_time=2.0, clock=clock)
    t.start()
    assert not t.should_stop(0) and not t.expired()
    clock.now = 1.999
    assert not t.expired() and t.elapsed == pytest.approx(1.999)
    clock.now = 2.0
    assert t.expired() and t.should_stop(1) and not t.interrupted


def test_expiry_ignores_iterations_costs_and_callbacks_but_not_terminate():
    t = Termination(max_iterations=1, cost_reached=5.0, callback=lambda i, c: True)
    t.start()
    assert t.should_stop(3, 1.0) and not t.expired()      # progress rules are for should_stop only
    t.terminate()
    assert t.expired()


def test_combined_conditions_expire_as_they_stop():
    clock = ManualClock()
    fast = Termination(max_time=1.0, clock=clock)
    either = any_of(fast, iteration_limit(10))
    both = all_of(Termination(max_time=1.0, clock=clock), iteration_limit(10))
    either.start()
    both.start()
    clock.now = 5.0
    assert either.expired() and not both.expired()        # all_of also needs the iterations spent


def test_checkpoint_raises_only_inside_an_interruptible_block_of_an_expired_condition():
    clock = ManualClock()
    t = Termination(max_time=1.0, clock=clock)
    t.start()
    clock.now = 3.0
    checkpoint()                                          # no block: nothing to stop
    with pytest.raises(BudgetExpired, match="budget expired") as caught:
        with t.interruptible():
            checkpoint()
    assert caught.value.condition is t and caught.value.value == 1.0
    checkpoint()                                          # the block ended with the exception


def test_nested_blocks_check_every_enclosing_condition_and_other_threads_are_not_affected():
    clock = ManualClock()
    outer, inner = Termination(max_time=1.0, clock=clock), Termination(max_time=100.0, clock=clock)
    outer.start()
    inner.start()
    with outer.interruptible(), inner.interruptible():
        checkpoint()
        errors = []
        clock.now = 2.0

        def elsewhere():
            try:
                checkpoint()                              # this thread has no block
            except BudgetExpired as exc:                  # pragma: no cover - the failure being tested
                errors.append(exc)

        thread = threading.Thread(target=elsewhere)
        thread.start()
        thread.join()
        assert not errors
        with pytest.raises(BudgetExpired):
            checkpoint()


def test_a_cancelled_executor_task_expires_its_conditions():
    cancel = threading.Event()
    t = Termination()
    t.start()
    with task_progress(cancel), t.interruptible():
        checkpoint()
        cancel.set()
        with pytest.raises(BudgetExpired, match="interrupted"):
            checkpoint()
    assert t.interrupted


def test_budget_reads_the_tightest_of_any_and_the_loosest_of_all():
    assert budget(None) == {"max_time": None, "max_iterations": None}
    assert budget(Termination(max_time=3.0, max_iterations=7)) == {"max_time": 3.0, "max_iterations": 7}
    assert budget(any_of(time_limit(5.0), time_limit(2.0), iteration_limit(9))) == {"max_time": 2.0,
                                                                                   "max_iterations": 9}
    assert budget(all_of(time_limit(5.0), time_limit(2.0))) == {"max_time": 5.0, "max_iterations": None}


def test_every_plan_result_records_its_budget_and_the_time_used_and_the_report_prints_them():
    pipe = Pipeline("se2-maze", planner={"name": "straight", "step": 0.05})
    ctx = pipe.build()
    problem = PlanningProblem.from_context(ctx)
    result = ctx.extras["planner"].plan(problem, np.random.default_rng(0))
    assert result.statistics["budget"] == {"max_time": None, "max_iterations": None, "unit": "iterations",
                                           "binding": "done", "source": "options"}
    assert result.statistics["planning_time"] >= 0.0
    capped = ctx.extras["planner"].plan(problem, np.random.default_rng(0), any_of(time_limit(4.0),
                                                                                  iteration_limit(3)))
    assert {k: capped.statistics["budget"][k] for k in ("max_time", "max_iterations", "source")} == \
        {"max_time": 4.0, "max_iterations": 3, "source": "termination"}
    record = Pipeline("se2-maze", planner="rrtstar", planning={"max_time": 30.0, "max_iterations": 5}).run(write=False)
    recorded = record.result.statistics["budget"]
    assert {k: recorded[k] for k in ("max_time", "max_iterations", "binding", "source")} == \
        {"max_time": 30.0, "max_iterations": 5, "binding": "iterations", "source": "request"}
    rows = dict(record.summary_rows())
    used = record.result.statistics["planning_time"]
    assert rows["budget"] == f"30 s or 5 {recorded['unit']}, used {used:.2f} s"
    assert rows["budget binding"] == "iterations"


def test_a_shortcut_stopped_by_the_budget_is_the_shortcut_of_the_iterations_it_ran():
    from pliant.planning.shortcut import perturb, shortcut

    pipe = Pipeline("se2-maze", planner={"name": "straight"})          # maze-slide's scripted, valid motion
    problem = PlanningProblem.from_context(pipe.build())
    path = np.array([problem.start, [7.75, 5.0, 0.0], [7.75, 1.375, 0.0], [0.75, 1.375, 0.0], problem.goal])
    assert problem.path_is_valid(path)
    step = problem.scene.resolution
    for method, extra in ((shortcut, {"length_weight": 1.0}),
                          (perturb, {"spacing": 2.5 * step, "sigma": step, "length_weight": 1.0})):
        calls = []

        def stop(calls=calls):
            calls.append(1)
            return len(calls) > 7                   # the budget expires before the eighth iteration

        cut, cut_cost = method(problem, path, np.random.default_rng(1), step=step, iterations=40, stop=stop, **extra)
        ran, ran_cost = method(problem, path, np.random.default_rng(1), step=step, iterations=7, **extra)
        assert len(calls) == 8 and cut_cost == ran_cost and np.array_equal(cut, ran)
        _, before = method(problem, path, np.random.default_rng(1), step=step, iterations=0, **extra)
        assert problem.is_valid(cut).all() and cut_cost <= before
