"""``pliant experiment metric-select``: does the metric change decisions?  Plan several candidate paths, score each
with the pipeline's metric, execute the best and the worst (or all) in the pipeline's execution world, and report
whether the metric's ranking matched execution success (issue: "a metric is only worth its cost if it changes
decisions").

Candidates are the pipeline's runs with seeds ``0 .. candidates - 1``: candidate ``s`` is planned, scored and
executed with run ``s``'s planning, metrics and execution streams (:mod:`pliant.seeds`); executions start where the
metric assumes the robot is when the path begins (for the ch. 6 metrics: anywhere free within ``epsilon_reached`` of
the first waypoint) and follow the path with the pipeline's controller.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from pliant.api import ConfigError, PipelineError, write_json, write_text


def select(pipeline_name: str, *, candidates: int, executions: int, execute_all: bool = False,
           overrides: list[str] | None = None, output: Path | None = None, echo=print) -> dict:
    """Run the selection experiment; returns (and writes, as ``selection.json`` and ``selection.md``) its report."""
    from pliant.api import Pipeline, PlanningProblem, safe_name, stream
    from pliant.api import execute_path as execute

    for key, value in (("--candidates", candidates), ("--executions", executions)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ConfigError("must be a positive integer", field=key, value=value)
    pipeline = Pipeline.from_file(pipeline_name, overrides or [])
    for kind in ("planner", "metric", "controller"):
        if kind not in pipeline.components:
            raise PipelineError(f"metric-select needs a [{kind}] in the pipeline", source=pipeline.source,
                                field=kind)
    directory = Path(output or "out") / f"{safe_name(pipeline.name)}-select"
    directory.mkdir(parents=True, exist_ok=True)
    context = pipeline.build()
    world = pipeline.execution_world(context)
    planner, metric = context.extras["planner"], context.extras["metric"]
    problem = PlanningProblem.from_context(context, budget=pipeline.budget)      # the pipeline's [planning] budget
    settings = pipeline.execution
    rows = []
    for seed in range(candidates):
        t0 = time.perf_counter()
        # candidate k is the run of seed k: its stages draw from that seed's streams (pliant.seeds), as
        # `pliant run PIPELINE --set seed=k` does
        result = planner.plan(problem, stream(seed, "planning"))
        plan_seconds = time.perf_counter() - t0
        if result.path is None:
            echo(f"candidate {seed}: no path ({result.status.value})")
            rows.append({"seed": seed, "path": None})
            continue
        t0 = time.perf_counter()
        scores = metric.evaluate(result.path, problem, stream(seed, "metrics"))
        rows.append({"seed": seed, "path": result.path.to_dict(), "waypoints": len(result.path),
                     "length": float(problem.space.path_length(result.path.configurations)),
                     "plan_seconds": plan_seconds, "metric_seconds": time.perf_counter() - t0, **scores})
        echo(f"candidate {seed}: {len(result.path)} waypoints, P_exec {scores['p_exec']:.3f}")
    scored = sorted((r for r in rows if r.get("path")), key=lambda r: r["p_exec"])
    if len(scored) < 2:
        raise PipelineError("fewer than two candidates found a path: nothing to choose between",
                            source=pipeline.source, field="planner", value=len(scored))
    chosen = scored if execute_all else [scored[0], scored[-1]]
    from pliant.api import Path as PlannedPath

    for row in chosen:
        path = PlannedPath.from_dict(row["path"])
        outcomes = []
        rng = stream(row["seed"], "execution")
        starts = _starts(metric, path, rng, executions)
        for k in range(executions):
            waypoints = path.configurations.copy()
            waypoints[0] = starts[k]
            record = execute(world, context.controller, PlannedPath(waypoints), rng, period=settings["period"],
                             time_limit=settings["time_limit"], world_name=pipeline.world_spec().name)
            outcomes.append(record.outcome)
        row["executed"] = executions
        row["outcomes"] = {o: outcomes.count(o) for o in sorted(set(outcomes))}
        row["success"] = outcomes.count("reached") / executions
        echo(f"candidate {row['seed']} (P_exec {row['p_exec']:.3f}): {outcomes.count('reached')}/{executions} "
             f"executions reached ({', '.join(f'{k} {v}' for k, v in row['outcomes'].items())})")
    best, worst = scored[-1], scored[0]
    executed = [r for r in scored if "success" in r]
    ranks = None
    metric_scores, successes = ([r[key] for r in executed] for key in ("p_exec", "success"))
    if len(executed) >= 3 and np.ptp(metric_scores) > 0 and np.ptp(successes) > 0:
        from scipy.stats import spearmanr

        ranks = float(spearmanr(metric_scores, successes).statistic)
    report = {"pipeline": pipeline.name, "world": pipeline.world_spec().name, "candidates": rows,
              "best": best["seed"], "worst": worst["seed"],
              "best_success": best["success"], "worst_success": worst["success"],
              "verdict": verdict(best, worst), "spearman": ranks}
    write_json(directory / "selection.json", report)
    write_text(directory / "selection.md", render(report))
    return report


#: the metric must rate the best candidate this much above the worst before its choice counts as a decision
#: (the issue's accuracy tolerance: the metric is only trusted to +-0.05 of the simulation it estimates)
SEPARATION = 0.05


def verdict(best: dict, worst: dict) -> str:
    """Did the metric's choice matter?  ``"metric does not separate"`` when it rates best and worst within
    :data:`SEPARATION`; ``"execution does not separate"`` when both succeeded equally often; else ``"matched"``
    (the metric's best succeeded more often) or ``"reversed"``."""
    if best["p_exec"] - worst["p_exec"] <= SEPARATION:
        return "metric does not separate"
    if best["success"] == worst["success"]:
        return "execution does not separate"
    return "matched" if best["success"] > worst["success"] else "reversed"


def _starts(metric, path, rng: np.random.Generator, n: int) -> np.ndarray:
    """Where the executions start: as the metric assumes, uniformly in the free part of the ``epsilon_reached``
    ball around the first waypoint (the ch. 6 metrics); exactly at it for a metric without a start distribution."""
    volumes = getattr(metric, "volumes", None)
    starts = getattr(metric, "starts", None)
    if callable(volumes) and callable(starts):
        return starts(volumes(path.configurations[0], path.configurations[1]), rng, n)
    return np.repeat(path.configurations[:1], n, axis=0)


def render(report: dict) -> str:
    """The report of :func:`select` as Markdown: the candidates by the metric's P_exec with their executions, the best
    and the worst with their success rates, the verdict and the Spearman rank correlation."""
    lines = [f"# {report['pipeline']}: candidates scored by the metric, executed in {report['world']}", "",
             "| seed | waypoints | length | metric P_exec | executions | success | outcomes |",
             "|---|---|---|---|---|---|---|"]
    for r in sorted((r for r in report["candidates"] if r.get("path")), key=lambda r: -r["p_exec"]):
        success = f"{r['success']:.2f}" if "success" in r else "-"
        lines.append(f"| {r['seed']} | {r['waypoints']} | {r['length']:.3f} | {r['p_exec']:.3f} | "
                     f"{r.get('executed', '-')} | {success} | "
                     f"{', '.join(f'{k} {v}' for k, v in r.get('outcomes', {}).items()) or '-'} |")
    lines += ["", f"best by the metric: seed {report['best']}, success {report['best_success']:.2f}; worst: seed "
              f"{report['worst']}, success {report['worst_success']:.2f}; verdict: {report['verdict']}"]
    if report["spearman"] is not None:
        lines.append(f"Spearman rank correlation of metric and success over the executed candidates: "
                     f"{report['spearman']:.2f}")
    else:
        lines.append("Spearman rank correlation: undefined (fewer than three executed candidates, or the metric "
                     "or the success rate is the same for all)")
    return "\n".join(lines) + "\n"
