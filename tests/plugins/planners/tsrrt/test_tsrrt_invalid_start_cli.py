"""``pliant run`` on a TS-RRT pipeline whose start is invalid (objects overlapping, an object off the table): one
error line on stderr naming the objects, exit status 2 (bad input), refused before any model is learned."""

from __future__ import annotations

from pathlib import Path

import pytest
from pliant import cli

SCENES = Path(__file__).resolve().parents[4] / "scenes"
CAN = "position = [0.72, 0.62, 0.0]"


@pytest.mark.parametrize(("position", "named", "says"), [
    ("[0.30, 0.62, 0.0]", ("book-1", "can-1"), "overlap"),       # the can inside the book
    ("[0.97, 0.62, 0.0]", ("can-1",), "off the table"),          # the can over the table's right edge
])
def test_an_invalid_start_names_the_objects_on_stderr_with_exit_2(capsys, tmp_path, position, named, says):
    scene = (SCENES / "tsrrt-table.toml").read_text()
    assert CAN in scene
    (tmp_path / "scene.toml").write_text(scene.replace(CAN, f"position = {position}"))
    pipeline = (SCENES / "pipelines" / "tsrrt-demo.toml").read_text()
    scene_line = f'scene = "{tmp_path / "scene.toml"}"'
    (tmp_path / "run.toml").write_text(pipeline.replace('scene = "tsrrt-table"', scene_line))
    code = cli.main(["run", str(tmp_path / "run.toml"), "--set", "planner.start=scene",
                     "--output", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    line = err.splitlines()[-1]
    assert line.startswith("error:") and says in line
    for name in named:
        assert f"'{name}'" in line
    assert not (tmp_path / "out" / "learned.json").exists()
