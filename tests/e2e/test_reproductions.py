"""Every available reproduction in its smallest mode (``ci`` if it has one, else ``quick``): its headline numbers
must lie within their documented tolerances, so a change that breaks a thesis result fails the build.

A reproduction whose smallest mode is declared longer than ``CI_MINUTES`` is skipped (named in the skip reason)
unless ``PLIANT_REPRODUCE_ALL=1``: docs/experiments.md lists which.
"""

import os

import pytest
from pliant.experiments.reproduce import reproductions, run_reproduction

AVAILABLE = reproductions()
#: the longest smallest-mode CI runs by default (minutes, as declared on two idle cores)
CI_MINUTES = 5.0


@pytest.fixture(scope="module")
def output(tmp_path_factory):
    """One output directory for all of them, so reproductions that share records (tables 6.1 / 6.3 and 6.2 / 6.4
    read the same evaluations) run them once."""
    return tmp_path_factory.mktemp("reproduce")


#: reproductions that read another's records (run once, in the module's ``output``): kept on one pytest-xdist worker
#: with it, while the others spread over the workers
READS_RECORDS_OF = {"table-6.3": "table-6.1", "table-6.4": "table-6.2"}


NAMES = [pytest.param(n, marks=pytest.mark.xdist_group("reproduce-" + READS_RECORDS_OF.get(n, n)))
         for n in sorted(AVAILABLE)]


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_the_smallest_reproduction_keeps_its_headline_numbers(name, output):
    reproduction = AVAILABLE[name]
    mode = "ci" if "ci" in reproduction.modes else "quick"
    minutes = reproduction.minutes.get(mode, 0.0)
    if minutes > CI_MINUTES and not os.environ.get("PLIANT_REPRODUCE_ALL"):
        pytest.skip(f"{name} --{mode} takes about {minutes:g} min (> {CI_MINUTES:g}); PLIANT_REPRODUCE_ALL=1 runs it")
    outcome, directory = run_reproduction(name, mode=mode, output=output, echo=lambda _: None)
    assert (directory / "report.md").exists() and outcome.rows and outcome.headlines
    out = [(h.name, h.ours, (h.low, h.high)) for h in outcome.headlines if not h.ok]
    assert not out, f"{name} ({mode}): headline numbers out of range: {out}; see {directory / 'report.md'}"
