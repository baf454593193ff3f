"""``pliant experiment table-5.1`` / ``table-5.2``: the belief planner's peg-in-hole tables (thesis 5.4.1) through
:func:`pliant_belief.experiments.run_experiment`, ours beside the thesis's; the options of ``pliant experiment
belief`` (``--plans``, ``--plan-time``, ...) override the mode's settings."""

from __future__ import annotations

import itertools
import json
import math
import os
from pathlib import Path

import numpy as np
from pliant.api import Headline, ReproductionRun, Row
from pliant.api import ReproductionOutcome as Outcome

#: thesis Table 5.1: row -> (P_plan, P_exec, P_exec std)
THESIS_51 = {"AC": (1.0, 0.97, 0.17), "PC": (1.0, 0.89, 0.19), "WCR 0.125": (1.0, 0.73, 0.42),
             "WCR 0.25": (0.97, 0.95, 0.18), "WCR 0.5": (0.97, 0.84, 0.34), "WCR 0.75": (0.97, 0.99, 0.02),
             "WCR 0.99": (0.97, 0.96, 0.18)}
#: thesis Table 5.2: row -> (P_plan, P_exec, P_exec std)
THESIS_52 = {}
for _g, _simple, _contact, _p24, _p48 in (
        ("0", (0, 0, 0), (1, 0.78, 0.38), (1, 0.42, 0.48), (0.97, 0.59, 0.47)),
        ("0.0625", (0, 0, 0), (1, 0.78, 0.39), (1, 0.60, 0.43), (1, 0.625, 0.43)),
        ("0.125", (0, 0, 0), (1, 0.79, 0.38), (1, 0.99, 0.18), (0.93, 0.81, 0.37)),
        ("0.25", (0, 0, 0), (1, 0.50, 0.37), (1, 0.90, 0.28), (0.86, 0.72, 0.41))):
    THESIS_52.update({f"simple, gamma {_g}": _simple, f"contact, gamma {_g}": _contact,
                      f"24 particles, gamma {_g}": _p24, f"48 particles, gamma {_g}": _p48})

#: mode -> run_experiment settings (``only``: the rows run; None: every row)
SETTINGS = {
    "table-5.1": {"full": {"plans": 30, "executions": 40, "plan_time": 300.0, "exec_time": 300.0, "only": None},
                  "quick": {"plans": 2, "executions": 4, "plan_time": 30.0, "exec_time": 120.0, "only": None},
                  "ci": {"plans": 1, "executions": 2, "plan_time": 600.0, "plan_iterations": 60, "exec_time": 120.0,
                         "only": ["AC", "WCR 0.75"]}},
    "table-5.2": {"full": {"plans": 30, "executions": 40, "plan_time": 300.0, "exec_time": 300.0, "only": None},
                  "quick": {"plans": 1, "executions": 4, "plan_time": 30.0, "exec_time": 120.0, "only": None},
                  "ci": {"plans": 1, "executions": 2, "plan_time": 600.0, "plan_iterations": 60, "exec_time": 120.0,
                         "only": ["simple, gamma 0.125", "contact, gamma 0.125", "24 particles, gamma 0.125"]}},
}
MODES = {
    "table-5.1": {"full": "every row, 30 policies of 300 s, 40 executions each (the thesis's protocol)",
                  "quick": "every row, 2 policies of 30 s, 4 executions each",
                  "ci": "rows AC and WCR 0.75, 1 policy of 60 iterations (about 20 s), 2 executions"},
    "table-5.2": {"full": "every row, 30 policies of 300 s, 40 executions each (the thesis's protocol)",
                  "quick": "every row, 1 policy of 30 s, 4 executions each",
                  "ci": "gamma 1/8: Simple RRT, Contact RRT, 24 particles; 1 policy of 60 iterations (about 20 s), "
                        "2 executions"},
}
MINUTES = {"table-5.1": {"full": 24 * 60 * 0.5, "quick": 8, "ci": 1.5},
           "table-5.2": {"full": 40 * 60 * 0.5, "quick": 10, "ci": 2}}


def _table(run: ReproductionRun) -> Outcome:
    from pliant_belief.experiments import run_experiment

    name = run.reproduction.name
    settings = dict(SETTINGS[name][run.mode])
    for key in ("plans", "executions", "plan_time", "plan_iterations", "exec_time", "only", "replay"):
        if run.options.get(key) is not None:
            settings[key] = run.options[key]
    thesis = THESIS_51 if name == "table-5.1" else THESIS_52
    rows_out = run_experiment(name, jobs=run.setting("jobs", os.cpu_count() or 1), fresh=run.fresh,
                              output=run.output, echo=run.echo, **settings)
    ours = {r["variant"]: r for r in rows_out}
    rows = []
    for label, r in ours.items():
        p_plan, p_exec, std = thesis.get(label, (None, None, None))
        rows += [Row(f"{label}: P_plan", p_plan, r["p_plan"], tolerance=0.1),
                 Row(f"{label}: P_exec (tolerance: the thesis's std, at least 0.1)", p_exec, r["p_exec"],
                     tolerance=None if std is None else max(std, 0.1)),
                 Row(f"{label}: policies planned / actions / first solution (s)", None,
                     f"{r['plans']} / {r['actions']:.1f} / {r['time_to_first']:.1f}")]
    headlines, left_out = _headlines(name, ours)
    directory = run.output / name
    tables = write_tables(directory, name)
    ompl = _ompl(run, directory, settings["plan_time"])
    notes = ("Executions run in pybullet, the thesis's in Gazebo; on se3-peg-in-hole (30% clearance) every row of ours "
             "plans and executes nearly always, so the thesis's ordering between rows is not reproduced (see "
             "docs/plugins/belief.md and the tight-hole experiments table-5.1-tight / table-5.2-tight).")
    return Outcome(rows, headlines, {"experiment": name, "mode": run.mode, **settings},
                   records=[directory / "runs.jsonl", directory / "summary.json", directory / "settings.json", tables,
                            directory / "ordering.json", *ompl],
                   notes=notes + (f" Headlines of rows not run (--only) left out: {', '.join(left_out)}."
                                  if left_out else ""))


#: headline -> (row it reads, lowest, highest, thesis, why), per table
HEADLINES = {
    "table-5.1": [("WCR 0.75: P_plan", "WCR 0.75", "p_plan", 1.0, 1.0, 0.97,
                   "every WCR 0.75 policy planned in ours (10 of 10 in 60 s, first after 2.6 s)"),
                  ("WCR 0.75: P_exec", "WCR 0.75", "p_exec", 0.5, 1.0, 0.99,
                   "ours 1.00 over 10 policies x 8 executions; a 1-policy, 2-execution mean can lose one"),
                  ("AC: P_plan", "AC", "p_plan", 1.0, 1.0, 1.0, "AC planned every time in ours (first solution after "
                                                                  "1.1 s)")],
    "table-5.2": [("Simple RRT, gamma 1/8: P_plan", "simple, gamma 0.125", "p_plan", 0.0, 0.0, 0.0,
                   "no straight path through the hole: the thesis's and ours find none"),
                  ("Contact RRT, gamma 1/8: P_plan", "contact, gamma 0.125", "p_plan", 1.0, 1.0, 1.0,
                   "contact makes the hole reachable: every plan in both"),
                  ("24 particles, gamma 1/8: P_plan", "24 particles, gamma 0.125", "p_plan", 1.0, 1.0, 1.0,
                   "the belief planner plans every time at gamma 1/8 with 24 particles"),
                  ("24 particles, gamma 1/8: P_exec", "24 particles, gamma 0.125", "p_exec", 0.5, 1.0, 0.99,
                   "ours 1.00 in the 3-plan runs of docs/plugins/belief.md")],
}


def _headlines(name: str, ours: dict) -> tuple[list[Headline], list[str]]:
    """The table's headlines whose rows ran, and the rows of the others (``--only`` left them out)."""
    kept = [Headline(title, ours[row][field], low, high, thesis, why)
            for title, row, field, low, high, thesis, why in HEADLINES[name] if row in ours]
    return kept, sorted({row for _, row, *_ in HEADLINES[name] if row not in ours})


def ordering(records: list[dict], thesis: dict, gap: float = 0.05) -> dict:
    """Whether the thesis's ordering of the rows by P_exec holds in ``records``: for every pair of rows whose
    thesis P_exec differ by at least ``gap``, the 95% bootstrap interval of our difference (higher-in-the-thesis
    minus lower, over the planned policies' success rates): ``holds`` when it lies above 0, ``reversed`` below,
    ``not separated`` when it contains 0; ``no policy`` when one of the two rows planned none (its P_exec, a mean
    over planned policies, does not exist: Simple RRT in Table 5.2, which the thesis lists with P_exec 0; the P_plan
    column compares those rows).  The statement: ``holds`` if every compared pair holds, ``refuted`` if one is
    reversed, else ``not resolved``."""
    from pliant_belief.experiments import bootstrap_mean

    def rates(label):
        return [float(np.mean([e["outcome"] == "success" for e in r["executions"].get("default", [])]))
                for r in records if r["variant"] == label and r["planned"] and r["executions"].get("default")]

    pairs = []
    labels = [label for label in thesis if any(r["variant"] == label for r in records)]
    for a, b in itertools.combinations(labels, 2):
        if abs(thesis[a][1] - thesis[b][1]) < gap:
            continue
        high, low = (a, b) if thesis[a][1] > thesis[b][1] else (b, a)
        ra, rb = rates(high), rates(low)
        if not ra or not rb:
            pairs.append({"higher": high, "lower": low, "thesis": [thesis[high][1], thesis[low][1]],
                          "ours": [float(np.mean(ra)) if ra else None, float(np.mean(rb)) if rb else None],
                          "difference_ci95": None, "verdict": "no policy"})
            continue
        interval = bootstrap_mean(ra, rb)
        verdict = "not separated" if interval[0] <= 0 <= interval[1] else "holds" if interval[0] > 0 else "reversed"
        pairs.append({"higher": high, "lower": low, "thesis": [thesis[high][1], thesis[low][1]],
                      "ours": [float(np.mean(ra)), float(np.mean(rb))], "difference_ci95": interval,
                      "verdict": verdict})
    verdicts = [p["verdict"] for p in pairs if p["verdict"] != "no policy"]
    statement = ("refuted" if "reversed" in verdicts else "holds" if verdicts and all(v == "holds" for v in verdicts)
                 else "not resolved")
    return {"statement": statement, "pairs": pairs, "gap": gap}


def write_tables(directory, name: str) -> Path:
    """``tables.md`` and ``ordering.json`` of the records in ``directory`` (an experiment's folder: runs.jsonl,
    settings.json): each row's P_plan and P_exec with 95% intervals (Wilson over plans; bootstrap over the planned
    policies' success rates), the thesis's beside, and whether the thesis's ordering holds (:func:`ordering`)."""
    from pliant.api import read_jsonl, write_json, write_text

    from pliant_belief.experiments import experiments, summarise, wilson

    directory = Path(directory)
    records, _ = read_jsonl(directory / "runs.jsonl")
    thesis = THESIS_51 if name.startswith("table-5.1") else THESIS_52
    rows = summarise(records, experiments()[name])
    order = ordering(records, thesis)
    settings = json.loads((directory / "settings.json").read_text()) if (directory / "settings.json").is_file() else {}

    def fmt(value, interval):
        return "-" if value != value else f"{value:.2f} [{interval[0]:.2f}, {interval[1]:.2f}]"

    lines = [f"# {name}: P_plan and P_exec with 95% intervals, the thesis's beside", "",
             f"Settings: {json.dumps(settings)}. {len(records)} policies on file.", "",
             "| row | plans | P_plan [95%] | thesis P_plan | P_exec [95%] | executions [95%] | thesis P_exec (std) "
             "| actions |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        t = thesis.get(r["variant"])
        runs = [e for q in records if q["variant"] == r["variant"] and q["planned"]
                for e in q["executions"].get("default", [])]
        won = sum(e["outcome"] == "success" for e in runs)
        pooled = "-" if not runs else f"{won}/{len(runs)} [{', '.join(f'{x:.2f}' for x in wilson(won, len(runs)))}]"
        lines.append(f"| {r['variant']} | {r['plans']} | {fmt(r['p_plan'], r['p_plan_ci95'])} | "
                     f"{'-' if t is None else t[0]} | {fmt(r['p_exec'], r['p_exec_ci95'])} | {pooled} | "
                     f"{'-' if t is None else f'{t[1]} ({t[2]})'} | "
                     f"{'-' if math.isnan(r['actions']) else format(r['actions'], '.1f')} |")
    lines += ["", "P_plan's interval: Wilson, over the plans. P_exec: the mean over planned policies of each one's "
              "success rate; its interval a percentile bootstrap over those policies (4,000 resamples, seed 0), which "
              "has no width when every policy scored the same; executions: every execution of the planned policies "
              "pooled, with its Wilson interval.", "",
              f"## The thesis's ordering: **{order['statement']}**", "",
              f"Every pair of rows whose thesis P_exec differ by at least {order['gap']}: our difference (the row "
              "higher in the thesis minus the lower), its 95% bootstrap interval, and the verdict (holds: above 0; "
              "reversed: below 0; not separated: contains 0; no policy: one of the rows planned none, so it has no "
              "P_exec to compare -- its P_plan says how it differs).", "",
              "| higher in the thesis | lower | thesis | ours | difference [95%] | verdict |",
              "|---|---|---|---|---|---|"]
    for p in order["pairs"]:
        ours = " / ".join("-" if v is None else f"{v:.2f}" for v in p["ours"])
        if p["difference_ci95"] is None:
            difference = "-"
        else:
            low, high = p["difference_ci95"]
            difference = f"{p['ours'][0] - p['ours'][1]:+.2f} [{low:+.2f}, {high:+.2f}]"
        lines.append(f"| {p['higher']} | {p['lower']} | {p['thesis'][0]} / {p['thesis'][1]} | {ours} | "
                     f"{difference} | {p['verdict']} |")
    counts = {v: sum(p["verdict"] == v for p in order["pairs"])
              for v in ("holds", "reversed", "not separated", "no policy")}
    lines += ["", f"{counts['holds']} pairs hold, {counts['reversed']} reversed, {counts['not separated']} not "
              f"separated, of {len(order['pairs']) - counts['no policy']} compared; {counts['no policy']} not "
              "compared (a row planned no policy)."]
    write_json(directory / "ordering.json", {"experiment": name, "policies": len(records), **order})
    return write_text(directory / "tables.md", "\n".join(lines) + "\n")


def _ompl(run: ReproductionRun, directory, plan_time: float) -> list:
    """The planning runs in OMPL's benchmark log and database: one planner configuration per row, the policy's
    goal probability as the run's ``goal probability``."""
    from pliant.api import PlannerRuns, ompl_database, read_jsonl, run_properties, write_ompl_log

    records, _ = read_jsonl(directory / "runs.jsonl")
    planners = []
    for variant in dict.fromkeys(r["variant"] for r in records):
        runs = []
        for r in (r for r in records if r["variant"] == variant):
            s = r.get("statistics", {})
            props = run_properties({"status": "solved" if r["planned"] else "timeout", "time": r["plan_seconds"],
                                    "cost": None, "nodes": s.get("nodes"), "iterations": s.get("iterations"),
                                    "time_to_first": s.get("time_to_first"), "seed": r["seed"]})
            props["goal probability REAL"] = s.get("best_probability")
            props["particles simulated INTEGER"] = s.get("particles_simulated")
            runs.append(props)
        planners.append(PlannerRuns(variant, {"planner": "belief"}, runs))
    if not planners:
        return []
    log = write_ompl_log(run.output / "benchmark.log", run.reproduction.name, planners, time_limit=plan_time,
                         total_time=sum(r["plan_seconds"] for r in records), setup=f"pliant belief-experiment "
                         f"{run.reproduction.name}")
    return [log, ompl_database(run.output / "benchmark.db", [log])]


def table_51(run: ReproductionRun) -> Outcome:
    """Table 5.1 (clustering methods)."""
    return _table(run)


def table_52(run: ReproductionRun) -> Outcome:
    """Table 5.2 (Simple RRT, Contact RRT, particles, noise)."""
    return _table(run)


def declarations() -> list:
    """The two reproductions, for the plugin's hook."""
    from pliant.api import CATALOGUE, Reproduction

    runners = {"table-5.1": "table_51", "table-5.2": "table_52"}
    return [Reproduction(name, CATALOGUE[name][0], f"pliant_belief.reproduce:{runner}", modes=MODES[name],
                         arguments="pliant_belief.plugin:table_arguments",
                         minutes=MINUTES[name]) for name, runner in runners.items()]
