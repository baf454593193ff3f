"""pliant reproduce: the catalogue, the plugins' reproductions, reports and headline checks."""

import json
from pathlib import Path

import pytest
from pliant.cli import main
from pliant.errors import ConfigError
from pliant.experiments.reproduce import (
    CATALOGUE,
    Headline,
    Outcome,
    Reproduction,
    Row,
    listing,
    render,
    reproductions,
    run_reproduction,
)


def test_the_listing_has_every_catalogue_entry_available_or_waiting_with_what_it_waits_for():
    rows = {r["name"]: r for r in listing()}
    assert set(CATALOGUE) <= set(rows)
    assert rows["figure-3.5"]["status"] == "available" and rows["figure-3.5"]["plugin"] == "pliant_astar"
    for r in rows.values():
        assert r["status"] in ("available", "waiting")
        if r["status"] == "waiting":
            assert r["waits_for"] and "pliant_" in r["waits_for"]


def test_every_declared_reproduction_names_a_loadable_runner_and_known_modes():
    import importlib

    for name, r in reproductions().items():
        module, _, function = r.runner.partition(":")
        assert callable(getattr(importlib.import_module(module), function)), name
        assert set(r.modes) <= {"full", "quick", "ci"} and "quick" in r.modes, name


def test_rows_mark_differences_beyond_tolerance_and_headlines_check_their_range():
    assert Row("x", 61, 61.4, tolerance=1.0).marked is False
    assert Row("x", 683, 600.0, tolerance=34.0).marked is True
    assert Row("x", None, 3.0).marked is False and Row("x", "n/a", 3.0, tolerance=1).difference is None
    assert Row("x", 0.0, float("nan"), tolerance=0.1).marked is False            # nothing to compare
    assert Headline("h", 1.0, 0.5, 1.5).ok and not Headline("h", float("nan"), 0, 1).ok
    outcome = Outcome([Row("a", 1.0, 2.0, tolerance=0.5)], [Headline("h", 2.0, 0.0, 1.0, 1.0)], {"k": 1})
    text = render(Reproduction("t", "T", "m:f", {"quick": "q"}), "quick", outcome, {"pliant": "x"}, 1.0, Path("."))
    assert "**+1**" in text and "OUT OF RANGE" in text and "k = 1" in text


def test_figure_35_writes_its_report_and_its_headlines_hold(tmp_path):
    outcome, directory = run_reproduction("figure-3.5", mode="ci", output=tmp_path, echo=lambda _: None)
    assert all(h.ok for h in outcome.headlines), [(h.name, h.ours) for h in outcome.headlines]
    report = (directory / "report.md").read_text()
    assert "| highest deformation: length | 61 voxels |" in report and "## Versions" in report
    data = json.loads((directory / "outcome.json").read_text())
    assert data["mode"] == "ci" and data["settings"]["values"] == 21 and data["versions"]["pliant"]
    assert (directory / "run" / "result.json").exists()


def test_unknown_waiting_and_missing_modes_are_errors_naming_the_field(tmp_path):
    with pytest.raises(ConfigError, match=r"NAME.*unknown reproduction"):
        run_reproduction("table-9.9", output=tmp_path)
    waiting = [r["name"] for r in listing() if r["status"] == "waiting"]
    if waiting:
        with pytest.raises(ConfigError, match="waits for"):
            run_reproduction(waiting[0], output=tmp_path)
    with pytest.raises(ConfigError, match="mode"):
        run_reproduction("figure-3.5", mode="fast", output=tmp_path)


def test_the_command_lists_and_exits_3_when_a_headline_is_out_of_range(tmp_path, capsys, monkeypatch):
    assert main(["experiment", "list"]) == 0
    assert "figure-3.5" in capsys.readouterr().out
    import pliant_astar.reproduce as module

    original = module.figure_35

    def broken(run):
        outcome = original(run)
        outcome.headlines[0].ours = 10.0                       # a change that breaks a result
        return outcome

    monkeypatch.setattr(module, "figure_35", broken)
    assert main(["experiment", "figure-3.5", "--ci", "--output", str(tmp_path)]) == 3
    assert "out of range" in capsys.readouterr().err


@pytest.mark.parametrize("output", ["", "  ", "file", "file/below", "nul\x00byte"])
def test_an_output_that_is_no_directory_is_refused_before_anything_is_written(tmp_path, monkeypatch, capsys, output):
    """``--output ""`` once wrote the report into the current directory and exited 0."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("kept")
    assert main(["experiment", "figure-3.5", "--ci", "--output", output]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --output:") and "\n" not in err and repr(output) in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"] and (tmp_path / "file").read_text() == "kept"
    with pytest.raises(ConfigError, match="--output"):
        run_reproduction("figure-3.5", mode="ci", output=tmp_path / "file")


def test_the_first_line_shows_the_own_options_that_have_a_value_as_typed():
    from pliant.experiments.reproduce import _given

    assert _given(None) == "" and _given({"plans": None, "straight": False, "only": []}) == ""
    assert _given({"plans": 2, "straight": True, "only": ["24 particles, gamma 0", "contact"], "max_time": 1.5}) == \
        "; with --plans 2 --straight --only '24 particles, gamma 0' contact --max-time 1.5"
