"""``pliant metric-select``: candidates planned, scored by the metric, best and worst executed, report written."""

import json

import pytest
from pliant.errors import ConfigError, PipelineError
from pliant_reachability.selection import select, verdict


@pytest.mark.slow
def test_candidates_are_scored_and_the_extremes_executed(tmp_path):
    lines = []
    report = select("passage-select", candidates=3, executions=2, output=tmp_path, echo=lines.append,
                    overrides=["planner.max_step=3.0", "metric.particles=200", "metric.labelled=50"])
    scored = [r for r in report["candidates"] if r.get("path")]
    assert len(scored) >= 2
    assert all(0.0 <= r["p_exec"] <= 1.0 for r in scored)
    best = max(scored, key=lambda r: r["p_exec"])
    worst = min(scored, key=lambda r: r["p_exec"])
    assert report["best"] == best["seed"] and report["worst"] == worst["seed"]
    assert best["executed"] == 2 and worst["executed"] == 2
    assert report["verdict"] == verdict(best, worst)
    saved = json.loads((tmp_path / "passage-select-select" / "selection.json").read_text())
    assert saved["best"] == report["best"]
    assert "verdict: " in (tmp_path / "passage-select-select" / "selection.md").read_text()


def test_bad_arguments_and_pipelines_are_clear_errors(tmp_path):
    with pytest.raises(ConfigError, match="--candidates"):
        select("passage-select", candidates=0, executions=1, output=tmp_path)
    with pytest.raises(PipelineError, match="metric"):
        select("maze-slide", candidates=2, executions=1, output=tmp_path)


@pytest.mark.parametrize(("best", "worst", "expected"), [
    ((0.90, 0.9), (0.88, 0.5), "metric does not separate"),
    ((0.90, 0.7), (0.50, 0.7), "execution does not separate"),
    ((0.90, 0.9), (0.50, 0.6), "matched"),
    ((0.90, 0.4), (0.50, 0.6), "reversed"),
])
def test_the_verdict_counts_only_decisions_the_metric_made(best, worst, expected):
    as_row = lambda pair: {"p_exec": pair[0], "success": pair[1]}  # noqa: E731
    assert verdict(as_row(best), as_row(worst)) == expected
