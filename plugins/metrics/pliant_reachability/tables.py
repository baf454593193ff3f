"""``pliant experiment metric-tables``: thesis Tables 6.1-6.4 regenerated -- every method in every cell of the
thesis's grid,
``--runs`` seeded evaluations each, resumable and parallel (:mod:`pliant.experiments.runs`), the thesis's numbers beside
ours, and a figure per task.

Records (``runs.jsonl``): one per task, cell, method and run, with ``p_exec``, ``seconds`` (wall time of the
evaluation), ``simulated_steps``, ``samples``, ``contacts`` and ``volumes``.  Run ``r`` of every method uses seed
``r``.  The density of the sampling methods is fixed per task from its lowest cell (:func:`.evaluation.task_density`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from pliant.api import ConfigError, check_settings, open_log, run_tasks, write_json, write_text

from pliant_reachability.evaluation import evaluate, task_density
from pliant_reachability.ground_truth import ground_truth
from pliant_reachability.tasks import (
    GROUND_TRUTH,
    METHODS,
    TASKS,
    THESIS_P_EXEC,
    THESIS_SECONDS,
    cells,
    thesis_values,
)

#: settings that give a record its meaning
RESUME_SETTINGS = ("simulations", "options", "executions")
#: --quick: CI-sized (minutes on two cores)
QUICK = {"runs": 2, "simulations": {"se3-peg-tight": 500, "se2-through-passage": 300, "se3-peg-in-hole": 500},
         "executions": 20}
#: ground-truth executions per cell (thesis: 100 on the real robot)
EXECUTIONS = 100


def _evaluate(task: str, method: str, cell: int, run: int, density: float, simulations: int, options: dict,
              executions: int) -> dict:
    eps, alpha = cells()[cell]
    if method == GROUND_TRUTH:
        record = ground_truth(task, eps, alpha, executions, seed=1000 * cell + run)
    else:
        record = evaluate(task, method, eps, alpha, run, density, simulations, **options)
    return {**record, "cell": cell, "run": run}


def run_tables(tasks: list[str], *, runs: int, jobs: int, output: Path, fresh: bool = False, quick: bool = False,
               methods: list[str] | None = None, options: dict | None = None, echo=print) -> dict:
    """Run (or resume) the tables of ``tasks``; returns the summary (also written as ``summary.json`` and
    ``tables.md``, with a figure per task)."""
    unknown = [t for t in tasks if t not in TASKS]
    if unknown:
        raise ConfigError(f"unknown task (tasks: {', '.join(TASKS)})", field="TASK", value=unknown[0])
    known = (GROUND_TRUTH, *METHODS)
    methods = list(methods or known)
    bad = [m for m in methods if m not in known]
    if bad:
        raise ConfigError(f"unknown method (methods: {', '.join(known)})", field="--methods", value=bad[0])
    for key, value in (("runs", runs), ("jobs", jobs)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ConfigError("must be a positive integer", field=f"--{key}", value=value)
    options = dict(options or {})
    simulations = {t: (QUICK["simulations"][t] if quick else TASKS[t].simulations) for t in tasks}
    executions = QUICK["executions"] if quick else EXECUTIONS
    directory = output / ("metric-tables-quick" if quick else "metric-tables")
    log, records = open_log(directory, "--output", echo)
    settings = check_settings(directory, {"simulations": simulations, "options": options, "executions": executions},
                              RESUME_SETTINGS,
                              replace=fresh or not records)
    if fresh:
        records = [r for r in records if r["task"] not in tasks]
        from pliant.api import rewrite_jsonl

        rewrite_jsonl(log, records)
    done = {(r["task"], r["method"], r["cell"], r["run"]) for r in records}
    todo = []
    for task in tasks:
        density = task_density(TASKS[task])
        for method in methods:
            for cell in range(len(cells())):
                for run in range(1 if method == GROUND_TRUTH else runs):
                    if (task, method, cell, run) not in done:
                        todo.append((task, method, cell, run, density, simulations[task], options, executions))
    # the ground truth first, then run by run (the baseline first in each), so that an interrupted run has tables
    # of every method over the same runs
    todo.sort(key=lambda t: (t[1] != GROUND_TRUTH, t[3], t[1] != "simulation", t[0], t[2]))
    echo(f"metric tables: {len(records)} evaluations on file, {len(todo)} to go, {jobs} at a time")

    def describe(r: dict) -> str:
        return (f"{r['task']} {r['method']} eps {r['epsilon']:g} alpha {r['alpha']:g} run {r['run']}: "
                f"P_exec {r['p_exec']:.3f} in {r['seconds']:.2f} s")

    def finish() -> dict:
        return write_summary(directory, records, tasks, methods, settings)

    run_tasks(_evaluate, todo, jobs=jobs, log=log, records=records, describe=describe, on_interrupt=finish,
              echo=echo)
    return finish()


def _reference(records: list[dict], task: str, method: str) -> dict[int, float]:
    out = {}
    for cell in range(len(cells())):
        values = [r["p_exec"] for r in records if r["task"] == task and r["method"] == method and r["cell"] == cell]
        if values:
            out[cell] = float(np.mean(values))
    return out


def _errors(values: dict[int, float], reference: dict[int, float]) -> dict:
    """Mean and largest absolute error over the cells both have, and the cells overestimated by more than 0.05."""
    common = [k for k in values if k in reference]
    if not common:
        return {"mean": None, "largest": None, "overestimates": None, "cells": 0}
    diff = np.array([values[k] - reference[k] for k in common])
    return {"mean": float(np.mean(np.abs(diff))), "largest": float(np.max(np.abs(diff))),
            "overestimates": int(np.sum(diff > 0.05)), "cells": len(common)}


def summarise(records: list[dict], tasks: list[str], methods: list[str]) -> dict:
    """Per task and method: mean and standard deviation of ``p_exec`` and ``seconds`` per cell, and the errors
    against our Simulation (baseline), our ground truth, and (the thesis's numbers) the thesis's ground truth."""
    out = {}
    for task in tasks:
        baseline = _reference(records, task, "simulation")
        truth = _reference(records, task, GROUND_TRUTH)
        thesis_truth = thesis_values(THESIS_P_EXEC, task, GROUND_TRUTH)
        rows = {}
        for method in methods:
            per_cell = []
            for cell in range(len(cells())):
                mine = [r for r in records if r["task"] == task and r["method"] == method and r["cell"] == cell]
                p = [r["p_exec"] for r in mine]
                seconds = [r["seconds"] for r in mine]
                per_cell.append({"runs": len(mine), "p_exec": float(np.mean(p)) if p else None,
                                 "p_exec_std": float(np.std(p)) if p else None,
                                 "seconds": float(np.mean(seconds)) if mine else None,
                                 "seconds_std": float(np.std(seconds)) if mine else None,
                                 "simulated_steps": float(np.mean([r["simulated_steps"] for r in mine]))
                                 if mine else None})
            values = {k: c["p_exec"] for k, c in enumerate(per_cell) if c["p_exec"] is not None}
            rows[method] = {"cells": per_cell, "vs_simulation": _errors(values, baseline),
                            "vs_ground_truth": _errors(values, truth),
                            "thesis_vs_its_ground_truth": _thesis_errors(task, method, thesis_truth)}
        out[task] = rows
    return out


def _thesis_errors(task: str, method: str, thesis_truth: tuple | None) -> dict | None:
    """The thesis's own errors of ``method`` against its real robot on ``task``; None where it gives no numbers."""
    values = thesis_values(THESIS_P_EXEC, task, method)
    if method == GROUND_TRUTH or values is None or thesis_truth is None:
        return None
    return _errors(dict(enumerate(values)), dict(enumerate(thesis_truth)))


def _thesis_cell(values: tuple | None, k: int) -> str:
    """The thesis's value in cell ``k`` in parentheses, ``(-)`` where it has none."""
    return "(-)" if values is None else f"({values[k]:.2f})"


def render(summary: dict) -> str:
    """The tables as Markdown: ours, with the thesis's value in parentheses."""
    lines = []
    header = "| method | " + " | ".join(f"{e:g} / {a:g}" for e, a in cells()) + " |"
    rule = "|---" * (len(cells()) + 1) + "|"
    for task, rows in summary.items():
        for what, key, table in (("P_exec", "p_exec", THESIS_P_EXEC), ("seconds", "seconds", THESIS_SECONDS)):
            lines += [f"\n### {task}: {what} (epsilon_reached / alpha; ours mean [std], thesis in parentheses, "
                      "(-) where it has none)\n", header, rule]
            truth = thesis_values(table, task, GROUND_TRUTH)
            if what == "P_exec":
                lines.append("| thesis ground truth (real robot) | "
                             + " | ".join(_thesis_cell(truth, k) for k in range(len(cells()))) + " |")
            for method, row in rows.items():
                if what == "seconds" and method == GROUND_TRUTH:
                    continue
                cellsout = []
                for k, c in enumerate(row["cells"]):
                    if c[key] is None:
                        cellsout.append("-")
                        continue
                    thesis = thesis_values(table, task, method)
                    text = f"{c[key]:.2f} [{c[key + '_std']:.2f}]"
                    cellsout.append(f"{text} {_thesis_cell(thesis, k)}")
                lines.append(f"| {method} | " + " | ".join(cellsout) + " |")
        lines += ["", f"{task}: mean |error| / largest / cells overestimated by more than 0.05", "",
                  "| method | vs our Simulation (baseline) | vs our ground truth | thesis, vs its ground truth |",
                  "|---|---|---|---|"]
        for method, row in rows.items():
            def fmt(e):
                return "-" if not e or e["mean"] is None else \
                    f"{e['mean']:.3f} / {e['largest']:.3f} / {e['overestimates']} of {e['cells']}"
            lines.append(f"| {method} | {fmt(row['vs_simulation'])} | {fmt(row['vs_ground_truth'])} | "
                         f"{fmt(row['thesis_vs_its_ground_truth'])} |")
    return "\n".join(lines) + "\n"


def write_summary(directory: Path, records: list[dict], tasks: list[str], methods: list[str], settings: dict) -> dict:
    """Summarise ``records`` (:func:`summarise`) and write ``summary.json`` (with ``settings``), ``tables.md`` and a
    figure per task (``TASK.png``) into ``directory``; returns the summary."""
    summary = summarise(records, tasks, methods)
    write_json(directory / "summary.json", {"settings": settings, "evaluations": len(records), "tables": summary})
    write_text(directory / "tables.md", render(summary))
    for task, rows in summary.items():
        _figure(directory / f"{task}.png", task, rows)
    return summary


def _figure(path: Path, task: str, rows: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [f"{e:g}/{a:g}" for e, a in cells()]
    x = np.arange(len(labels))
    width = 0.8 / max(len(rows), 1)
    fig, ax = plt.subplots(figsize=(10, 4))
    for k, (method, row) in enumerate(rows.items()):
        p = [np.nan if c["p_exec"] is None else c["p_exec"] for c in row["cells"]]
        err = [0.0 if c["p_exec_std"] is None else c["p_exec_std"] for c in row["cells"]]
        ax.bar(x + (k - (len(rows) - 1) / 2) * width, p, width, yerr=err, label=method, capsize=2)
    truth = thesis_values(THESIS_P_EXEC, task, GROUND_TRUTH)
    if truth:
        ax.plot(x, truth, "k_", markersize=18, mew=2, label="thesis ground truth (real robot)")
    ax.set_xticks(x, labels)
    ax.set_xlabel("epsilon_reached / alpha")
    ax.set_ylabel("P_exec")
    ax.set_ylim(0, 1.05)
    ax.set_title(f"{task}: P_exec per cell")
    ax.legend(fontsize=7, ncol=3, loc="lower left")
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
