"""The astar and astar-pareto planners on the thesis scenes (ch. 3.3.1)."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import Pipeline, load_scene, registry
from pliant.errors import ConfigError, PlanningError
from pliant.interfaces import Context, PlanningProblem
from pliant.results import PlanResult, Status
from pliant.testing import check_component


def problem_for(scene_context, name, start=None, goal=None):
    return PlanningProblem.from_context(scene_context(name, "voxel"), start=start, goal=goal)


def plan(scene_context, name, p, **kw):
    ctx = scene_context(name, "voxel")
    return registry.create("planner", "astar", ctx, p=p).plan(PlanningProblem.from_context(ctx, **kw),
                                                              np.random.default_rng(0))


def test_triple_wall_extremes_match_the_thesis(scene_context):
    # thesis Figure 3.5: p = 0 gives length 61 and deformation 1062; p = 0.7 a deformation-free path of
    # length 94 (our lengths count sqrt 2 / sqrt 3 for diagonal steps)
    shortest = plan(scene_context, "triple-wall", 0.0)
    assert shortest.status is Status.SOLVED
    assert shortest.statistics["length_voxels"] == pytest.approx(61.456, abs=1e-3)
    assert shortest.statistics["deformation"] == pytest.approx(1062.0)
    free = plan(scene_context, "triple-wall", 0.7)
    assert free.statistics["deformation"] == 0.0
    assert free.statistics["length_voxels"] == pytest.approx(94.38, abs=0.01)


def test_path_is_valid_and_connects_start_to_goal(scene_context):
    result = plan(scene_context, "triple-wall", 0.3)
    problem = problem_for(scene_context, "triple-wall")
    q = result.path.configurations
    assert np.allclose(q[0], problem.start) and np.allclose(q[-1], problem.goal)
    assert np.all(problem.is_valid(q))
    steps = np.abs(np.diff(q, axis=0)) / 0.008
    assert np.all(steps <= 1 + 1e-9)
    cost = scene_context("triple-wall", "voxel").cost
    assert result.statistics["deformation"] == pytest.approx(float(np.sum(cost.cost(q))))


def test_exact_astar_is_never_worse_than_the_thesis_at_small_p(scene_context):
    # thesis Figure 3.5(c): p = 0.01 gave length 65, deformation 683 -> f = 0.99*65 + 0.01*683 = 71.18
    result = plan(scene_context, "triple-wall", 0.01)
    assert result.cost <= 0.99 * 65 + 0.01 * 683


@pytest.mark.parametrize("scene", ["triple-wall", "multi-cost"])
def test_pareto_sweep_is_monotone(scene, scene_context):
    ctx = scene_context(scene, "voxel")
    result = registry.create("planner", "astar-pareto", ctx, values=21).plan(PlanningProblem.from_context(ctx),
                                                                            np.random.default_rng(0))
    sweep = np.array(result.statistics["sweep"])
    assert np.all(np.diff(sweep[:, 2]) <= 1e-9), "deformation must never rise as p grows"
    assert np.all(np.diff(sweep[:-1, 1]) >= -1e-9), "length must never fall as p grows"
    front = result.statistics["pareto"]
    lengths = [f["length_voxels"] for f in front]
    deform = [f["deformation"] for f in front]
    assert lengths == sorted(lengths) and deform == sorted(deform, reverse=True)
    assert len(front) >= 2


def test_invalid_start_and_goal_statuses(scene_context):
    inside_wall = (np.array([5, 15, 20]) + 0.5) * 0.008
    hard = Context(scene=load_scene("triple-wall:hard-robot-hard-walls"))
    hard.robot = registry.create("robot", "rigid", hard)
    hard.cost = registry.create("cost", "voxel", hard)
    planner = registry.create("planner", "astar", hard, p=0.5)
    assert planner.plan(PlanningProblem.from_context(hard, start=inside_wall), np.random.default_rng(0)).status \
        is Status.INVALID_START
    assert planner.plan(PlanningProblem.from_context(hard, goal=inside_wall), np.random.default_rng(0)).status \
        is Status.INVALID_GOAL


def test_hard_walls_force_the_deformation_free_path(scene_context):
    hard = Context(scene=load_scene("triple-wall:hard-robot-hard-walls"))
    hard.robot = registry.create("robot", "rigid", hard)
    hard.cost = registry.create("cost", "voxel", hard)
    result = registry.create("planner", "astar", hard, p=0.0).plan(PlanningProblem.from_context(hard),
                                                                   np.random.default_rng(0))
    assert result.status is Status.SOLVED
    assert result.statistics["length_voxels"] == pytest.approx(94.38, abs=0.01)


def test_p_out_of_range_is_a_config_error(scene_context):
    with pytest.raises(ConfigError, match=r"planner\.p"):
        registry.create("planner", "astar", scene_context("triple-wall", "voxel"), p=1.5)


def test_non_translation_space_is_rejected(scene_context):
    ctx = scene_context("cube-wall", "voxel")
    with pytest.raises(PlanningError, match="r3"):
        registry.create("planner", "astar", ctx).plan(PlanningProblem.from_context(ctx), np.random.default_rng(0))


def test_conformance():
    assert check_component("planner", "astar", scene="multi-cost")


def test_demo_pipeline_end_to_end(tmp_path):
    record = Pipeline.from_file("triple-wall-pareto", overrides=["planner.values=11", f'output="{tmp_path}"']).run()
    assert record.result.status is Status.SOLVED
    for name in ("report.md", "result.json", "pareto_front.png", "pareto_paths.png", "path.png"):
        assert (tmp_path / name).is_file(), name
    loaded = PlanResult.load(tmp_path / "result.json")
    assert loaded.statistics["pareto_size"] == record.result.statistics["pareto_size"]
    assert "astar-pareto" in (tmp_path / "report.md").read_text()


def test_pareto_command(tmp_path, capsys):
    from pliant.cli import main

    assert main(["experiment", "pareto", "multi-cost", "--values", "11", "--output", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "length (voxels)" in out and (tmp_path / "pareto_front.png").is_file()


def test_a_robot_that_fits_nowhere_is_a_planning_error():
    from pliant import Scene

    data = {"name": "tiny", "start": [0.5, 0.5, 0.5], "goal": [1.5, 0.5, 0.5],
            "bounds": {"lower": [0, 0, 0], "upper": [2, 1, 1], "resolution": 1.0},
            "robot": {"kind": "rigid", "space": "r3", "parts": [{"cells": [[0, 3], [0, 1], [0, 1]]}]}}
    ctx = Context(scene=Scene.from_dict(data))
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.cost = registry.create("cost", "voxel", ctx)
    with pytest.raises(PlanningError, match="does not fit"):
        registry.create("planner", "astar", ctx).plan(PlanningProblem.from_context(ctx), np.random.default_rng(0))
