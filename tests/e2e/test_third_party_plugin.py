"""A third-party plugin installed with pip is found through its entry point and used by name.

This installs docs/examples/pliant-example-plugin with pip (no dependencies fetched) into a directory of its own on
the ``PYTHONPATH`` of the ``pliant`` processes it then runs, as a user would: the test environment itself is left
alone, so that tests running beside this one (``make test`` runs two processes) never see the example appear or
vanish.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "docs" / "examples" / "pliant-example-plugin"


def _pip(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pip", "--disable-pip-version-check", "-q", *args],
                          capture_output=True, text=True, check=False)


#: where the example plugin is installed (set by the fixture): first on the PYTHONPATH of the pliant processes
_TARGET: list[Path] = []


def _pliant(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([*(str(t) for t in _TARGET), *filter(None, [env.get("PYTHONPATH")])])
    return subprocess.run([sys.executable, "-m", "pliant.cli", *args], capture_output=True, text=True, check=False,
                          cwd=ROOT, env=env)


@pytest.fixture(scope="module")
def example_plugin_installed(tmp_path_factory):
    target = tmp_path_factory.mktemp("site")
    done = _pip("install", "--no-deps", "--no-build-isolation", "--target", str(target), str(EXAMPLE))
    assert done.returncode == 0, done.stderr
    _TARGET[:] = [target]
    yield target
    _TARGET.clear()


def test_plugins_lists_the_example(example_plugin_installed):
    out = _pliant("plugins")
    assert out.returncode == 0, out.stderr
    assert "path-length" in out.stdout
    line = next(ln for ln in out.stdout.splitlines() if ln.startswith("example "))
    assert "pliant-example-plugin" in line and "loaded" in line


def test_pipeline_uses_the_example_by_name(example_plugin_installed, tmp_path):
    out = _pliant("run", "straight-demo", "--set", "metric=path-length", "--set", "metric.scale=1000",
                  "--output", str(tmp_path))
    assert out.returncode == 0, out.stderr
    run = json.loads((tmp_path / "run.json").read_text())
    result = json.loads((tmp_path / "result.json").read_text())
    configs = result["path"]["configurations"]
    import numpy as np

    q = np.asarray(configs)
    expected = float(np.sum(np.linalg.norm(np.diff(q, axis=0), axis=1))) * 1000
    assert run["metrics"]["length"] == pytest.approx(expected)
    assert run["metrics"]["waypoints"] == len(configs)
    assert "metric length" in (tmp_path / "report.md").read_text()


def test_unknown_component_names_the_alternatives(example_plugin_installed, tmp_path):
    out = _pliant("run", "straight-demo", "--set", "metric=path-lenght", "--output", str(tmp_path))
    assert out.returncode == 2
    assert "path-length" in out.stderr and "metric" in out.stderr
