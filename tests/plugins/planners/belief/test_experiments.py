"""The experiment command's bookkeeping: validation, the summary table's arithmetic, resuming from the file."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pliant import Pipeline
from pliant.errors import ConfigError
from pliant.interfaces import PlanningProblem
from pliant_belief.experiments import experiments, run_experiment, summarise


def _record(variant, seed, planned, worlds):
    return {"variant": variant, "seed": seed, "planned": planned, "plan_seconds": 1.0,
            "statistics": {"time_to_first": 2.0 + seed, "particles_simulated": 100, "particles_stored": 50,
                           "solutions": 3},
            "executions": {w: [{"outcome": o, "actions": 10, "seconds": 5.0} for o in outcomes]
                           for w, outcomes in worlds.items()}}


def test_the_summary_is_the_mean_over_planned_policies_of_their_success_rates():
    maze = experiments()["maze"][:1]
    records = [_record("belief, WCR 0.75", 0, True, {"unblocked": ["success"] * 4, "blocked": ["failure"] * 4}),
               _record("belief, WCR 0.75", 1, True, {"unblocked": ["success", "failure", "failure", "failure"],
                                                     "blocked": ["success"] * 4}),
               _record("belief, WCR 0.75", 2, False, {})]
    rows = {r["world"]: r for r in summarise(records, maze)}
    assert rows["unblocked"]["p_plan"] == pytest.approx(2 / 3)
    assert rows["unblocked"]["p_exec"] == pytest.approx((1.0 + 0.25) / 2)
    assert rows["unblocked"]["p_exec_std"] == pytest.approx(np.std([1.0, 0.25]))
    assert rows["blocked"]["p_exec"] == pytest.approx(0.5)
    assert rows["unblocked"]["time_to_first"] == pytest.approx(2.5)        # over planned policies only


def test_a_second_run_resumes_from_the_tasks_on_file(tmp_path):
    (tmp_path / "maze").mkdir()
    label = experiments()["maze"][0].label
    done = [_record(label, s, True, {"unblocked": ["success"], "blocked": ["failure"]}) for s in range(2)]
    (tmp_path / "maze" / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in done))
    lines = []
    rows = run_experiment("maze", plans=2, executions=1, plan_time=1.0, exec_time=1.0, jobs=1, fresh=False,
                          output=tmp_path, only=[label], echo=lines.append)
    assert lines[0] == "maze: 2 tasks on file, 0 to go, 1 at a time"          # nothing planned again
    assert {r["world"]: r["p_exec"] for r in rows} == {"unblocked": 1.0, "blocked": 0.0}
    summary = json.loads((tmp_path / "maze" / "summary.json").read_text())
    assert summary["experiment"] == "maze" and len(summary["rows"]) == 2


@pytest.mark.parametrize("name, options, field", [
    ("nope", {}, "NAME"), ("maze", {"plans": 0}, "plans"), ("maze", {"jobs": True}, "jobs"),
    ("maze", {"plan_time": -1.0}, "plan_time")])
def test_bad_input_names_the_field(tmp_path, name, options, field):
    kwargs = {"plans": 1, "executions": 1, "plan_time": 1.0, "exec_time": 1.0, "jobs": 1, **options}
    with pytest.raises(ConfigError, match=field):
        run_experiment(name, fresh=False, output=tmp_path, echo=lambda *_: None, **kwargs)


def _fake_task(variant, seed, plan_time, executions, exec_time, policy_file=None):
    return _record(variant.label, seed, True, {w: ["success"] * executions for w in variant.worlds})


def test_fresh_forgets_only_the_variants_being_run(tmp_path, monkeypatch):
    import pliant_belief.experiments as module

    monkeypatch.setattr(module, "run_task", _fake_task)          # no planning here: the bookkeeping only
    (tmp_path / "maze").mkdir()
    first, second = (v.label for v in experiments()["maze"][:2])
    kept = _record(second, 0, True, {"unblocked": ["success"], "blocked": ["success"]})
    forgotten = _record(first, 0, False, {})
    (tmp_path / "maze" / "runs.jsonl").write_text(json.dumps(kept) + "\n" + json.dumps(forgotten) + "\n")
    lines = []
    run_experiment("maze", plans=1, executions=1, plan_time=1.0, exec_time=1.0, jobs=1, fresh=True,
                   output=tmp_path, only=[second], echo=lines.append)
    assert lines[0].startswith("maze: 1 tasks on file, 1 to go")       # the selected variant starts over
    left = [json.loads(x) for x in (tmp_path / "maze" / "runs.jsonl").read_text().splitlines()]
    assert [r["variant"] for r in left] == [first, second]             # the other variant's task is kept
    assert left[1]["executions"] == {"unblocked": [{"outcome": "success", "actions": 10, "seconds": 5.0}],
                                     "blocked": [{"outcome": "success", "actions": 10, "seconds": 5.0}]}


def test_baxter_reach_compares_the_belief_planner_with_contact_rrt_and_its_pipeline_builds():
    import pliant

    variants = {v.label: v for v in experiments()["baxter-reach"]}
    assert list(variants) == ["belief", "contact RRT"]
    assert {v.pipeline for v in variants.values()} == {"baxter-policy"}
    assert variants["belief"].overrides == ()
    contact = variants["contact RRT"].overrides
    assert 'planner.mode="contact"' in contact and 'simulator.noise="none"' in contact
    assert not any(o.startswith("execution.") for o in contact)       # executed with the pipeline's noise
    pipeline = pliant.Pipeline.from_file("baxter-policy", overrides=list(contact))
    context = pipeline.build()
    assert context.extras["planner"].options.mode == "contact"
    assert context.simulator.noise.model == "none"
    simulator = pipeline.execution_world(context)
    assert type(simulator).__name__ == "PybulletSimulator"
    assert simulator.noise.model == "proportional" and simulator.per_actuator
    np.testing.assert_allclose(simulator.limits, [0.5, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0])


def test_replay_executes_the_saved_policies_again_without_planning(tmp_path):
    # a policy planned here with an iteration budget (a time-limited plan could find nothing on a loaded machine)
    variant = experiments()["maze"][0]
    pipeline = Pipeline.from_file(variant.pipeline, overrides=[
        *variant.overrides, "planner.max_time=null", "planner.max_iterations=400", "planner.stop_on_first=true",
        "planner.progress=false", "seed=0"])
    context = pipeline.build()
    result = context.extras["planner"].plan(PlanningProblem.from_context(context), np.random.default_rng(0))
    assert result.policy is not None
    policy_file = tmp_path / "maze" / "policies" / "policy.json"
    result.policy.save(policy_file)
    planned = {"variant": variant.label, "seed": 0, "planned": True, "plan_seconds": 1.0,
               "statistics": {"solutions": 1}, "executions": {}, "policy_file": str(policy_file)}
    log = tmp_path / "maze" / "runs.jsonl"
    log.write_text(json.dumps(planned) + "\n")
    lines = []
    run_experiment("maze", plans=1, executions=2, plan_time=5.0, exec_time=2.0, jobs=1, fresh=False,
                   output=tmp_path, only=[variant.label], echo=lines.append, replay=True)
    (replayed,) = [json.loads(x) for x in log.read_text().splitlines()]
    assert lines[0] == "replaying 1 saved policies, 1 at a time"
    assert replayed["replayed"] and replayed["statistics"] == planned["statistics"]      # nothing planned again
    assert {w: len(runs) for w, runs in replayed["executions"].items()} == {"unblocked": 2, "blocked": 2}
    assert all(run["seconds"] <= 2.0 + 1e-9 for runs in replayed["executions"].values() for run in runs)
    with pytest.raises(ConfigError, match="replay"):
        run_experiment("maze", plans=1, executions=1, plan_time=1.0, exec_time=1.0, jobs=1, fresh=True,
                       output=tmp_path, echo=lambda *_: None, replay=True)
