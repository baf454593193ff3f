"""The robot demos plan to a budget of work (iterations), wall time only a cap, and the user's --set wins (issue 31,
item 6); no ROS needed."""

from __future__ import annotations

import pliant
import pytest
from pliant_ros1.demo import BUDGETS, PIPELINES, budget_overrides


def _budget(name, overrides):
    """The planning request's budget of the demo's run ([planning], docs/determinism.md)."""
    return pliant.Pipeline.from_file(name, overrides=budget_overrides(name, overrides)).budget


@pytest.mark.parametrize("name", ["iiwa-policy", "pr2-policy"])
def test_the_iiwa_and_pr2_demos_plan_to_an_iteration_budget_with_time_as_a_cap(name):
    iterations, cap = BUDGETS[name]
    budget = _budget(name, [])
    assert budget.max_iterations == iterations
    assert budget.max_time == cap
    assert cap >= 600                    # a cap, not the budget: far above what the iterations take on a quiet machine


def test_the_users_settings_win():
    budget = _budget("pr2-policy", ["planning.max_time=120"])
    assert budget.max_time == 120 and budget.max_iterations == BUDGETS["pr2-policy"][0]
    assert _budget("iiwa-policy", ["planning.max_iterations=5"]).max_iterations == 5


def test_every_budget_names_a_demo_and_baxter_keeps_its_pipelines_budget():
    assert set(BUDGETS) <= set(PIPELINES)
    assert budget_overrides("baxter-policy", ["seed=1"]) == ["seed=1"]


@pytest.mark.parametrize("name", ["iiwa-policy", "pr2-policy"])
def test_on_the_peer_the_driver_gets_the_demo_watchdog_and_the_users_world_settings(name, tmp_path):
    from pliant_ros1.demo import DEMO_STATE_TIMEOUT, robot_overrides

    driver = PIPELINES[name][0]
    pipeline = pliant.Pipeline.from_file(name, overrides=robot_overrides(name, 3, [], "http://127.0.0.1:1", tmp_path))
    world = pipeline.world_spec()
    assert world.name == driver and world.options["state_timeout"] == DEMO_STATE_TIMEOUT
    assert world.options["master_uri"] == "http://127.0.0.1:1" and pipeline.seed == 3
    assert pipeline.budget.max_iterations == BUDGETS[name][0]
    user = ["execution.world.state_timeout=0.1", "planning.max_time=120"]
    pipeline = pliant.Pipeline.from_file(name, overrides=robot_overrides(name, 0, user, "http://127.0.0.1:1", tmp_path))
    assert pipeline.world_spec().options["state_timeout"] == 0.1           # the user's setting wins
    assert pipeline.budget.max_time == 120


def test_the_peer_starts_when_the_driver_connects_not_before():
    """Planning runs without the peer's load: building the execution world starts nothing, opening the driver starts
    the peer once, and a world that is not a driver is left alone."""
    from pliant.testing.memory_robot import MemoryDriver
    from pliant_ros1.demo import start_peer_on_connect

    class Peer:
        robot = "iiwa"
        starts = 0

        def alive(self):
            return self.starts > 0

        def start(self):
            self.starts += 1
            return self

    class Pipeline:
        def __init__(self, world):
            self.world = world

        def execution_world(self, context):
            return self.world

    peer = Peer()
    pipeline = Pipeline(MemoryDriver())
    start_peer_on_connect(pipeline, peer)
    driver = pipeline.execution_world(None)
    assert peer.starts == 0
    driver.open()
    driver.open()
    assert peer.starts == 1 and driver._open
    other = Pipeline(object())
    start_peer_on_connect(other, peer)
    assert isinstance(other.execution_world(None), object) and peer.starts == 1
