"""The belief tables' 95% intervals and the verdict on the thesis's ordering (known answers, synthetic records)."""

import pytest
from pliant_belief.experiments import bootstrap_mean, wilson
from pliant_belief.reproduce import THESIS_51, ordering, write_tables


def test_wilson_interval_known_answers():
    assert wilson(10, 10) == pytest.approx([0.7225, 1.0], abs=1e-4)
    assert wilson(0, 10) == pytest.approx([0.0, 0.2775], abs=1e-4)
    assert wilson(15, 30) == pytest.approx([0.3315, 0.6685], abs=1e-4)
    assert wilson(0, 0) != wilson(0, 0)                    # nan: no trials


def test_bootstrap_interval_is_seeded_and_brackets_the_mean():
    values = [1.0, 0.5, 0.9, 0.0, 1.0, 0.8]
    low, high = bootstrap_mean(values)
    assert low < sum(values) / len(values) < high
    assert bootstrap_mean(values) == [low, high]
    assert bootstrap_mean([1.0] * 5) == [1.0, 1.0]


def records(label, rates, plans=10, executions=10):
    out = []
    for seed in range(plans):
        won = round(rates[seed % len(rates)] * executions)
        out.append({"variant": label, "seed": seed, "planned": True, "statistics": {}, "executions": {"default": [
            {"outcome": "success" if k < won else "failure", "actions": 5} for k in range(executions)]}})
    return out


def test_the_thesiss_ordering_holds_is_refuted_or_is_not_resolved():
    thesis = {"A": (1.0, 0.99, 0.02), "B": (1.0, 0.73, 0.4)}
    assert ordering(records("A", [1.0]) + records("B", [0.5, 0.6]), thesis)["statement"] == "holds"
    reversed_ = ordering(records("A", [0.4, 0.5]) + records("B", [1.0]), thesis)
    assert reversed_["statement"] == "refuted" and reversed_["pairs"][0]["verdict"] == "reversed"
    assert ordering(records("A", [1.0]) + records("B", [1.0]), thesis)["statement"] == "not resolved"


def unplanned(label, plans=10):
    return [{"variant": label, "seed": seed, "planned": False, "statistics": {}, "executions": {}}
            for seed in range(plans)]


def test_a_row_that_planned_no_policy_is_not_compared_and_leaves_the_statement_to_the_others(tmp_path):
    """Simple RRT in Table 5.2 plans nothing: it has no P_exec (a mean over planned policies), so its pairs are
    ``no policy``, not ``not separated``, and the tables show dashes, not nan."""
    import json

    thesis = {"A": (1.0, 0.99, 0.02), "B": (1.0, 0.73, 0.4), "Simple": (0.0, 0.0, 0.0)}
    result = ordering(records("A", [1.0]) + records("B", [0.5, 0.6]) + unplanned("Simple"), thesis)
    assert result["statement"] == "holds"
    verdicts = {(p["higher"], p["lower"]): (p["verdict"], p["ours"], p["difference_ci95"]) for p in result["pairs"]}
    assert verdicts[("A", "Simple")] == ("no policy", [1.0, None], None)
    assert verdicts[("B", "Simple")][0] == "no policy" and verdicts[("A", "B")][0] == "holds"
    lines = records("contact, gamma 0", [1.0]) + records("24 particles, gamma 0", [0.6]) + unplanned("simple, gamma 0")
    (tmp_path / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in lines))
    text = write_tables(tmp_path, "table-5.2").read_text()
    assert "nan" not in text
    assert "| simple, gamma 0 | 10 | 0.00 [0.00, 0.28] | 0 | - | - | 0 (0) | - |" in text
    assert "| contact, gamma 0 | simple, gamma 0 | 0.78 / 0 | 1.00 / - | - | no policy |" in text
    assert "1 pairs hold, 0 reversed, 0 not separated, of 1 compared; 2 not compared" in text


def test_tables_are_written_from_the_records(tmp_path):
    import json

    lines = records("WCR 0.75", [1.0]) + records("WCR 0.125", [0.5, 0.7])
    (tmp_path / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in lines))
    text = write_tables(tmp_path, "table-5.1").read_text()
    assert "| WCR 0.75 | 10 | 1.00 [0.72, 1.00] | 0.97 | 1.00 [1.00, 1.00] | 100/100 [0.96, 1.00]" in text
    assert "## The thesis's ordering: **holds**" in text
    assert json.loads((tmp_path / "ordering.json").read_text())["pairs"][0]["thesis"] == [
        THESIS_51["WCR 0.75"][1], THESIS_51["WCR 0.125"][1]]


def test_a_table_run_with_only_some_rows_keeps_the_headlines_of_those_rows_and_names_the_others():
    """``pliant experiment table-5.2 --ci --only "24 particles, gamma 0.125"`` once raised KeyError on a headline's
    row that --only had left out."""
    from pliant_belief.reproduce import HEADLINES, _headlines

    ours = {"24 particles, gamma 0.125": {"p_plan": 1.0, "p_exec": 0.75}}
    kept, left_out = _headlines("table-5.2", ours)
    assert [(h.name, h.ours) for h in kept] == [("24 particles, gamma 1/8: P_plan", 1.0),
                                                ("24 particles, gamma 1/8: P_exec", 0.75)]
    assert left_out == ["contact, gamma 0.125", "simple, gamma 0.125"]
    kept, left_out = _headlines("table-5.1", {})
    assert kept == [] and left_out == ["AC", "WCR 0.75"]
    every = {row: {"p_plan": 1.0, "p_exec": 1.0} for _, row, *_ in HEADLINES["table-5.1"]}
    assert len(_headlines("table-5.1", every)[0]) == 3 and _headlines("table-5.1", every)[1] == []
