"""Failures say so, and nothing is lost (docs/outcomes.md): every run ends with a typed outcome and its exit status,
a run that fails while executing still writes its plan, the steps executed and a report naming the failure, Ctrl-C
leaves consistent files, and a run folder never holds files of two runs.

The failing worlds and planners are the bundled ones with one step (or ``plan``) replaced, registered from Python
as a third-party plugin would be, so the pipeline, the CLI and the report are the ones a user runs.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from pliant import Outcome, Pipeline, PlanResult, registry
from pliant.cli import main
from pliant.errors import SimulationError, StaleState
from pliant.pipeline import MANIFEST, RunInterrupted
from pliant_kinematic.simulator import KinematicSimulator
from pliant_straight.planner import WaypointPlanner

#: the maze-slide pipeline (se2-maze, scripted waypoints, the contact controller), short
MAZE = {"name": "maze", "scene": "se2-maze", "seed": 0,
        "planner": {"name": "waypoints", "waypoints": [[7.75, 5.0, 0.0], [7.75, 1.375, 0.0], [0.75, 1.375, 0.0]]},
        "simulator": "kinematic", "controller": {"name": "contact", "gain": 2.0, "tolerance": 0.05},
        "execution": {"period": 0.1, "time_limit": 30.0}}
STEPS_BEFORE_FAILURE = 4


def _failing_world(error):
    """The kinematic simulator, whose step number ``STEPS_BEFORE_FAILURE + 1`` raises ``error()``."""

    class Failing(KinematicSimulator):
        steps = 0

        def step(self, velocity, dt, rng):
            self.steps += 1
            if self.steps > STEPS_BEFORE_FAILURE:
                raise error()
            return super().step(velocity, dt, rng)

    return Failing


@pytest.fixture
def plugin():
    """Register test components by name for one test (``plugin(kind, name, cls)``), unregistered after it."""
    added = []

    def add(kind, name, cls):
        registry.register(kind, name, cls, "a test component")
        added.append((kind, name))
        return name

    yield add
    for kind, name in added:
        registry.default_registry().unregister(kind, name)


def _pipeline_file(tmp_path, simulator="kinematic", planner=None):
    table = {**MAZE, "simulator": simulator, "planner": planner or MAZE["planner"]}
    lines = [f'name = "{table["name"]}"', f'scene = "{table["scene"]}"', "seed = 0",
             f'simulator = "{simulator}"', "[planner]", f'name = "{table["planner"]["name"]}"',
             f'waypoints = {MAZE["planner"]["waypoints"]}', "[controller]", 'name = "contact"', "gain = 2.0",
             "tolerance = 0.05", "[execution]", "period = 0.1", "time_limit = 30.0"]
    path = tmp_path / "maze.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


def _run_json(folder):
    return json.loads((folder / "run.json").read_text())


@pytest.mark.slow
def test_push_slide_stuck_in_the_kinematic_simulator_exits_3(tmp_path, capsys):
    # the issue's `pliant run push-slide --set simulator=kinematic`: the paddle stops at the crate (held fixed)
    out = tmp_path / "push"
    code = main(["run", "push-slide", "--set", "simulator=kinematic", "--output", str(out)])
    assert code == 3
    captured = capsys.readouterr()
    assert "outcome             stuck" in captured.out
    assert captured.err.strip().splitlines()[-1].startswith("stuck: the execution in kinematic ended stuck")
    report = (out / "report.md").read_text()
    assert "**Outcome: stuck** (exit status 3)" in report and "| outcome | stuck |" in report
    plan = PlanResult.load(out / "result.json")
    np.testing.assert_allclose(plan.path.configurations, [[0.3, 0.5, 0.0], [1.0, 0.5, 0.0], [0.8, 0.5, 0.0]])
    execution = json.loads((out / "execution.json").read_text())
    assert execution["outcome"] == "stuck" and execution["details"]["waypoints_reached"] == 0
    assert _run_json(out)["outcome"] == "stuck"


def test_a_simulator_error_mid_execution_is_a_failed_run_with_everything_on_file(tmp_path, plugin):
    name = plugin("simulator", "test-failing-sim",
                  _failing_world(lambda: SimulationError("the body left the world", field="q", value=[9.0])))
    out = tmp_path / "run"
    record = Pipeline.from_dict({**MAZE, "simulator": name, "output": str(out)}).run()
    # the Python API: the record comes back, its outcome is the failure
    assert record.outcome is Outcome.FAILED and record.exit_status == 3 and record.stage == "done"
    assert "SimulationError" in record.error and "the body left the world" in record.error
    partial = record.execution
    assert partial.outcome == "failed" and len(partial.times) == STEPS_BEFORE_FAILURE + 1
    assert partial.times[-1] == pytest.approx(0.1 * STEPS_BEFORE_FAILURE)
    # on disk: the plan, the steps executed up to the failure, a report that names it, the outcome in run.json
    assert PlanResult.load(out / "result.json").path.configurations.tolist() == \
        record.result.path.configurations.tolist()
    executed = json.loads((out / "execution.json").read_text())
    assert executed["outcome"] == "failed" and len(executed["configurations"]) == STEPS_BEFORE_FAILURE + 1
    assert "the body left the world" in executed["error"]
    assert executed["events"][-1].startswith("t=0.40s: SimulationError")
    report = (out / "report.md").read_text()
    assert "**Outcome: failed** (exit status 3)" in report and "the body left the world" in report
    assert "up to the failure" in report
    assert _run_json(out)["outcome"] == "failed"
    listed = json.loads((out / MANIFEST).read_text())["files"]
    assert set(listed) == {"run.json", "result.json", "execution.json", "report.md", "path.png"}
    assert set(_files(out)) == {*listed, MANIFEST}


def test_the_cli_exits_3_when_the_execution_raises(tmp_path, plugin, capsys):
    plugin("simulator", "test-failing-sim", _failing_world(lambda: RuntimeError("pybullet lost its server")))
    out = tmp_path / "run"
    assert main(["run", str(_pipeline_file(tmp_path, "test-failing-sim")), "--output", str(out)]) == 3
    captured = capsys.readouterr()
    assert "failed: the execution in test-failing-sim failed: RuntimeError: pybullet lost its server" in captured.err
    assert "| outcome | failed |" in (out / "report.md").read_text()
    assert json.loads((out / "execution.json").read_text())["outcome"] == "failed"


@pytest.mark.usefixtures("frozen_heap")
def test_a_driver_watchdog_mid_execution_keeps_the_plan_and_the_steps(tmp_path):
    from pliant.hardware.limits import load_limits
    from pliant.testing.memory_robot import MemoryDriver, MemoryRobot

    names = [f"lbr_iiwa_joint_{i}" for i in range(1, 8)]
    limits = tmp_path / "iiwa.toml"
    limits.write_text('robot = "iiwa"\ncommand_rate = 100.0\nstate_timeout = 0.1\nposition_margin = 0.02\n'
                      'sources = ["test values"]\n' + "".join(
                          f'[[joints]]\nname = "{n}"\nlower = -2.9\nupper = 2.9\nvelocity = 1.5\n'
                          f'acceleration = 5.0\njerk = 50.0\n' for n in names))
    robot = MemoryRobot(load_limits(limits), np.array([0.0, 0.3, 0.0, -1.2, 0.0, 0.6, 0.0])).start()
    MemoryDriver.robots[131] = (robot, limits)
    registry.register("driver", "memory-131", MemoryDriver, "the core's emulated arm (tests)")
    try:
        def on_step(step):
            if step.time > 0.12:           # the robot stops publishing its joint states: the watchdog fires
                robot.publishing = False

        out = tmp_path / "out"
        pipeline = Pipeline(scene="iiwa-shelf", name="iiwa-watchdog", output=out,
                            planner={"name": "waypoints", "waypoints": [[0.4, 0.45, 0.0, -1.1, 0.0, 0.75, 0.0]]},
                            simulator={"name": "kinematic", "noise": "none", "joint_velocity_limits": [1.0] * 7},
                            controller={"name": "contact", "gain": 4.0, "tolerance": 0.05},
                            execution={"period": 0.05, "time_limit": 30.0,
                                       "world": {"name": "memory-131", "robot_id": 131}})
        record = pipeline.run(on_step=on_step)
    finally:
        registry.default_registry().unregister("driver", "memory-131")
        MemoryDriver.robots.pop(131, None)
        robot.stop()
    assert record.outcome is Outcome.FAILED and record.exit_status == 3
    assert StaleState.__name__ in record.execution.error
    assert len(record.execution.times) >= 3                 # the steps before the watchdog fired are kept
    assert robot.violations() == []
    assert PlanResult.load(out / "result.json").path is not None
    executed = json.loads((out / "execution.json").read_text())
    assert executed["outcome"] == "failed" and executed["world"] == "memory-131"
    assert len(executed["configurations"]) == len(record.execution.times)
    report = (out / "report.md").read_text()
    assert "**Outcome: failed**" in report and StaleState.__name__ in report


def test_not_planned_exits_1(tmp_path, capsys):
    out = tmp_path / "np"
    assert main(["run", "straight-demo", "--set", "planner=rrtstar", "--set", "planner.max_iterations=1",
                 "--output", str(out)]) == 1
    assert "not planned: the planner returned status 'timeout'" in capsys.readouterr().err
    assert _run_json(out)["outcome"] == "not planned"
    assert PlanResult.load(out / "result.json").status.value == "timeout"
    assert "**Outcome: not planned** (exit status 1)" in (out / "report.md").read_text()


def test_a_second_run_leaves_no_file_of_the_first(tmp_path):
    out = tmp_path / "shared"
    first = Pipeline.from_file("push-slide", overrides=["simulator=kinematic", "controller.eps_adjust_max=0.05",
                                                        f'output="{out}"']).run()
    assert first.outcome is Outcome.STUCK
    assert {"execution.json", "path.png"} <= set(_files(out))
    (out / "notes.txt").write_text("mine")                 # the user's own files in the folder stay
    (out / "data").mkdir()
    (out / "data" / "x.csv").write_text("1,2")
    second = Pipeline.from_file("straight-demo", overrides=["planner=rrtstar", "planner.max_iterations=1",
                                                           f'output="{out}"']).run()
    assert second.outcome is Outcome.NOT_PLANNED
    assert _files(out) == sorted([MANIFEST, "data", "notes.txt", "report.md", "result.json", "run.json"])
    assert (out / "data" / "x.csv").read_text() == "1,2"
    assert _run_json(out)["pipeline"]["name"] == "straight-demo"
    assert "push-slide" not in (out / "report.md").read_text()


def test_bad_input_exits_2_writes_nothing_and_keeps_the_earlier_run(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["run", "straight-demo", "--output", str(out)]) == 0
    before = {name: (out / name).read_bytes() for name in _files(out)}
    assert "path.png" in before
    capsys.readouterr()
    assert main(["run", "straight-demo", "--set", "planner.step=-2", "--output", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "planner.step" in err[0]
    assert {name: (out / name).read_bytes() for name in _files(out)} == before


def test_an_error_after_building_is_reported_in_the_cleared_folder(tmp_path, plugin, capsys):
    from pliant.errors import PlanningError

    class Refusing(WaypointPlanner):
        def plan(self, problem, rng, termination=None):
            raise PlanningError("cannot plan in this scene", field="scene", value="se2-maze")

    plugin("planner", "test-refusing", Refusing)
    out = tmp_path / "o"
    assert main(["run", "push-slide", "--set", "simulator=kinematic", "--set", "controller.eps_adjust_max=0.05",
                 "--output", str(out)]) == 3
    capsys.readouterr()
    assert main(["run", str(_pipeline_file(tmp_path, planner={"name": "test-refusing"})), "--output", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot plan in this scene" in err[0]
    assert _files(out) == sorted([MANIFEST, "report.md", "run.json"])       # nothing of the push-slide run
    assert _run_json(out)["outcome"] == "error" and _run_json(out)["stage"] == "plan"
    report = (out / "report.md").read_text()
    assert "**Outcome: error** (exit status 2)" in report and "cannot plan in this scene" in report
    assert "No plan was made" in report


def test_an_earlier_run_from_before_the_manifest_is_cleared_of_pliants_files_only(tmp_path):
    out = tmp_path / "old"
    out.mkdir()
    (out / "run.json").write_text(json.dumps({"pipeline": {"name": "old", "scene": "triple-wall", "seed": 0}}))
    (out / "report.md").write_text("# old\n\n![path](path.png)\n![front](front.png)\n")
    for name in ("path.png", "front.png", "result.json", "execution.json", "mine.png"):
        (out / name).write_text("old")
    Pipeline.from_file("straight-demo", overrides=["planner=rrtstar", "planner.max_iterations=1",
                                                   f'output="{out}"']).run()
    assert _files(out) == sorted([MANIFEST, "mine.png", "report.md", "result.json", "run.json"])


def test_ctrl_c_while_planning_exits_130_with_consistent_files(tmp_path, plugin, capsys):
    class Interrupted(WaypointPlanner):
        def plan(self, problem, rng, termination=None):
            raise KeyboardInterrupt

    plugin("planner", "test-ctrl-c", Interrupted)
    out = tmp_path / "o"
    assert main(["run", str(_pipeline_file(tmp_path, planner={"name": "test-ctrl-c"})), "--output", str(out)]) == 130
    assert "interrupted: Ctrl-C during plan (exit status 130)" in capsys.readouterr().err
    assert _files(out) == sorted([MANIFEST, "report.md", "run.json"])
    assert _run_json(out)["outcome"] == "interrupted" and _run_json(out)["stage"] == "plan"
    assert "**Outcome: interrupted** (exit status 130)" in (out / "report.md").read_text()


def test_an_anytime_planner_stopped_by_ctrl_c_keeps_its_plan_and_executes_nothing(tmp_path, plugin):
    class StoppedEarly(WaypointPlanner):
        def plan(self, problem, rng, termination=None):
            result = super().plan(problem, rng)
            result.statistics["interrupted"] = True        # what Termination.watch() reports after Ctrl-C
            return result

    name = plugin("planner", "test-stopped-early", StoppedEarly)
    out = tmp_path / "o"
    with pytest.raises(RunInterrupted) as stopped:
        Pipeline.from_dict({**MAZE, "planner": {"name": name, "waypoints": MAZE["planner"]["waypoints"]},
                            "output": str(out)}).run()
    record = stopped.value.record
    assert isinstance(stopped.value, KeyboardInterrupt)
    assert record.outcome is Outcome.INTERRUPTED and record.exit_status == 130 and record.execution is None
    assert PlanResult.load(out / "result.json").solved
    assert "execution.json" not in _files(out) and _run_json(out)["outcome"] == "interrupted"


def test_ctrl_c_while_executing_exits_130_with_the_steps_so_far(tmp_path, plugin, capsys):
    name = plugin("simulator", "test-ctrl-c-sim", _failing_world(KeyboardInterrupt))
    out = tmp_path / "o"
    assert main(["run", str(_pipeline_file(tmp_path, name)), "--output", str(out)]) == 130
    assert "outcome" in capsys.readouterr().out
    assert set(_files(out)) == {MANIFEST, "execution.json", "path.png", "report.md", "result.json", "run.json"}
    executed = json.loads((out / "execution.json").read_text())
    assert executed["outcome"] == "interrupted" and len(executed["times"]) == STEPS_BEFORE_FAILURE + 1
    assert _run_json(out)["outcome"] == "interrupted" and _run_json(out)["stage"] == "execute"
    assert PlanResult.load(out / "result.json").solved
    # the Python API: the same, as a KeyboardInterrupt carrying the record
    with pytest.raises(RunInterrupted) as stopped:
        Pipeline.from_dict({**MAZE, "simulator": name}).run(write=False)
    assert stopped.value.record.execution.outcome == "interrupted"


def test_a_world_that_fails_before_the_first_step_leaves_an_empty_record(tmp_path, plugin):
    class Unreachable(KinematicSimulator):
        def reset(self, q):
            raise SimulationError("the server does not answer", field="reset")

    name = plugin("simulator", "test-unreachable", Unreachable)
    out = tmp_path / "o"
    record = Pipeline.from_dict({**MAZE, "simulator": name, "output": str(out)}).run()
    assert record.outcome is Outcome.FAILED and "the server does not answer" in record.error
    assert record.execution.configurations.shape == (0, 3) and len(record.execution.times) == 0
    assert set(_files(out)) == {MANIFEST, "execution.json", "path.png", "report.md", "result.json", "run.json"}
    assert "the execution (0 control steps, up to the failure)" in (out / "report.md").read_text()


def _ignore_sigint():
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@pytest.mark.parametrize("stop", ["SIGINT", "SIGTERM to a background job"])
def test_a_real_ctrl_c_while_planning_exits_130_and_keeps_the_best_result(stop, tmp_path):
    """SIGINT to a `pliant run` process once its anytime planner shows progress: exit status 130, run.json and
    report.md say interrupted during plan, the planner's best result so far is in result.json, nothing executed.

    SIGTERM does the same -- also to a process started in the background by a script (``pliant run ... &``), which
    inherits SIGINT ignored, so SIGTERM is the only polite way to stop it."""
    import os
    import signal
    import subprocess
    import sys

    out = tmp_path / "o"
    background = stop != "SIGINT"
    process = subprocess.Popen([sys.executable, "-m", "pliant.cli", "run", "straight-demo", "--set", "planner=rrtstar",
                                "--set", "planner.max_time=600", "--set", "planner.progress=true",
                                "--output", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               preexec_fn=_ignore_sigint if background else None)
    try:
        seen = b""
        while b"rrtstar: iterations" not in seen:       # the progress line: the planner's loop is running
            chunk = os.read(process.stderr.fileno(), 4096)
            assert chunk, f"the run ended before planning: {seen.decode(errors='replace')}"
            seen += chunk
        process.send_signal(signal.SIGTERM if background else signal.SIGINT)
        _, err = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130
    assert ("SIGTERM during plan" in err.decode()) == background, err.decode()
    run = _run_json(out)
    assert run["outcome"] == "interrupted" and run["stage"] == "plan"
    assert "**Outcome: interrupted** (exit status 130)" in (out / "report.md").read_text()
    assert PlanResult.load(out / "result.json").statistics["interrupted"] is True
    assert _files(out) == sorted([MANIFEST, "report.md", "result.json", "run.json"] +
                                 (["path.png"] if PlanResult.load(out / "result.json").path is not None else []))
