"""The task se3-peg-in-hole (ours: the thesis has no numbers for it): its definition, a tiny ground truth, and
everything that prints the thesis's numbers beside ours printing ``-`` for it; the thesis's two tasks unchanged."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pliant
import pytest
from pliant.cli import build_parser
from pliant.interfaces import Context
from pliant_reachability.tables import render, summarise
from pliant_reachability.tasks import (
    PEG_IN_HOLE_LEVER,
    TASKS,
    THESIS_P_EXEC,
    THESIS_SECONDS,
    THESIS_TASKS,
    WRIST_LEVER,
    cells,
    thesis_values,
)

TASK = "se3-peg-in-hole"
BENCHMARKS = Path(__file__).resolve().parents[4] / "benchmarks"


def _context(alpha: float) -> Context:
    task = TASKS[TASK]
    context = Context(scene=pliant.load_scene(task.scene))
    context.robot = pliant.registry.create("robot", "rigid", context, translation_weight=task.translation_weight)
    context.simulator = pliant.registry.create("simulator", "kinematic", context, **task.simulator_options(alpha))
    return context


def test_the_thesis_has_no_numbers_for_the_task_and_its_two_tasks_are_unchanged():
    assert TASK not in THESIS_TASKS and TASK not in THESIS_P_EXEC and TASK not in THESIS_SECONDS
    assert thesis_values(THESIS_P_EXEC, TASK, "reachable-volume") is None
    assert thesis_values(THESIS_P_EXEC, "se3-peg-tight", "sampling-driven") is None      # lost in Table 6.1
    assert thesis_values(THESIS_P_EXEC, "se3-peg-tight", "ground truth")[0] == 0.91
    # what a run of `pliant metric-table` on file (settings.json) was started with: the same again
    assert THESIS_TASKS == ("se3-peg-tight", "se2-through-passage")
    args = build_parser().parse_args(["experiment", "metric-tables"])
    assert args.tasks == list(THESIS_TASKS)
    assert {t: TASKS[t].simulations for t in THESIS_TASKS} == {"se3-peg-tight": 10000, "se2-through-passage": 2000}
    assert [TASKS[t].translation_weight for t in THESIS_TASKS] == [10.0, 10.0]
    assert TASKS["se3-peg-tight"].world_options == {"max_force": 0.2, "max_torque": 0.2 * WRIST_LEVER}
    assert TASKS["se3-peg-tight"].metric_options == {}
    assert TASKS["se2-through-passage"].metric_options == {"labelled": 400}


def test_the_task_is_se3_peg_tight_scaled_by_ten():
    task, tight = TASKS[TASK], TASKS["se3-peg-tight"]
    assert task.scene == TASK and task.world == "pybullet"
    assert task.translation_weight == tight.translation_weight / 10
    assert task.simulator["velocity_limit"] == 10 * tight.simulator["velocity_limit"]
    assert task.simulator["angular_velocity_limit"] == tight.simulator["angular_velocity_limit"]
    assert task.simulator["effort_length"] == PEG_IN_HOLE_LEVER == pytest.approx(10 * WRIST_LEVER)
    # the world's wrist is the model's: torque over force is the same lever
    world = task.world_settings(0.125)
    assert world["max_torque"] / world["max_force"] == pytest.approx(task.simulator["effort_length"])
    assert world["noise_linear"] == 0.125 and world["noise_angular"] == 0.125 / 4


def test_the_waypoints_start_free_the_goal_is_reached_and_the_pair_is_not_trivial():
    from pliant.interfaces import PlanningProblem
    from pliant.results import Path as WaypointPath

    task = TASKS[TASK]
    context = _context(0.25)
    metric = pliant.registry.create("metric", "simulation", context, epsilon_reached=0.125,
                                    translation_weight=task.translation_weight, simulations=200)
    a, b = (np.asarray(w, dtype=np.float64) for w in task.waypoints)
    assert np.allclose(np.linalg.norm([a[3:], b[3:]], axis=1), 1.0)
    clearance, _, colliding = metric.clearance.query(np.array([a, b]))
    assert not colliding.any()
    assert clearance[0] > context.scene.resolution            # the start does not touch: 0.1 m above the block
    assert b[2] - 0.5 == pytest.approx(0.125)                 # the goal: the peg's bottom on the hole's floor
    # 200 kinematic executions from the start ball in cell (0.125, 0.25): most reach the goal, some stick on the
    # block beside the hole (the 1,000-run baseline said 0.873)
    scores = metric.evaluate(WaypointPath(np.array([a, b])), PlanningProblem.from_context(context),
                             np.random.default_rng(0))
    assert 0.5 < scores["p_exec"] < 1.0
    assert scores["simulated_steps"] > 0


@pytest.mark.slow
def test_a_tiny_ground_truth_runs_end_to_end():
    from pliant_reachability.ground_truth import ground_truth

    record = ground_truth(TASK, 0.25, 0.25, 2, seed=0)
    assert record["world"] == "pybullet" and record["executions"] == 2
    assert sum(record["outcomes"].values()) == 2
    assert 0.0 <= record["p_exec"] <= 1.0


def _records(task: str) -> list[dict]:
    records = []
    for cell in range(len(cells())):
        metric = 0.97 if cell == 0 else 0.88
        for method, p in (("simulation", 0.9), ("reachable-volume", metric), ("ground truth", 1.0)):
            records.append({"task": task, "method": method, "cell": cell, "p_exec": p, "seconds": 1.5,
                            "simulated_steps": 1000.0 if method == "simulation" else 20.0})
    return records


def test_the_tables_print_a_dash_where_the_thesis_has_no_number():
    methods = ["ground truth", "simulation", "reachable-volume"]
    summary = summarise(_records(TASK), [TASK], methods)
    rows = summary[TASK]
    assert all(row["thesis_vs_its_ground_truth"] is None for row in rows.values())
    assert rows["reachable-volume"]["vs_simulation"]["overestimates"] == 1
    assert rows["reachable-volume"]["vs_ground_truth"]["mean"] == pytest.approx((0.03 + 8 * 0.12) / 9)
    text = render(summary)
    assert "| thesis ground truth (real robot) | " + " | ".join(["(-)"] * 9) + " |" in text
    assert "| reachable-volume | 0.97 [0.00] (-) |" in text
    assert "| simulation | 0.90 [0.00] (-) |" in text          # P_exec and seconds alike
    errors = [line for line in text.splitlines() if line.startswith("| reachable-volume | 0.0")]
    assert len(errors) == 1 and errors[0].endswith(" | - |")       # the thesis's own error: none
    # the thesis's tasks still print its numbers
    text = render(summarise(_records("se3-peg-tight"), ["se3-peg-tight"], methods))
    assert "| thesis ground truth (real robot) | (0.91) |" in text and "(4.99)" in text


def test_the_reproduction_table_has_no_thesis_value_and_marks_nothing(tmp_path):
    from pliant_reachability.reproduce import outcome

    rows = summarise(_records(TASK), [TASK], ["ground truth", "simulation", "reachable-volume"])[TASK]
    for quantity in ("p_exec", "seconds"):
        result = outcome(TASK, quantity, rows, tmp_path, "ci")
        assert result.rows and all(row.thesis is None and not row.marked for row in result.rows)
        assert all(headline.thesis is None for headline in result.headlines)
    tight = summarise(_records("se3-peg-tight"), ["se3-peg-tight"], ["simulation", "reachable-volume"])
    result = outcome("se3-peg-tight", "p_exec", tight["se3-peg-tight"], tmp_path, "ci")
    assert result.rows[0].thesis == 1.0                       # Simulation (baseline), cell (0.125, 0.0625)


def _bench():
    """benchmarks/bench_metric.py as a module."""
    sys.path.insert(0, str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location("bench_metric_under_test", BENCHMARKS / "bench_metric.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench


def test_the_benchmark_prints_a_dash_where_the_thesis_has_no_number():
    bench = _bench()
    result = {"p_exec": 0.9, "seconds": 1.0, "simulated_steps": 10.0}
    record = {"task": TASK, "cell": 0, "epsilon": 0.125, "alpha": 0.0625,
              "baseline": {**result, "simulated_steps": 1000.0},
              **{m: result for m in ("simulation-scaled", "sampling-driven", "reachable-volume")}}
    row = bench._row(record)
    assert row[3] == "0.900 (+0.000) [-]" and row[-1] == "100x"
    assert bench._thesis(None) == "-" and bench._thesis((1.0, 2.0), 1) == "2.00"
    assert bench._row({**record, "task": "se3-peg-tight"})[3] == "0.900 (+0.000) [1.00]"


def test_the_benchmark_reports_each_method_against_the_ground_truth(tmp_path, capsys):
    import json

    bench = _bench()
    result = {"p_exec": 0.9, "seconds": 1.0, "simulated_steps": 10.0, "seconds_idle": 0.5}
    records = [{"task": TASK, "cell": k, "epsilon": e, "alpha": a, "baseline": {**result, "p_exec": 0.8},
                **{m: result for m in ("simulation-scaled", "sampling-driven", "reachable-volume")}}
               for k, (e, a) in enumerate(cells())]
    (tmp_path / "metric.json").write_text(json.dumps({"simulations": 10000, "results": records}))
    truth = [{"task": TASK, "method": "ground truth", "cell": k, "p_exec": 1.0 if k else 0.8} for k in range(9)]
    (tmp_path / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in truth))
    assert bench.main(["--replay", str(tmp_path / "metric.json"), "--tasks", TASK,
                       "--ground-truth", str(tmp_path / "runs.jsonl")]) == 0
    out = capsys.readouterr().out
    assert "(10000 runs)" in out and "[-]" in out and "(thesis, 16 threads: -)" in out
    assert "ground truth per cell: 0.80 1.00" in out
    lines = {line.split()[0]: line.split() for line in out.splitlines() if line.startswith(("baseline ", "reach"))}
    assert lines["baseline"][1:] == ["0.178", "0.200", "0", "of", "9"]          # (8 x 0.2 + 0) / 9
    assert lines["reachable-volume"][1:] == ["0.100", "0.100", "1", "of", "9"]  # 0.9 against 0.8 in cell 0
