"""The swap matrix (issue 36 item 4): every bundled pipeline x every registered simulator x every robot that fits its
space runs to its documented outcome or is refused at build time with a one-line reason.

The cells are generated (:mod:`pliant.experiments.swap`): a new pipeline, simulator plugin or robot scene joins the
matrix, and this test fails until its expectations are regenerated.  The expectations (tests/e2e/swap_matrix.json)
and the table in docs/swap-matrix.md come from one command, run in the repository::

    python -m pliant.experiments.swap --write

Quick mode: each cell is built; the cells whose plan is given (waypoints) also execute, at most 30 s of simulated
time.  One test per pipeline, so that a changed outcome names its cells.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from pliant.experiments.swap import COMMAND, expectations, swap_matrix
from pliant.pipeline import available_pipelines

EXPECTED = json.loads((Path(__file__).with_name("swap_matrix.json")).read_text())["cells"]


def _of(pipeline: str, cells: dict) -> dict:
    return {label: value for label, value in cells.items() if label.split(" | ")[0] == pipeline}


def test_the_expectations_name_only_bundled_pipelines():
    stale = sorted({label.split(" | ")[0] for label in EXPECTED} - set(available_pipelines()))
    assert not stale, f"expectations for pipelines no longer bundled: {stale}; regenerate them with `{COMMAND}`"


@pytest.mark.parametrize("pipeline", available_pipelines())
def test_every_cell_has_its_documented_outcome(pipeline):
    got = expectations(swap_matrix([pipeline]))
    expected = _of(pipeline, EXPECTED)
    lines = []
    for label in sorted(set(got) | set(expected)):
        if got.get(label) != expected.get(label):
            lines.append(f"  {label}\n    documented: {expected.get(label, '(no such cell)')}\n"
                         f"    now:        {got.get(label, '(no such cell)')}")
    assert not lines, ("the swap matrix changed (if intended, regenerate the table and the expectations with "
                       f"`{COMMAND}`):\n" + "\n".join(lines))
    for label, value in got.items():          # a refusal is one line that names the file and field at fault
        if value["outcome"] == "refused":
            assert "\n" not in value["reason"] and ":" in value["reason"], label


def test_a_refusal_is_one_clear_line_and_anything_else_is_a_defect():
    from pliant.errors import PipelineError, PliantError
    from pliant.experiments.swap import _refusal

    clear = PipelineError("no such simulator", source="/home/u/pliant/scenes/pipelines/x.toml", field="simulator",
                          value="nope")
    assert _refusal(clear, "build") == ("refused", "pipelines/x.toml:simulator: no such simulator (got 'nope')")
    assert _refusal(PliantError("two\nlines", field="f"), "build")[0] == "defect"
    assert _refusal(PliantError("x" * 500, field="f"), "build")[0] == "defect"
    assert _refusal(PliantError("names nothing"), "build")[0] == "defect"
    assert _refusal(KeyError("joint"), "run") == ("defect", "KeyError at run: 'joint'")


def test_a_new_simulator_plugin_joins_the_matrix_without_a_list_to_edit():
    from pliant import registry
    from pliant.experiments.swap import cells, try_cell

    registry.register("simulator", "swap-test-sim", "no_such_module:Simulator", "a simulator that cannot load")
    try:
        new = [c for c in cells(["maze-slide"]) if c.simulator == "swap-test-sim"]
        assert [c.overrides for c in new] == [("simulator=swap-test-sim",)]
        result = try_cell(new[0])
        assert (result.outcome, result.stage) == ("refused", "build")
        assert "cannot load simulator 'swap-test-sim'" in result.reason and "\n" not in result.reason
    finally:
        registry.default_registry().unregister("simulator", "swap-test-sim")
