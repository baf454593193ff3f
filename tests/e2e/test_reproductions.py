"""Every available reproduction in its smallest mode (``ci`` if it has one, else ``quick``): its headline numbers
must lie within their documented tolerances, so a change that breaks a thesis result fails the build."""

import pytest
from pliant.reproduce import reproductions, run_reproduction

AVAILABLE = reproductions()


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(AVAILABLE))
def test_the_smallest_reproduction_keeps_its_headline_numbers(name, tmp_path):
    mode = "ci" if "ci" in AVAILABLE[name].modes else "quick"
    outcome, directory = run_reproduction(name, mode=mode, output=tmp_path, echo=lambda _: None)
    assert (directory / "report.md").exists() and outcome.rows and outcome.headlines
    out = [(h.name, h.ours, (h.low, h.high)) for h in outcome.headlines if not h.ok]
    assert not out, f"{name} ({mode}): headline numbers out of range: {out}; see {directory / 'report.md'}"
