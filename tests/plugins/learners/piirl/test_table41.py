"""Table 4.1's bookkeeping (pliant_piirl.experiments): budgets checked up front, per-plan cost ratios."""

import json

import pytest
from pliant.errors import ConfigError
from pliant_piirl.experiments import TABLE_FULL, TABLE_QUICK, render_table41, run_table41, write_table41


def test_budgets_are_counts_and_bad_ones_fail_before_any_work(tmp_path):
    assert TABLE_FULL["max_iterations"] and TABLE_QUICK["max_iterations"]          # never a time budget by default
    assert TABLE_FULL["refine"] == TABLE_QUICK["refine"] > 0
    with pytest.raises(ConfigError, match="exactly one budget"):
        run_table41(plans=1, max_time=None, max_iterations=None, jobs=1, output=tmp_path)
    with pytest.raises(ConfigError, match="--refine"):
        run_table41(plans=1, max_time=None, max_iterations=10, jobs=1, output=tmp_path, refine=-1)
    assert not any(tmp_path.iterdir())


def test_the_table_gives_each_plans_cost_over_its_demonstrations_in_true_and_recovered_units(tmp_path):
    zero = dict.fromkeys(["L1", "L2", "M1", "M2", "H1", "H2"], 0.0)
    recovered = {**dict.fromkeys(zero, 0.1), "H1": 0.4}
    shown = {**zero, "L1": 100.0, "H1": 2.0}          # true cost 0.2 * 100 + 0.8 * 2 = 21.6; H1 under 10% of it
    plans = [{**zero, "L1": 90.0, "H1": 2.0},                         # 19.6: cheaper, the same class
             {**zero, "L1": 80.0, "H1": 10.0},                        # 24: costlier, H1 a third of it but L the most
             {**zero, "L1": 10.0, "H1": 20.0}]                        # 18: cheaper, but H takes the most (16 of 18)
    records = [{"task": 0, "plan": k, "objects": ["H1", "L1"], "status": "solved", "demonstrated": shown,
                "planned": p, "planned_cost": 0.0, "start": "straight" if k else "rrtstar"}
               for k, p in enumerate(plans)]
    summary = write_table41(tmp_path, {"sensitivities": recovered}, records)
    row = summary["rows"][0]
    assert row["ratio_true"] == pytest.approx([19.6 / 21.6, 24 / 21.6, 18 / 21.6])
    assert row["ratio_recovered"] == pytest.approx([9.8 / 10.8, 12 / 10.8, 9 / 10.8])
    assert row["no_costlier"] == 2
    assert row["same_objects"] == 2 and row["same_share"] == 1            # main class: plans 0, 1; > 10%: plan 0
    assert row["starts"] == ["rrtstar", "straight", "straight"]
    assert summary["tasks_same_objects"] == 1 and summary["tasks_same_share"] == 0
    assert summary["plans_no_costlier"] == 2 and summary["plans_solved"] == 3
    assert summary["ratio_true"]["median"] == pytest.approx(19.6 / 21.6)
    assert summary["references"] == {}                                     # none on file
    assert json.loads((tmp_path / "summary.json").read_text())["rows"][0]["ratio_true"] == row["ratio_true"]
    text = render_table41(summary)
    assert "0.91 1.11 0.83" in text and "2 of 3 plans" in text and "rrtstar straight straight" in text


def test_reference_paths_on_file_are_scored_like_the_plans(tmp_path):
    zero = dict.fromkeys(["L1", "L2", "M1", "M2", "H1", "H2"], 0.0)
    shown = {**zero, "L1": 100.0, "H1": 2.0}                          # 21.6, L the main class
    references = {"true": [{"task": 0, "deformation": {**zero, "L1": 95.0, "H1": 3.0}}],      # 21.4
                  "uniform": [{"task": 0, "deformation": {**zero, "L1": 20.0, "H1": 30.0}},   # 28, H the main class
                              {"task": 5, "deformation": {**zero, "L1": 1.0}}]}               # a task not planned
    (tmp_path / "references.json").write_text(json.dumps(references))
    records = [{"task": 0, "plan": 0, "objects": ["H1", "L1"], "status": "solved", "demonstrated": shown,
                "planned": shown, "planned_cost": 0.0}]
    refs = write_table41(tmp_path, {"sensitivities": dict.fromkeys(zero, 1.0)}, records)["references"]
    # H1 takes 11% of the reference's cost and 7% of the demonstration's: the 10% count sees different classes
    assert refs["true"] == {"tasks": 1, "same_objects": 1, "same_share": 0, "no_costlier": 1,
                            "ratio_true": [pytest.approx(21.4 / 21.6)]}
    assert refs["uniform"]["tasks"] == 1 and refs["uniform"]["same_objects"] == 0
    assert refs["uniform"]["no_costlier"] == 0 and refs["uniform"]["same_share"] == 0
