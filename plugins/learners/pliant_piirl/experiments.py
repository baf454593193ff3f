"""``pliant learn-active``: thesis 4.4.1-4.4.2 on the hollow cube, as seeded, resumable, parallel trials.

Each trial runs the ``active-piirl`` learner with its own seed: Algorithm 2 asks for demonstrations, the
simulated expert shows them, PIIRL recovers the sensitivities.  ``--all-pairs`` asks for every adjacent pair
instead (the chapter's conservative 12 demonstrations, the first part of Table 4.1).  Every trial is one record
in ``runs.jsonl``, written as it finishes; ``summary.json`` and ``report.md`` hold the counts of demonstrations,
whether the low < medium < high order was recovered, the recovered values mean [std] per object and the thesis's
numbers beside them.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from pliant.errors import ConfigError
from pliant.experiment import check_settings, open_log, run_tasks
from pliant.files import write_json, write_text

SCENE = "hollow-cube"
#: thesis 4.4.2: 15 trials of active learning; 10 demonstrations in 14, 8 in 1; recovered mean [std]
THESIS_ACTIVE = {"trials": 15, "demonstrations": {10: 14, 8: 1},
                 "sensitivities": {"L1": (0.100, 0.0), "L2": (0.101, 0.0002), "M1": (2.858, 0.012),
                                   "M2": (8.630, 0.071), "H1": (984.12, 29.272), "H2": (999.509, 0.165)}}
#: thesis 4.4.1: recovered from all 12 demonstrations
THESIS_ALL_PAIRS = {"L1": 0.10004, "L2": 0.10092, "M1": 2.8523, "M2": 8.5683, "H1": 958.92, "H2": 999.51}
#: --quick: CI-sized (a few minutes on two cores)
QUICK = {"trials": 2, "options": {"samples": 30, "grid": 11, "refine": 1}}


def run_trials(*, trials: int, jobs: int, output: Path, all_pairs: bool = False, quick: bool = False,
               fresh: bool = False, options: dict | None = None, echo=print) -> dict:
    """Run (or resume) ``trials`` seeded trials; returns the summary (also ``summary.json`` and ``report.md``)."""
    for key, value in (("--trials", trials), ("--jobs", jobs)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ConfigError("must be a positive integer", field=key, value=value)
    options = {**(QUICK["options"] if quick else {}), **(options or {})}
    _learner(options)                                       # bad options: an error now, not in every worker
    mode = "all-pairs" if all_pairs else "active"
    directory = Path(output) / f"learn-{mode}{'-quick' if quick else ''}"
    log, records = open_log(directory, "--output", echo)
    check_settings(directory, {"options": options, "mode": mode}, ["options", "mode"], replace=fresh or not records)
    if fresh:
        from pliant.files import rewrite_jsonl

        records.clear()
        rewrite_jsonl(log, records)
    done = {r["trial"] for r in records}
    todo = [(trial, mode, options) for trial in range(trials) if trial not in done]
    echo(f"learn {mode}: {len(records)} trials on file, {len(todo)} to go, {jobs} at a time")

    def describe(r: dict) -> str:
        values = " ".join(f"{k} {v:.3g}" for k, v in r["sensitivities"].items())
        return (f"trial {r['trial']}: {r['demonstrations']} demonstrations, order "
                f"{'right' if r['order_correct'] else 'WRONG'}: {values} ({r['seconds']:.0f} s)")

    def finish() -> dict:
        return write_summary(directory, [r for r in records if r["trial"] < trials], mode)

    run_tasks(_trial, todo, jobs=jobs, log=log, records=records, describe=describe, on_interrupt=finish, echo=echo)
    return finish()


def _learner(options: dict, name: str = "active-piirl"):
    import pliant
    from pliant.interfaces import Context

    context = Context(scene=pliant.load_scene(SCENE))
    context.robot = pliant.registry.create("robot", "rigid", context)
    return pliant.registry.create("learner", name, context, **options)


def _trial(trial: int, mode: str, options: dict) -> dict:
    from pliant_piirl.features import true_sensitivities
    from pliant_piirl.tasks import rotation_onto

    started = time.perf_counter()
    learner = _learner(options)
    rng = np.random.default_rng(trial)
    if mode == "all-pairs":
        adjacency = learner.tasks.adjacency()
        pairs = sorted({tuple(sorted((a, b))) for a in adjacency for b in adjacency[a]})
        shown = [learner.expert.demonstrate(
            learner.tasks.generate_task(a, b, rng, np.asarray(learner.options.tip), rotation_onto), rng)
            for a, b in pairs]
        result = learner.fit(shown, rng)
        result["asked"] = [list(p) for p in pairs]
    else:
        result = learner.fit(None, rng)
    truth = true_sensitivities(learner.scene)
    learned = result["sensitivities"]
    order = all(learned[a] < learned[b] for a in truth for b in truth if truth[a] < truth[b])
    names = result["features"]["names"]
    demonstrated = np.array(result["features"]["demonstrations"])
    return {"trial": trial, "mode": mode, "demonstrations": len(result["demonstrations"]), "asked": result["asked"],
            "preferences": result.get("preferences"), "sensitivities": learned, "order_correct": bool(order),
            "true_cost": (demonstrated @ np.array([truth[n] for n in names])).tolist(),
            "features": result["features"], "replaced": result["replaced"], "used": result["used"],
            "recovery_seconds": learner.timing["recovery_seconds"], "fit_seconds": learner.timing["seconds"],
            "seconds": time.perf_counter() - started}


def summarise(records: list[dict], mode: str) -> dict:
    """Counts of demonstrations, order correctness, recovered values mean [std] per object, with the thesis's."""
    names = list(records[0]["sensitivities"]) if records else []
    values = {n: [r["sensitivities"][n] for r in records] for n in names}
    counts: dict[int, int] = {}
    for r in records:
        counts[r["demonstrations"]] = counts.get(r["demonstrations"], 0) + 1
    return {"mode": mode, "trials": len(records), "demonstrations": dict(sorted(counts.items())),
            "at_most_10": sum(r["demonstrations"] <= 10 for r in records),
            "order_correct": sum(r["order_correct"] for r in records),
            "sensitivities": {n: {"mean": float(np.mean(v)), "std": float(np.std(v))} for n, v in values.items()},
            "recovery_seconds": {"mean": float(np.mean([r["recovery_seconds"] for r in records])) if records else None,
                                 "max": float(np.max([r["recovery_seconds"] for r in records])) if records else None},
            "trial_seconds": {"mean": float(np.mean([r["seconds"] for r in records])) if records else None,
                              "max": float(np.max([r["seconds"] for r in records])) if records else None},
            "thesis": THESIS_ACTIVE if mode == "active" else {"sensitivities": THESIS_ALL_PAIRS}}


def render(summary: dict) -> str:
    """The report as Markdown."""
    lines = [f"# Learning sensitivities on {SCENE}: {summary['mode']}, {summary['trials']} trials", ""]
    if summary["mode"] == "active":
        thesis = ", ".join(f"{k} in {v}" for k, v in THESIS_ACTIVE["demonstrations"].items())
        ours = ", ".join(f"{k} in {v}" for k, v in summary["demonstrations"].items())
        lines += [f"Demonstrations asked for: {ours} (thesis: {thesis} of 15); at most 10 in "
                  f"{summary['at_most_10']} of {summary['trials']}.", ""]
    lines += [f"Low < medium < high recovered in {summary['order_correct']} of {summary['trials']} trials.", "",
              "| object | recovered mean [std] | thesis |", "|---|---|---|"]
    for name, stats in summary["sensitivities"].items():
        ref = summary["thesis"]["sensitivities"].get(name)
        shown = (f"{ref[0]:.4g} [{ref[1]:.3g}]" if isinstance(ref, tuple | list) else f"{ref:.5g}") if ref else "-"
        lines.append(f"| {name} | {stats['mean']:.4g} [{stats['std']:.3g}] | {shown} |")
    rs, ts = summary["recovery_seconds"], summary["trial_seconds"]
    if rs["mean"] is not None:
        lines += ["", f"Eq. 4.1's solve: {rs['mean'] * 1000:.1f} ms mean, {rs['max'] * 1000:.1f} ms at most.  Whole "
                  f"trial (asking, demonstrating, sampling, features, solve): {ts['mean']:.0f} s mean, "
                  f"{ts['max']:.0f} s at most, one core."]
    return "\n".join(lines) + "\n"


def write_summary(directory: Path, records: list[dict], mode: str) -> dict:
    summary = summarise(sorted(records, key=lambda r: r["trial"]), mode)
    write_json(directory / "summary.json", summary)
    write_text(directory / "report.md", render(summary))
    return summary
