"""``pliant experiment table-6.1 ... table-6.4``: the path-quality metrics' tables (thesis 6.5) through
``pliant experiment metric-tables``'s runs (:func:`pliant_reachability.tables.run_tables`), ours beside the thesis's.

Tables 6.1 / 6.3 (P_exec / seconds on se3-peg-tight) come from the same evaluations, as do 6.2 / 6.4 on
se2-through-passage: the four reproductions share their records (``out/reproduce/_metric-tables/<mode>/<task>/``),
so the second of a pair only reads them.
"""

from __future__ import annotations

import math
import os

from pliant.api import Headline, ReproductionRun, Row
from pliant.api import ReproductionOutcome as Outcome

#: reproduction -> (task, quantity)
TABLES = {"table-6.1": ("se3-peg-tight", "p_exec"), "table-6.2": ("se2-through-passage", "p_exec"),
          "table-6.3": ("se3-peg-tight", "seconds"), "table-6.4": ("se2-through-passage", "seconds")}
#: the methods of the ci mode: the baseline and the proposed metric
CI_METHODS = ["simulation", "reachable-volume"]
MODES = {"full": "every method, 30 runs per cell, the thesis's baseline sizes, 100 ground-truth executions",
         "quick": "every method, 2 runs per cell, 500 / 300 baseline simulations, 20 ground-truth executions",
         "ci": "Simulation and the reachable-volume metric, 1 run per cell, 500 / 300 baseline simulations"}
MINUTES = {"full": 210, "quick": 10, "ci": 1.5}     # full: both tasks' 30-run protocol, ~3.5 h on 2 idle cores
#: the reachable-volume metric's simulated control steps per evaluation, mean over the cells (measured: the peg in
#: ci mode; the passage in the benchmark, seed 0, since the task labels 400 contact events instead of 200),
#: and the range the seconds tables accept (about 0.6x to 1.5x)
STEPS_MEASURED = {"se2-through-passage": 10704.0, "se3-peg-tight": 2747.0}
STEPS = {task: (0.6 * v, 1.5 * v) for task, v in STEPS_MEASURED.items()}


def _summary(run: ReproductionRun, task: str) -> tuple[dict, object]:
    from pliant_reachability.tables import run_tables

    shared = run.output.parent.parent / "_metric-tables" / run.mode / task
    kwargs = {"full": {"runs": 30}, "quick": {"runs": 2, "quick": True},
              "ci": {"runs": 1, "quick": True, "methods": CI_METHODS}}[run.mode]
    summary = run_tables([task], jobs=os.cpu_count() or 1, output=shared, fresh=run.fresh, echo=run.echo, **kwargs)
    directory = shared / ("metric-tables-quick" if kwargs.get("quick") else "metric-tables")
    return summary[task], directory


def _table(run: ReproductionRun) -> Outcome:
    task, quantity = TABLES[run.reproduction.name]
    rows_by_method, directory = _summary(run, task)
    return outcome(task, quantity, rows_by_method, directory, run.mode)


def outcome(task: str, quantity: str, rows_by_method: dict, directory, mode: str) -> Outcome:
    """The reproduction's table of ``quantity`` (``p_exec`` or ``seconds``) on ``task`` from its summary
    (:func:`pliant_reachability.tables.summarise`): ours beside the thesis's value, ``None`` (printed ``-``, not
    compared) where the thesis has none, as for a task it did not evaluate."""
    from pliant_reachability.tasks import THESIS_P_EXEC, THESIS_SECONDS, cells, thesis_values

    table = THESIS_P_EXEC if quantity == "p_exec" else THESIS_SECONDS
    rows = []
    for method, row in rows_by_method.items():
        if quantity == "seconds" and method == "ground truth":
            continue
        for k, (eps, alpha) in enumerate(cells()):
            ours = row["cells"][k][quantity]
            values = thesis_values(table, task, method)
            reference = None if values is None else values[k]
            # P_exec: 0.1 (the thesis's own spread between methods); seconds: the thesis's value (16 threads there,
            # one core here), i.e. marked beyond twice the thesis's time
            tolerance = 0.1 if quantity == "p_exec" else reference
            rows.append(Row(f"{method}, eps {eps:g} / alpha {alpha:g}", reference, ours, tolerance=tolerance,
                            unit="s" if quantity == "seconds" else ""))
    rv = rows_by_method["reachable-volume"]
    if quantity == "p_exec":
        errors = rv["vs_simulation"]
        headlines = [
            Headline("reachable-volume: mean |P_exec - our Simulation| over the cells", errors["mean"], 0.0, 0.05,
                     None, "docs/plugins/reachability.md: 0.011 (peg) and 0.015 (passage) in the quick tables"),
            Headline("reachable-volume: largest |P_exec - our Simulation|", errors["largest"], 0.0, 0.1, None,
                     "within 0.02 in every cell of the quick tables; 0.1 leaves room for a 1-run mean"),
        ]
    else:
        seconds = [c["seconds"] for c in rv["cells"] if c["seconds"] is not None]
        steps = [c["simulated_steps"] for c in rv["cells"] if c["simulated_steps"] is not None]
        low, high = STEPS.get(task, (0.0, math.inf))
        thesis_seconds = thesis_values(THESIS_SECONDS, task, "reachable-volume")
        headlines = [
            Headline("reachable-volume: simulated control steps per evaluation (mean over cells)",
                     sum(steps) / len(steps), low, high, None,
                     "the metric's work, independent of the machine's load: measured "
                     f"{STEPS_MEASURED.get(task, math.nan):.0f}; a change that makes it simulate far more (or "
                     "nothing) fails")]
        # wall time depends on the machine: reported, never a checked headline (the speed figure is a benchmark's)
        rows.append(Row("reachable-volume: mean seconds per evaluation (2-4 s on an idle core; not checked)",
                        None if thesis_seconds is None else sum(thesis_seconds) / len(thesis_seconds),
                        sum(seconds) / len(seconds), unit="s"))
    notes = ("The thesis's ground truth is 100 executions of a real KUKA iiwa; ours is a dynamic simulator "
             "(docs/plugins/reachability.md), so the ground-truth rows are not expected to match. "
             f"The complete tables (every method, errors against the baselines) are in {directory / 'tables.md'}.")
    figures = [directory / f"{task}.png"] if (directory / f"{task}.png").exists() else []
    settings = {"task": task, "mode": mode, "protocol": MODES[mode],
                "records": str(directory / "runs.jsonl")}
    return Outcome(rows, headlines, settings, records=[directory / "runs.jsonl", directory / "summary.json"],
                   figures=figures, notes=notes)


def table_61(run: ReproductionRun) -> Outcome:
    """Table 6.1: P_exec on se3-peg-tight."""
    return _table(run)


table_62 = table_63 = table_64 = table_61


def declarations() -> list:
    """The four reproductions, for the plugin's hook."""
    from pliant.api import CATALOGUE, Reproduction

    runner = {"table-6.1": "table_61", "table-6.2": "table_62", "table-6.3": "table_63", "table-6.4": "table_64"}
    return [Reproduction(name, CATALOGUE[name][0], f"pliant_reachability.reproduce:{runner[name]}", modes=MODES,
                         minutes=MINUTES) for name in TABLES]
