"""Composable stop conditions (pliant.termination): any / all, cost reached, thread-safe terminate, progress."""

import signal
import threading
import time

import numpy as np
import pytest
from pliant.errors import ConfigError
from pliant.termination import (
    AllOf,
    AnyOf,
    Termination,
    all_of,
    any_of,
    cost_reached,
    first_solution,
    iteration_limit,
    never,
    task_progress,
    time_limit,
    when,
)


def test_cost_reached_stops_at_or_below_the_cost_and_never_on_nan():
    c = cost_reached(2.0)
    c.start()
    assert not c.should_stop(0, float("nan")) and not c.should_stop(1, 2.5)
    assert c.should_stop(2, 2.0) and c.should_stop(3, 1.0)


def test_any_of_stops_on_the_first_condition_that_holds():
    c = any_of(iteration_limit(10), cost_reached(1.0))
    c.start()
    assert isinstance(c, AnyOf)
    assert not c.should_stop(5, 3.0)
    assert c.should_stop(5, 0.5)                  # the cost
    assert c.should_stop(10, 3.0)                 # the iterations


def test_all_of_stops_only_when_every_condition_holds():
    c = all_of(iteration_limit(10), first_solution())
    c.start()
    assert isinstance(c, AllOf)
    assert not c.should_stop(20, solved=False) and not c.should_stop(5, solved=True)
    assert c.should_stop(10, solved=True)


def test_operators_and_nesting():
    c = (iteration_limit(100) & first_solution()) | when(lambda i, cost: cost < 0.1)
    c.start()
    assert not c.should_stop(200, 1.0, solved=False)
    assert c.should_stop(200, 1.0, solved=True)
    assert c.should_stop(3, 0.05)


def test_time_limit_in_a_combination_uses_the_clock_started_by_watch():
    c = any_of(time_limit(0.05), never())
    with c.watch():
        assert not c.should_stop(0)
        time.sleep(0.06)
        assert c.should_stop(1) and not c.interrupted        # the budget, not an interruption


def test_terminate_from_another_thread_stops_the_loop_and_marks_it_interrupted():
    c = any_of(time_limit(30.0), iteration_limit(10**9))
    started = threading.Event()
    iterations = []

    def loop():
        with c.watch():                       # not the main thread: only the clock starts
            started.set()
            i = 0
            while not c.should_stop(i):
                i += 1
            iterations.append(i)

    thread = threading.Thread(target=loop)
    thread.start()
    started.wait(5.0)
    time.sleep(0.02)
    c.terminate()
    thread.join(5.0)
    assert not thread.is_alive() and iterations and c.interrupted


def test_terminating_one_condition_of_any_of_stops_the_whole():
    cancel = never()
    c = any_of(iteration_limit(10**9), cancel)
    c.start()
    assert not c.should_stop(1)
    cancel.terminate()
    assert c.should_stop(2) and c.interrupted
    both = all_of(never(), never())
    both.start()
    both.conditions[0].terminate()
    assert not both.should_stop(0) and not both.interrupted       # all of: one is not enough
    both.terminate()
    assert both.should_stop(0) and both.interrupted


def test_wait_returns_when_terminated():
    c = never()
    threading.Timer(0.05, c.terminate).start()
    t0 = time.perf_counter()
    assert c.wait(5.0) and time.perf_counter() - t0 < 2.0
    c.start()
    assert not c.interrupted and not c.wait(0.01)


def test_progress_values_are_published_and_readable_from_another_thread():
    c = any_of(iteration_limit(100))
    c.start()
    c.should_stop(7, 3.5, solved=True)
    c.publish(nodes=42)
    seen = {}
    thread = threading.Thread(target=lambda: seen.update(c.progress()))
    thread.start()
    thread.join()
    assert seen["iterations"] == 7 and seen["best_cost"] == 3.5 and seen["solved"] and seen["nodes"] == 42
    assert seen["elapsed"] >= 0
    assert c.conditions[0].progress()["nodes"] == 42           # the combined conditions see them too


def test_task_progress_collects_what_any_condition_publishes():
    with task_progress() as sink:
        t = Termination(max_iterations=5)
        t.start()
        for i in range(10):
            if t.should_stop(i, 1.0 / (i + 1)):
                break
        t.publish(nodes=12)
    assert sink == {"iterations": 5, "best_cost": pytest.approx(1 / 6), "solved": False, "nodes": 12}
    t.publish(nodes=13)                                          # outside the block: not collected
    assert sink["nodes"] == 12


def test_bad_budgets_name_the_field():
    with pytest.raises(ConfigError, match=r"termination\.max_time"):
        Termination(max_time=-1.0)
    with pytest.raises(ConfigError, match=r"termination\.cost_reached"):
        Termination(cost_reached=float("nan"))
    with pytest.raises(ConfigError, match=r"termination\.any_of\[1\]"):
        any_of(never(), 3.0)
    with pytest.raises(ConfigError, match=r"termination\.all_of"):
        all_of()


def test_ctrl_c_inside_watch_of_a_combination_terminates_it(python_sigint):
    c = any_of(iteration_limit(10), time_limit(60))
    with c.watch():
        signal.raise_signal(signal.SIGINT)
        assert c.interrupted and c.should_stop(0)
    with pytest.raises(KeyboardInterrupt):
        signal.raise_signal(signal.SIGINT)


def test_a_planner_takes_a_combined_condition():
    from pliant import registry
    from pliant.interfaces import PlanningProblem
    from pliant.spaces import RealVectorSpace

    planner = registry.create("planner", "rrtstar", max_step=0.1, goal_bias=0.1)
    space = RealVectorSpace(np.zeros(2), np.ones(2))
    problem = PlanningProblem(space=space, start=np.array([0.1, 0.1]), goal=np.array([0.9, 0.9]),
                              goal_tolerance=0.05)
    stop = any_of(iteration_limit(3000), first_solution())
    result = planner.plan(problem, np.random.default_rng(0), stop)
    assert result.status.value == "solved"
    assert stop.progress()["solved"] and stop.progress()["iterations"] < 3000 and not stop.interrupted
    assert stop.progress()["nodes"] > 1                       # the planner publishes its tree size


def test_a_cancelled_task_terminates_every_condition_it_polls():
    cancel = threading.Event()
    with task_progress(cancel):
        t = Termination(max_iterations=10**9)
        t.start()
        assert not t.should_stop(0)
        cancel.set()                                   # the executor cancels the task
        assert t.should_stop(1) and t.interrupted
    fresh = Termination(max_iterations=10**9)         # outside the task: not affected
    fresh.start()
    assert not fresh.should_stop(2)
