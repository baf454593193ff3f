"""``pliant experiment table-4.1`` / ``table-4.2`` / ``table-8.1``: the learners' tables (thesis ch. 4 and appendix
A), ours beside the thesis's; each takes its own options (:mod:`pliant_piirl.commands`) over the mode's settings."""

from __future__ import annotations

import os

from pliant.api import Headline, ReproductionRun, Row
from pliant.api import ReproductionOutcome as Outcome

MODES = {
    "table-4.1": {"full": "learn from the 12 pairs, then 3 plans per task: 10,000 RRT* iterations, shortcut, 60 rounds "
                          "of local search in the recovered cost (the thesis: 30 and 15 RRT* plans of 30 and 60 "
                          "minutes, no local search)",
                  "quick": "3 tasks, 1 plan each: 3,000 RRT* iterations, shortcut, 60 rounds of local search "
                           "(iteration budgets: the headlines depend on the seed only), a coarser expert"},
    "table-4.2": {"full": "the expert, the uniform and the recovered plans with 300 s each (the thesis's 5 minutes)",
                  "quick": "25,000 RRT* iterations per plan (about 60 s on an idle 2-core machine; an iteration "
                           "budget, so the result depends on the seed only)",
                  "ci": "12,000 RRT* iterations per plan (about 30 s each; seed 0's expert still demonstrates the "
                        "O2 passage)"},
    "table-8.1": {"full": "30 presses per object (the thesis's 30), the force chosen from the reference",
                  "quick": "5 presses per object",
                  "ci": "3 presses per object"},
}
MINUTES = {"table-4.1": {"full": 15, "quick": 1}, "table-4.2": {"full": 16, "quick": 4, "ci": 2},
           "table-8.1": {"full": 1.5, "quick": 0.4, "ci": 0.3}}


def table_41(run: ReproductionRun) -> Outcome:
    """Table 4.1: recovered sensitivities from 12 demonstrations, then plans per task against the demonstration."""
    from pliant.api import parse_override

    from pliant_piirl.experiments import TABLE_FULL, TABLE_QUICK, THESIS_ALL_PAIRS, THESIS_TABLE_41, run_table41

    quick = run.mode != "full"
    mode = TABLE_QUICK if quick else TABLE_FULL
    max_time = run.setting("max_time", None)
    budget = {"max_time": max_time,
              "max_iterations": None if max_time is not None else run.setting("max_iterations",
                                                                              mode["max_iterations"]),
              "refine": run.setting("refine", mode["refine"])}
    plans = run.setting("plans", mode["plans"])
    options = dict(parse_override(item, "--set") for item in run.setting("set", []))
    summary = run_table41(plans=plans, **budget, jobs=run.setting("jobs", os.cpu_count() or 1), output=run.output,
                          quick=quick, fresh=run.fresh, echo=run.echo, options=options,
                          straight=run.setting("straight", True))
    values = summary["sensitivities"]
    rows = [Row(f"recovered sensitivity {k}", THESIS_ALL_PAIRS.get(k), v) for k, v in values.items()]
    for r in summary["rows"]:
        k = r["task"]
        thesis = THESIS_TABLE_41[k] if k < len(THESIS_TABLE_41) else None
        for i, c in enumerate("LMH"):
            planned = r["planned"][c]
            rows.append(Row(f"task {k + 1} ({'-'.join(r['objects'])}): planned {c} cost (mean)",
                            thesis[1][i][0] if thesis else None,
                            sum(planned) / len(planned) if planned else None))
    low = max(values[k] for k in values if k.startswith("L"))
    medium = (min(values[k] for k in values if k.startswith("M")), max(values[k] for k in values if k.startswith("M")))
    high = min(values[k] for k in values if k.startswith("H"))
    ordered = float(low < medium[0] and medium[1] < high)
    headlines = [Headline("recovered order low < medium < high (1 = yes)", ordered, 1.0, 1.0, 1.0,
                          "the thesis recovered the three classes in order; so does every trial of ours"),
                 Headline("tasks planned (fraction with a solved plan)",
                          sum(r["solved"] > 0 for r in summary["rows"]) / max(len(summary["rows"]), 1), 1.0, 1.0,
                          1.0, "RRT* finds a path for every task within the budget")]
    rows_ = summary["rows"]
    tasks = max(len(rows_), 1)
    thesis_ratios = sorted(sum(p[0] for p in planned) / sum(shown) for shown, planned in THESIS_TABLE_41)
    # a range is the figure measured with these budgets and seeds less one task of room for another machine's
    # rounding, but never below what the thesis's chapter is asked to show (10 of 12 no costlier, 11 of 12 the same
    # main class).  Measured with the default recovery (the geometric mean of the ranking at h = 5 and 10) and the
    # local search started from the cheaper of the RRT* path and the best straight insertion (docs/plugins/piirl.md):
    # full 10 of 12 tasks no costlier (12 of 12 with h = 5 alone, the default before session 25), 12 of 12 the same
    # main class, median ratio 0.94; quick 3 of 3, 3 of 3, 0.93.  So the full run's "no costlier" range has no room
    bound = {"cheaper": 10 / 12, "same": 11 / 12, "median": 1.0} if not quick else \
        {"cheaper": 2 / 3, "same": 2 / 3, "median": 1.0}
    rows.append(Row("tasks where most plans deform the same classes (a class > 10% of the true cost)",
                    11 / 12, summary.get("tasks_same_share", 0) / tasks))
    for name, ref in summary.get("references", {}).items():
        if ref.get("tasks"):
            rows += [Row(f"reference, {name} values' best straight insertion: tasks with the same main class", None,
                         ref["same_objects"] / ref["tasks"]),
                     Row(f"reference, {name} values' best straight insertion: tasks no costlier", None,
                         ref["no_costlier"] / ref["tasks"])]
    headlines += [
        Headline("tasks where most plans cost no more than the demonstration (fraction, true cost)",
                 summary["tasks_no_costlier"] / tasks, bound["cheaper"], 1.0, 2 / 12,
                 "the issue asks for 10 of 12; the thesis's own Table 4.1 has 2 of 12"),
        Headline("tasks where most plans deform most the class the demonstration deforms most (fraction)",
                 summary["tasks_same_objects"] / tasks, bound["same"], 1.0, 11 / 12,
                 "the issue asks for 11 of 12 deforming the same objects; in the thesis's tasks a demonstration "
                 "deformed one class, in ours every path deforms both faces, so the face deformed most is compared "
                 "(the 10% count is a row above; uniform values' insertions pass it as often as the true values')"),
        Headline("median planned / demonstrated true cost", summary["ratio_true"]["median"], 0.0, bound["median"],
                 (thesis_ratios[5] + thesis_ratios[6]) / 2,
                 "a plan at the demonstration's cost is 1; the thesis's 30-minute RRT* plans 1.55")]
    directory = run.output / f"learn-table-4.1{'-quick' if quick else ''}"
    settings = {"plans": plans, **budget, "quick": quick, **({"options": options} if options else {})}
    return Outcome(rows, headlines, settings,
                   records=[directory / "runs.jsonl", directory / "learned.json", directory / "summary.json"],
                   notes="The thesis's tasks are its own (its object layout); costs are volume change times the true "
                         "sensitivity in both. Thesis's planned costs come from 30-minute RRT* plans without local "
                         "search; ours from RRT* and shortcutting or the best straight insertion, whichever is "
                         "cheaper in the recovered cost, then local search in that cost.")


def table_42(run: ReproductionRun) -> Outcome:
    """Table 4.2: uniform, demonstrated and recovered-sensitivity paths on planar-objects."""
    from pliant_piirl.experiments import THESIS_TABLE_42, run_table42

    budget = {"full": {"max_time": 300.0}, "quick": {"max_iterations": 25_000},
              "ci": {"max_iterations": 12_000}}[run.mode]
    if run.setting("max_time", None) is not None:
        budget = {"max_time": run.options["max_time"]}
    elif run.setting("max_iterations", None) is not None:
        budget = {"max_iterations": run.options["max_iterations"]}
    seed = run.setting("seed", 0)
    summary = run_table42(**budget, seed=seed, output=run.output, echo=run.echo)
    names = list(summary["truth"])
    rows = []
    for path, row in summary["rows"].items():
        for i, n in enumerate(names):
            rows.append(Row(f"{path}: {n} deformation (ours robot points, thesis pixels)",
                            float(THESIS_TABLE_42[path][i]), row["deformation"][n]))
        rows.append(Row(f"{path}: true cost", None, row["true_cost"]))
    cost = {k: v["true_cost"] for k, v in summary["rows"].items()}
    s = summary["sensitivities"]
    headlines = [Headline("true cost: recovered plan / uniform plan", cost["recovered"] / cost["uniform"], 0.0, 1.0,
                          None, "planning with the recovered values must not cost more than with uniform ones "
                                "(ours 435 / 1298 with 12,000 iterations, seed 0, run streams)"),
                 Headline("recovered O2 below O3 (1 = yes)", float(s["O2"] < s["O3"]), 1.0, 1.0, None,
                          "the demonstration pushes through O2 and avoids O3: PIIRL gives O2 the lower bound")]
    directory = run.output / "learn-table-4.2"
    return Outcome(rows, headlines, {**budget, "seed": seed},
                   records=[directory / "summary.json", directory / "demonstration.json"],
                   notes="The thesis's deformation is pixels tracked by a camera in its physical layout; ours is robot "
                         "points in voxels of deformable objects, so the numbers are not comparable, only which "
                         "objects each path deforms.")


def table_81(run: ReproductionRun) -> Outcome:
    """Table 8.1: deformability recovered from presses against a known object."""
    from pliant_piirl.experiments import THESIS_TABLE_81, run_table81

    repetitions = run.setting("repetitions", {"full": 30, "quick": 5, "ci": 3}[run.mode])
    force, seed = run.setting("force", None), run.setting("seed", 0)
    summary = run_table81(repetitions=repetitions, force=force, seed=seed, output=run.output, echo=run.echo)
    rows = [Row(f"{name}: recovered (truth {truth:g})", THESIS_TABLE_81["recovered"][k], summary["recovered"][name],
                tolerance=0.08) for k, (name, truth) in enumerate(summary["truth"].items())]
    rows.append(Row("mean absolute error", summary["thesis_mean_absolute_error"], summary["mean_absolute_error"],
                    tolerance=0.02))
    headlines = [Headline("mean absolute error against the ground truth", summary["mean_absolute_error"], 0.0, 0.08,
                          summary["thesis_mean_absolute_error"],
                          "the development set's 0.009 with 3 presses (docs/plugins/piirl.md; target 0.04)"),
                 Headline("ranking correct (1 = yes)", float(summary["ranking_correct"]), 1.0, 1.0, 1.0,
                          "the thesis and ours rank the five objects correctly")]
    return Outcome(rows, headlines, {"repetitions": repetitions, "force": force, "seed": seed},
                   records=[run.output / "learn-table-8.1" / "summary.json"])


def declarations() -> list:
    """The three reproductions, for the plugin's hook."""
    from pliant.api import CATALOGUE, Reproduction

    runners = {"table-4.1": "table_41", "table-4.2": "table_42", "table-8.1": "table_81"}
    return [Reproduction(name, CATALOGUE[name][0], f"pliant_piirl.reproduce:{runner}", modes=MODES[name],
                         arguments=f"pliant_piirl.commands:table{runner[-2:]}_arguments",
                         minutes=MINUTES[name]) for name, runner in runners.items()]
