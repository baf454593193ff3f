"""Deterministic by default (issue 32 items 3 and 4): random streams per stage (pliant.seeds) and the planning
request's budget (``[planning]``, ``PlanningProblem.budget``) replacing the planners' budget options."""

from __future__ import annotations

import tomllib
import warnings

import numpy as np
import pytest
from pliant.components import PlanningProblem
from pliant.errors import ConfigError, PipelineError
from pliant.pipeline import Pipeline, bundled_pipelines_dir
from pliant.seeds import STAGES, Streams, derived_seed, sequence, spawn_key, stream, stream_from_layout
from pliant.termination import Budget, BudgetDeprecationWarning

# --- streams --------------------------------------------------------------------------------------------------------


def test_each_stage_has_its_own_stream_and_asking_again_gives_the_same_numbers():
    streams = Streams(7)
    draws = {stage: streams.rng(stage).random(4) for stage in ("learning", "planning", "metrics", "execution")}
    assert len({tuple(d) for d in draws.values()}) == 4                 # four different streams
    for stage, first in draws.items():
        np.testing.assert_array_equal(Streams(7).rng(stage).random(4), first)     # the order of asking is irrelevant
    assert not np.array_equal(Streams(8).rng("planning").random(4), draws["planning"])


def test_a_stage_stream_is_the_spawned_child_of_the_runs_seed_sequence():
    children = np.random.SeedSequence(3).spawn(len(STAGES))
    for stage, key in STAGES.items():
        np.testing.assert_array_equal(stream(3, stage).integers(0, 2**31, 8),
                                      np.random.default_rng(children[key]).integers(0, 2**31, 8))


def test_streams_are_statistically_independent():
    # correlation of 100 000 uniform draws of two stages of one seed and of two adjacent seeds' planning streams
    a, b = stream(0, "planning").random(100_000), stream(0, "metrics").random(100_000)
    c = stream(1, "planning").random(100_000)
    assert abs(np.corrcoef(a, b)[0, 1]) < 0.02
    assert abs(np.corrcoef(a, c)[0, 1]) < 0.02


def test_task_streams_are_keyed_by_task_not_by_hand_picked_offsets():
    assert spawn_key("task", 7, 2) == (4, 7, 2)
    assert spawn_key("task", "clearance", 3)[1] == spawn_key("task", "clearance", 0)[1]      # a stable string key
    seeds = {derived_seed(5, "task", task, plan) for task in range(20) for plan in range(20)}
    assert len(seeds) == 400
    assert derived_seed(5, "task", 1, 2) == int(sequence(5, "task", 1, 2).generate_state(1)[0])
    with pytest.raises(ConfigError, match="streams:"):
        stream(0, "nonsense")
    with pytest.raises(ConfigError):
        Streams(-1)


def test_the_layout_rebuilds_every_stream_it_records():
    streams = Streams(11)
    first = streams.rng("task", 3, 1).random(3)
    streams.rng("planning")
    layout = streams.layout()
    assert layout == {"task.3.1": [11, 4, 3, 1], "planning": [11, 1]}
    np.testing.assert_array_equal(stream_from_layout(layout["task.3.1"]).random(3), first)
    assert streams.stages() == {"learning": [11, 0], "planning": [11, 1], "metrics": [11, 2], "execution": [11, 3]}


# --- the request's budget ---------------------------------------------------------------------------------------------


def test_a_planning_table_is_checked_and_overridable():
    assert Budget.from_table({"max_iterations": 40, "max_time": 600}) == Budget(max_time=600, max_iterations=40)
    with pytest.raises(ConfigError, match=r"planning\.max_iters"):
        Budget.from_table({"max_iters": 40})
    with pytest.raises(ConfigError, match=r"planning\.max_iterations"):
        Budget.from_table({"max_iterations": 0})
    with pytest.raises(PipelineError, match=r"planning\.max_time"):
        Pipeline("se2-maze", planner="straight", planning={"max_time": -1})
    pipe = Pipeline.from_dict({"scene": "se2-maze", "planner": "rrtstar", "planning": {"max_time": 60}},
                              overrides=["planning.max_iterations=12"])
    assert pipe.budget == Budget(max_time=60, max_iterations=12)
    assert pipe.to_dict()["planning"] == {"max_time": 60, "max_iterations": 12}


@pytest.mark.parametrize("planner", ["rrtstar", "trrt"])
def test_a_planner_given_planning_max_iterations_stops_there(planner):
    pipe = Pipeline("triple-wall", cost="voxel", planner={"name": planner, "stop_on_first": False},
                    planning={"max_iterations": 30, "max_time": 600.0})
    with warnings.catch_warnings():
        warnings.simplefilter("error", BudgetDeprecationWarning)        # the new spelling warns about nothing
        record = pipe.run(write=False)
    stats = record.result.statistics
    assert stats["iterations"] == 30
    assert stats["budget"]["binding"] == "iterations"
    assert stats["budget"]["max_iterations"] == 30 and stats["budget"]["source"] == "request"


def test_the_deprecated_planner_option_still_works_with_a_warning_naming_the_new_spelling():
    with pytest.warns(BudgetDeprecationWarning, match=r"planning\.max_iterations"):
        record = Pipeline("triple-wall", cost="voxel", seed=3,
                          planner={"name": "rrtstar", "max_iterations": 20}).run(write=False)
    assert record.result.statistics["iterations"] == 20
    new = Pipeline("triple-wall", cost="voxel", seed=3, planner="rrtstar",
                   planning={"max_iterations": 20}).run(write=False)
    assert new.result.status is record.result.status                 # the same search under both spellings
    assert new.result.statistics["nodes"] == record.result.statistics["nodes"]


def test_a_problem_built_by_hand_carries_the_budget_too():
    pipe = Pipeline("triple-wall", cost="voxel", planner="rrtstar")
    ctx = pipe.build()
    problem = PlanningProblem.from_context(ctx, budget={"max_iterations": 9})
    result = ctx.extras["planner"].plan(problem, np.random.default_rng(0))
    assert result.statistics["iterations"] == 9


def test_a_time_budget_that_binds_says_so_in_the_result_and_the_report():
    record = Pipeline("triple-wall", cost="voxel", planner="rrtstar",
                      planning={"max_time": 0.0}).run(write=False)
    assert record.result.statistics["budget"]["binding"] == "time"
    assert "depends on the machine" in dict(record.summary_rows())["budget binding"]


# --- adding a stage changes no other stage's numbers ------------------------------------------------------------------


def test_a_pipeline_with_and_without_a_metric_plans_the_same_path_and_records_its_streams(tmp_path):
    data = tomllib.loads((bundled_pipelines_dir() / "passage-select.toml").read_text())
    for key in ("controller", "execution"):
        data.pop(key, None)
    data["planner"].pop("max_time", None)                              # the file's older spelling, if still there
    data["planning"] = {"max_iterations": 400, "max_time": 600.0}
    data["metric"]["particles"] = 20
    with_metric = Pipeline.from_dict(data)
    record = with_metric.run(write=False)
    assert record.result.solved and record.metrics                     # the metric ran (and drew from its stream)
    data.pop("metric")
    data.pop("simulator")                # the metric's: without it nothing would use it (a build error), and RRT*
    bare = Pipeline.from_dict(data).run(write=False)                 # plans without one
    np.testing.assert_array_equal(bare.result.path.configurations, record.result.path.configurations)
    assert bare.result.statistics["iterations"] == record.result.statistics["iterations"]
    record.result.save(tmp_path / "result.json")
    import json

    saved = json.loads((tmp_path / "result.json").read_text())
    assert saved["seed"] == 0
    assert saved["streams"] == {"learning": [0, 0], "planning": [0, 1], "metrics": [0, 2], "execution": [0, 3]}
