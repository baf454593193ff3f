"""The pliant command as a user runs it."""

from __future__ import annotations

import pytest
from pliant.cli import main


def test_help_teaches(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    for word in ("plugins", "scenes", "run", "bench", "experiment", "robot", "learn", "view", "examples:"):
        assert word in out


def test_plugins_and_options(capsys):
    assert main(["plugins"]) == 0
    out = capsys.readouterr().out
    assert "straight" in out and "voxel" in out and "loaded" in out
    assert main(["plugins", "--options", "planner", "astar"]) == 0
    out = capsys.readouterr().out
    assert "p " in out and "[0.0, 1.0]" in out


def test_scenes(capsys):
    assert main(["scenes"]) == 0
    assert "triple-wall" in capsys.readouterr().out
    assert main(["scenes", "triple-wall"]) == 0
    assert "(30, 66, 30)" in capsys.readouterr().out


def test_run_and_bad_override(tmp_path, capsys):
    assert main(["run", "straight-demo", "--set", "planner.step=0.01", "--output", str(tmp_path)]) == 0
    assert (tmp_path / "report.md").is_file()
    capsys.readouterr()
    assert main(["run", "straight-demo", "--set", "planner.step=-2", "--output", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "planner.step" in err[0]


def test_bench_lists(capsys):
    assert main(["bench"]) == 0
    assert "astar" in capsys.readouterr().out
