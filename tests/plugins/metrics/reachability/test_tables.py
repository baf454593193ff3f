"""``pliant metric-table``: the thesis grid evaluated, resumable, summarised beside the thesis's numbers."""

import json

import numpy as np
import pytest
from pliant.errors import ConfigError
from pliant_reachability.tables import render, run_tables, summarise
from pliant_reachability.tasks import THESIS_P_EXEC, cells


@pytest.mark.slow
def test_quick_table_runs_every_cell_resumes_and_writes_its_report(tmp_path):
    lines = []
    summary = run_tables(["se2-through-passage"], runs=1, jobs=1, output=tmp_path, quick=True,
                         methods=["ground truth", "simulation-scaled"], echo=lines.append)
    directory = tmp_path / "metric-tables-quick"
    records = [json.loads(line) for line in (directory / "runs.jsonl").read_text().splitlines()]
    assert len(records) == 18 and {r["cell"] for r in records} == set(range(9))
    truth = [r for r in records if r["method"] == "ground truth"]
    assert all(r["world"] == "pymunk" and r["executions"] == 20 for r in truth)
    assert summary["se2-through-passage"]["simulation-scaled"]["vs_ground_truth"]["cells"] == 9
    row = summary["se2-through-passage"]["simulation-scaled"]
    assert all(0.0 <= c["p_exec"] <= 1.0 and c["runs"] == 1 for c in row["cells"])
    assert (directory / "se2-through-passage.png").stat().st_size > 10_000
    table = (directory / "tables.md").read_text()
    assert "(0.74)" in table                 # the thesis's ground truth beside ours
    # a second call finds everything on file and runs nothing
    lines.clear()
    run_tables(["se2-through-passage"], runs=1, jobs=1, output=tmp_path, quick=True,
               methods=["ground truth", "simulation-scaled"], echo=lines.append)
    assert "0 to go" in lines[0]
    # other settings on file: refused, naming the setting
    with pytest.raises(ConfigError, match="--options"):
        run_tables(["se2-through-passage"], runs=1, jobs=1, output=tmp_path, quick=True,
                   methods=["simulation-scaled"], options={"contact_horizon": 3}, echo=lines.append)


def test_summary_errors_against_the_simulation_baseline():
    records = []
    for cell in range(len(cells())):
        records.append({"task": "se2-through-passage", "method": "simulation", "cell": cell, "p_exec": 0.5,
                        "seconds": 1.0, "simulated_steps": 100})
        records.append({"task": "se2-through-passage", "method": "reachable-volume", "cell": cell,
                        "p_exec": 0.6 if cell < 3 else 0.48, "seconds": 0.5, "simulated_steps": 10})
    summary = summarise(records, ["se2-through-passage"], ["simulation", "reachable-volume"])
    row = summary["se2-through-passage"]["reachable-volume"]
    assert row["vs_simulation"]["mean"] == pytest.approx((3 * 0.1 + 6 * 0.02) / 9)
    assert row["vs_simulation"]["largest"] == pytest.approx(0.1)
    assert row["vs_simulation"]["overestimates"] == 3
    assert row["vs_ground_truth"]["mean"] is None            # no ground truth on file
    # the thesis's own metric against its ground truth, from its Table 6.2
    thesis = THESIS_P_EXEC["se2-through-passage"]
    expected = np.mean(np.abs(np.subtract(thesis["reachable-volume"], thesis["ground truth"])))
    assert row["thesis_vs_its_ground_truth"]["mean"] == pytest.approx(expected)
    text = render(summary)
    assert f"({THESIS_P_EXEC['se2-through-passage']['reachable-volume'][0]:.2f})" in text


@pytest.mark.parametrize("kwargs, field", [({"methods": ["nope"]}, "--methods"), ({"runs": 0}, "--runs")])
def test_bad_arguments_name_the_flag(tmp_path, kwargs, field):
    args = {"runs": 1, "jobs": 1, "output": tmp_path, **kwargs}
    with pytest.raises(ConfigError, match=field):
        run_tables(["se2-through-passage"], **args)
    with pytest.raises(ConfigError, match="TASK"):
        run_tables(["nope"], runs=1, jobs=1, output=tmp_path)
