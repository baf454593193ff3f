"""Pipelines from dicts, files and Python; overrides; reports."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pliant import Pipeline, PlanResult, Status, registry
from pliant.errors import PipelineError
from pliant.pipeline import apply_overrides, parse_override


def test_parse_override_values():
    assert parse_override("planner.max_time=5") == ("planner.max_time", 5)
    assert parse_override("planner.p=0.25") == ("planner.p", 0.25)
    assert parse_override("simulator=pybullet") == ("simulator", "pybullet")
    assert parse_override("planner.flag=true") == ("planner.flag", True)
    assert parse_override("planner.w=[1, 2]") == ("planner.w", [1, 2])
    with pytest.raises(PipelineError, match="key=value"):
        parse_override("planner.max_time")


def test_overrides_replace_and_set():
    data = {"scene": "triple-wall", "planner": {"name": "astar", "p": 0.5}}
    out = apply_overrides(data, ["planner.p=0.7", "scene.variant=soft-robot-soft-walls", "seed=4"], "t")
    assert out["planner"] == {"name": "astar", "p": 0.7}
    assert out["scene"] == {"name": "triple-wall", "variant": "soft-robot-soft-walls"}
    assert out["seed"] == 4
    assert apply_overrides(data, ["planner=straight"], "t")["planner"] == "straight"
    assert data["planner"]["p"] == 0.5   # the input is not modified


def test_run_writes_the_report(tmp_path):
    pipeline = Pipeline.from_dict({"name": "t", "scene": "triple-wall", "planner": {"name": "straight", "step": 0.01},
                                   "cost": "voxel", "output": str(tmp_path)})
    record = pipeline.run()
    # the straight line from start to goal crosses the soft walls: feasible but costly
    assert record.result.status is Status.SOLVED and record.result.cost > 0
    for name in ("result.json", "run.json", "report.md", "path.png"):
        assert (tmp_path / name).is_file()
    loaded = PlanResult.load(tmp_path / "result.json")
    assert np.allclose(loaded.path.configurations, record.result.path.configurations)
    assert json.loads((tmp_path / "run.json").read_text())["pipeline"]["planner"]["step"] == 0.01
    report = (tmp_path / "report.md").read_text()
    assert "| status | solved |" in report and "![path](path.png)" in report


def test_from_file_with_overrides(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('name = "f"\nscene = "triple-wall"\n[planner]\nname = "straight"\nstep = 0.5\n')
    pipeline = Pipeline.from_file(path, overrides=["planner.step=0.02", "seed=9"])
    assert pipeline.components["planner"].options == {"step": 0.02} and pipeline.seed == 9
    assert pipeline.name == "f"


def test_scene_relative_to_the_pipeline_file(tmp_path):
    from pliant.scene import resolve_scene_path

    (tmp_path / "my-scene.toml").write_text(resolve_scene_path("triple-wall").read_text())
    (tmp_path / "p.toml").write_text('scene = "my-scene.toml"\nplanner = "straight"\n')
    ctx = Pipeline.from_file(tmp_path / "p.toml").build()
    assert ctx.scene.source == str(tmp_path / "my-scene.toml")


def test_python_pipeline_with_instances():
    planner = registry.create("planner", "straight", step=0.05)
    record = Pipeline("triple-wall", planner=planner).run(write=False)
    assert record.result.solved and record.result.options["step"] == 0.05


def test_a_scene_file_runs_its_own_pipeline():
    from pliant.scene import resolve_scene_path

    pipeline = Pipeline.from_file(resolve_scene_path("triple-wall"), overrides=["planner.p=0.7"])
    assert pipeline.components["planner"].name == "astar" and pipeline.components["planner"].options["p"] == 0.7
    record = pipeline.run(write=False)
    assert record.result.solved and record.result.statistics["deformation"] == 0.0
    with pytest.raises(PipelineError, match=r"se2-maze.toml:pipeline: this is a scene file without"):
        Pipeline.from_file(resolve_scene_path("se2-maze"))


def test_bundled_pipelines_build():
    from pliant.pipeline import available_pipelines

    for name in available_pipelines():
        assert Pipeline.from_file(name).build().scene is not None


def test_every_outcome_has_its_documented_exit_status():
    from pliant import Outcome

    assert {o.value: o.exit_status for o in Outcome} == {
        "planned": 0, "reached": 0, "not planned": 1, "stuck": 3, "failed": 3, "error": 2, "interrupted": 130}
    assert [o.value for o in Outcome if o.success] == ["planned", "reached"]
    assert Outcome.STUCK == "stuck"                      # a str enum: compares and serialises by value


def test_a_run_without_execution_is_planned_and_writes_its_manifest(tmp_path):
    from pliant import Outcome
    from pliant.pipeline import MANIFEST

    record = Pipeline("triple-wall", planner={"name": "straight", "step": 0.01}, cost="voxel",
                      output=tmp_path).run()
    assert record.outcome is Outcome.PLANNED and record.exit_status == 0 and record.error == ""
    listed = json.loads((tmp_path / MANIFEST).read_text())["files"]
    assert listed == ["path.png", "report.md", "result.json", "run.json"]
    assert json.loads((tmp_path / "run.json").read_text())["outcome"] == "planned"
    assert "**Outcome: planned** (exit status 0)" in (tmp_path / "report.md").read_text()


def test_a_simulator_nothing_would_use_is_refused_naming_it():
    """`--set simulator=kinematic` on a pipeline that only plans: no controller executes in it and the planner does
    not simulate, so the setting would change nothing -- an error naming it, not a silent no-op.  With a controller
    the same simulator is the execution world."""
    plan_only = {"name": "t", "scene": "se2-maze", "planner": {"name": "straight", "step": 0.01}, "cost": "voxel",
                 "simulator": "kinematic"}
    with pytest.raises(PipelineError, match="nothing would use the simulator 'kinematic'") as caught:
        Pipeline.from_dict(plan_only).build()
    assert caught.value.field == "simulator" and "'straight' does not simulate" in str(caught.value)
    context = Pipeline.from_dict({**plan_only, "controller": "contact"}).build()
    assert context.simulator is not None and context.controller is not None


def test_clearing_a_folder_removes_only_files_the_earlier_run_wrote(tmp_path):
    from pliant.pipeline import MANIFEST

    outside = tmp_path / "outside.txt"
    outside.write_text("not the run's")
    out = tmp_path / "run"
    (out / "figs").mkdir(parents=True)
    (out / "keep").mkdir()
    for name in ("report.md", "figs/a.png", "user.csv"):
        (out / name).write_text("x")
    (out / "link.png").symlink_to(outside)
    # a manifest that names files outside the folder, a directory, a link out, a missing file and a non-string
    (out / MANIFEST).write_text(json.dumps({"files": ["report.md", "figs/a.png", "../outside.txt", str(outside),
                                                      "keep", "link.png", "gone.json", 7]}))
    removed = Pipeline("triple-wall", planner="straight", output=out).clear_previous_run(out)
    assert sorted(p.relative_to(out).as_posix() for p in removed) == ["figs/a.png", "report.md"]
    assert outside.read_text() == "not the run's" and (out / "keep").is_dir() and (out / "user.csv").is_file()
    assert (out / "link.png").is_symlink() and not (out / MANIFEST).exists()


def test_a_folder_pliant_never_wrote_is_left_alone(tmp_path):
    (tmp_path / "report.md").write_text("the user's own notes")
    (tmp_path / "result.json").write_text("{}")
    assert Pipeline("triple-wall", planner="straight", output=tmp_path).clear_previous_run(tmp_path) == []
    assert (tmp_path / "result.json").read_text() == "{}"
