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
    records = [_record("belief, WCR 0.75", 0, True, {"unblocked": ["success"] * 4, "blocked (right)": ["failure"] * 4}),
               _record("belief, WCR 0.75", 1, True, {"unblocked": ["success", "failure", "failure", "failure"],
                                                     "blocked (right)": ["success"] * 4}),
               _record("belief, WCR 0.75", 2, False, {})]
    rows = {r["world"]: r for r in summarise(records, maze)}
    assert rows["unblocked"]["p_plan"] == pytest.approx(2 / 3)
    assert rows["unblocked"]["p_exec"] == pytest.approx((1.0 + 0.25) / 2)
    assert rows["unblocked"]["p_exec_std"] == pytest.approx(np.std([1.0, 0.25]))
    assert rows["blocked (right)"]["p_exec"] == pytest.approx(0.5)
    assert rows["unblocked"]["time_to_first"] == pytest.approx(2.5)        # over planned policies only


def test_a_second_run_resumes_from_the_tasks_on_file(tmp_path):
    (tmp_path / "maze").mkdir()
    label = experiments()["maze"][0].label
    done = [_record(label, s, True, {"unblocked": ["success"], "blocked (right)": ["failure"]}) for s in range(2)]
    (tmp_path / "maze" / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in done))
    lines = []
    rows = run_experiment("maze", plans=2, executions=1, plan_time=1.0, exec_time=1.0, jobs=1, fresh=False,
                          output=tmp_path, only=[label], echo=lines.append)
    assert lines[0] == "maze: 2 tasks on file, 0 to go, 1 at a time"          # nothing planned again
    p_exec = {r["world"]: r["p_exec"] for r in rows}
    assert p_exec["unblocked"] == 1.0 and p_exec["blocked (right)"] == 0.0
    assert np.isnan(p_exec["blocked (first route)"])                        # no executions of that world on file
    summary = json.loads((tmp_path / "maze" / "summary.json").read_text())
    assert summary["experiment"] == "maze" and len(summary["rows"]) == 3


@pytest.mark.parametrize("name, options, field", [
    ("nope", {}, "NAME"), ("maze", {"plans": 0}, "--plans"), ("maze", {"jobs": True}, "--jobs"),
    ("maze", {"plan_time": -1.0}, "--plan-time"), ("maze", {"plan_iterations": 0}, "--plan-iterations"),
    ("maze", {"plan_iterations": 2.5}, "--plan-iterations"), ("maze", {"exec_time": 0}, "--exec-time")])
def test_bad_input_names_the_field(tmp_path, name, options, field):
    kwargs = {"plans": 1, "executions": 1, "plan_time": 1.0, "exec_time": 1.0, "jobs": 1, **options}
    with pytest.raises(ConfigError, match=field):
        run_experiment(name, fresh=False, output=tmp_path, echo=lambda *_: None, **kwargs)


def _fake_task(variant, seed, plan_time, executions, exec_time, policy_file=None, plan_iterations=None):
    return _record(variant.label, seed, True, {w: ["success"] * executions for w in variant.worlds})


def test_fresh_forgets_only_the_variants_being_run(tmp_path, monkeypatch):
    import pliant_belief.experiments as module

    monkeypatch.setattr(module, "run_task", _fake_task)          # no planning here: the bookkeeping only
    (tmp_path / "maze").mkdir()
    first, second = (v.label for v in experiments()["maze"][:2])
    kept = _record(second, 0, True, {"unblocked": ["success"], "blocked (right)": ["success"]})
    forgotten = _record(first, 0, False, {})
    (tmp_path / "maze" / "runs.jsonl").write_text(json.dumps(kept) + "\n" + json.dumps(forgotten) + "\n")
    lines = []
    run_experiment("maze", plans=1, executions=1, plan_time=1.0, exec_time=1.0, jobs=1, fresh=True,
                   output=tmp_path, only=[second], echo=lines.append)
    assert lines[0].startswith("maze: 1 tasks on file, 1 to go")       # the selected variant starts over
    left = [json.loads(x) for x in (tmp_path / "maze" / "runs.jsonl").read_text().splitlines()]
    assert [r["variant"] for r in left] == [first, second]             # the other variant's task is kept
    run = [{"outcome": "success", "actions": 10, "seconds": 5.0}]
    assert left[1]["executions"] == {"unblocked": run, "blocked (first route)": run, "blocked (right)": run}


def _budget_task(variant, seed, plan_time, executions, exec_time, policy_file=None, plan_iterations=None):
    return {**_fake_task(variant, seed, plan_time, executions, exec_time), "statistics": {
        "plan_iterations": plan_iterations}}


def test_an_iteration_budget_reaches_the_planner_and_a_resume_with_another_is_refused(tmp_path, monkeypatch):
    import pliant_belief.experiments as module

    monkeypatch.setattr(module, "run_task", _budget_task)
    label = experiments()["maze"][0].label
    run_experiment("maze", plans=1, executions=1, plan_time=600.0, exec_time=1.0, jobs=1, fresh=False,
                   output=tmp_path, only=[label], echo=lambda *_: None, plan_iterations=60)
    records = [json.loads(x) for x in (tmp_path / "maze" / "runs.jsonl").read_text().splitlines()]
    assert [r["statistics"]["plan_iterations"] for r in records] == [60]
    assert json.loads((tmp_path / "maze" / "settings.json").read_text())["plan_iterations"] == 60
    with pytest.raises(ConfigError, match="--plan-iterations"):
        run_experiment("maze", plans=2, executions=1, plan_time=600.0, exec_time=1.0, jobs=1, fresh=False,
                       output=tmp_path, only=[label], echo=lambda *_: None, plan_iterations=80)


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
    runs = {w: len(runs) for w, runs in replayed["executions"].items()}
    assert runs == {"unblocked": 2, "blocked (first route)": 2, "blocked (right)": 2}
    assert all(run["seconds"] <= 2.0 + 1e-9 for runs in replayed["executions"].values() for run in runs)
    with pytest.raises(ConfigError, match="replay"):
        run_experiment("maze", plans=1, executions=1, plan_time=1.0, exec_time=1.0, jobs=1, fresh=True,
                       output=tmp_path, echo=lambda *_: None, replay=True)


# --- interruption, crashes and resuming (real processes) -------------------------------------------------------

_RUNNER = '''
import os, signal, sys, time
from pathlib import Path
import pliant_belief.experiments as module

# as in a terminal: a process started in the background (CI, a job shell) inherits SIGINT ignored
signal.signal(signal.SIGINT, signal.default_int_handler)

pids = Path(sys.argv[2])

def task(variant, seed, plan_time, executions, exec_time, policy_file=None, plan_iterations=None):
    (pids / str(os.getpid())).write_text("")
    time.sleep(float(sys.argv[3]) if seed else 0.2)
    return {"variant": variant.label, "seed": seed, "planned": True, "plan_seconds": 0.1, "statistics": {},
            "executions": {w: [{"outcome": "success", "actions": 1, "seconds": 1.0}] for w in variant.worlds}}

module.run_task = task
try:
    module.run_experiment("maze", plans=3, executions=1, plan_time=1.0, exec_time=1.0, jobs=2, fresh=False,
                          output=Path(sys.argv[1]), echo=lambda line: print(line, flush=True))
except KeyboardInterrupt:
    sys.exit(130)
'''


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split()[2] != "Z"
    except OSError:
        return False


def _start_runner(tmp_path, task_seconds: float):
    import subprocess
    import sys

    script = tmp_path / "runner.py"
    script.write_text(_RUNNER)
    pids = tmp_path / "pids"
    pids.mkdir(exist_ok=True)
    process = subprocess.Popen([sys.executable, str(script), str(tmp_path / "out"), str(pids), str(task_seconds)],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return process, pids


def _wait(condition, timeout: float) -> bool:
    import time

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return condition()


def test_ctrl_c_stops_within_seconds_keeps_every_finished_task_and_a_resume_does_the_rest(tmp_path):
    import signal
    import time

    from pliant.files import read_jsonl

    process, pids = _start_runner(tmp_path, task_seconds=60.0)
    log = tmp_path / "out" / "maze" / "runs.jsonl"
    assert _wait(lambda: len(read_jsonl(log)[0]) >= 1 and len(list(pids.iterdir())) >= 2, 60.0)
    workers = [int(p.name) for p in pids.iterdir()]
    t0 = time.monotonic()
    process.send_signal(signal.SIGINT)
    output = process.communicate(timeout=20)[0]
    assert process.returncode == 130, output
    assert time.monotonic() - t0 < 10.0                          # not after the queued 60 s tasks
    assert "interrupted" in output and "resume" in output
    assert _wait(lambda: not any(_alive(pid) for pid in workers), 10.0)
    finished, torn = read_jsonl(log)
    assert not torn and len(finished) >= 1 and all(r["seed"] == 0 for r in finished)
    summary = json.loads((tmp_path / "out" / "maze" / "summary.json").read_text())
    assert summary["tasks"] == len(finished)
    process, _ = _start_runner(tmp_path, task_seconds=0.1)       # resume: only the missing tasks run
    output = process.communicate(timeout=120)[0]
    assert process.returncode == 0, output
    records, _ = read_jsonl(log)
    keys = [(r["variant"], r["seed"]) for r in records]
    assert len(keys) == len(set(keys)) == 2 * 3                  # every task exactly once


def test_pool_workers_die_with_a_killed_parent(tmp_path):
    import signal

    process, pids = _start_runner(tmp_path, task_seconds=60.0)
    assert _wait(lambda: len(list(pids.iterdir())) >= 2, 60.0)
    workers = [int(p.name) for p in pids.iterdir()]
    process.send_signal(signal.SIGKILL)
    process.wait(10)
    assert _wait(lambda: not any(_alive(pid) for pid in workers), 10.0), "workers outlived their parent"


def test_a_torn_last_line_is_dropped_and_a_corrupt_middle_line_is_an_error(tmp_path, monkeypatch):
    import pliant_belief.experiments as module

    monkeypatch.setattr(module, "run_task", _fake_task)
    label = experiments()["maze"][0].label
    directory = tmp_path / "maze"
    directory.mkdir()
    good = json.dumps(_record(label, 0, True, {"unblocked": ["success"], "blocked (right)": ["success"]}))
    (directory / "runs.jsonl").write_text(good + "\n" + good[: len(good) // 2])      # a crash mid-write
    lines = []
    run_experiment("maze", plans=2, executions=1, plan_time=1.0, exec_time=1.0, jobs=1, fresh=False,
                   output=tmp_path, only=[label], echo=lines.append)
    assert "cut off" in lines[0] and lines[1].startswith("maze: 1 tasks on file, 1 to go")
    assert [json.loads(x)["seed"] for x in (directory / "runs.jsonl").read_text().splitlines()] == [0, 1]
    (directory / "runs.jsonl").write_text(good + "\n{not json\n" + good + "\n")
    with pytest.raises(ConfigError, match=r"runs.jsonl:line 2: line 2 is not JSON"):
        run_experiment("maze", plans=2, executions=1, plan_time=1.0, exec_time=1.0, jobs=1, fresh=False,
                       output=tmp_path, only=[label], echo=lambda *_: None)


def test_a_resume_with_other_settings_is_refused_and_fresh_starts_over(tmp_path, monkeypatch):
    import pliant_belief.experiments as module

    monkeypatch.setattr(module, "run_task", _fake_task)
    label = experiments()["maze"][0].label
    kwargs = {"plans": 1, "jobs": 1, "output": tmp_path, "only": [label], "echo": lambda *_: None}
    run_experiment("maze", executions=1, plan_time=1.0, exec_time=1.0, fresh=False, **kwargs)
    with pytest.raises(ConfigError, match=r"--plan-time: this run was started with --plan-time 1.0; resuming "
                                          r"with 2.0"):
        run_experiment("maze", executions=1, plan_time=2.0, exec_time=1.0, fresh=False, **kwargs)
    run_experiment("maze", executions=1, plan_time=2.0, exec_time=1.0, fresh=True, **kwargs)
    summary = json.loads((tmp_path / "maze" / "summary.json").read_text())
    assert summary["settings"]["plan_time"] == 2.0                 # the settings the records were made with


def test_the_first_route_block_is_the_passage_the_policys_first_route_takes():
    from types import SimpleNamespace

    from pliant import load_scene
    from pliant_belief.experiments import first_route_passage

    scene = load_scene("se2-maze")

    def policy(*points):
        nodes = [SimpleNamespace(expected=np.array([x, y, 0.0])) for x, y in points]
        return SimpleNamespace(nodes=nodes, start_node=0, route=lambda start: list(range(len(nodes))))

    # start top right, down the middle passage, along the bottom corridor to the goal bottom left
    assert first_route_passage(policy((7.75, 7.75), (5.0, 8.0), (5.0, 2.0), (0.75, 0.75)), scene) == "middle"
    assert first_route_passage(policy((7.75, 7.75), (8.2, 5.0), (8.2, 2.0), (0.75, 0.75)), scene) == "right"
    assert first_route_passage(policy((7.75, 7.75), (1.7, 8.0), (1.7, 1.5), (0.75, 0.75)), scene) == "left"
    for passage in ("left", "middle", "right"):                # each has a variant that blocks it
        blocked = load_scene("se2-maze", variant=f"blocked-{passage}")
        assert [o.name for o in blocked.objects][-1] == "block"
