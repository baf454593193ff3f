"""Hostile data at the command line (issue 31 item 8): TS-RRT scenes whose objects overlap, leave the table or are
rotated out of the plane; PIIRL demonstrations a million metres away or naming objects the scene lacks, and ``lower``
above ``upper``; a metric asked to score waypoints out of the workspace or without a problem.  Each is one line
``error: ...`` naming the field and the value, exit status 2, within seconds, and no half-written file: no plan, no
learned values, no demonstrations file; what the run folder holds (run.json, report.md) is whole and says "error"."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pliant import cli
from pliant.errors import PliantError
from pliant.scene import resolve_scene_path


def _one_line_error(capsys, argv) -> str:
    code = cli.main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, f"{argv}: exit {code}, stderr {err!r}"
    lines = [line for line in err.splitlines() if line.startswith("error: ")]
    assert len(lines) == 1 and "Traceback" not in err, f"{argv}: {err!r}"
    return lines[0]


def _nothing_half_written(folder) -> None:
    """No plan, no learned values; whatever the run left is complete JSON reporting the error."""
    if not folder.exists():
        return
    names = {p.name for p in folder.iterdir()}
    assert not names & {"result.json", "learned.json", "execution.json"}, names
    if "run.json" in names:
        assert json.loads((folder / "run.json").read_text())["outcome"] == "error"


# --- TS-RRT scenes --------------------------------------------------------------------------------------------------

BLOCK_AT = "position = [0.8, 0.18, 0.0]"
BLOCK_TURN = "orientation = [0.0, 0.0, -0.173648, 0.984808]"

TSRRT = {
    "overlap": ({BLOCK_AT: "position = [0.26, 0.58, 0.0]"},
                "objects[1].position: objects 'book-1' and 'block-1' overlap by"),
    "off the table": ({BLOCK_AT: "position = [1.12, 0.18, 0.0]"},
                      "objects[1].position: object 'block-1' reaches"),
    "movable rotated out of the plane": ({BLOCK_TURN: "orientation = [0.707107, 0.0, 0.0, 0.707107]"},
                                         "objects[1].orientation: movable object 'block-1'"),
}


@pytest.mark.parametrize("case", list(TSRRT))
def test_a_hostile_tsrrt_scene_is_one_error_line_naming_the_object(capsys, tmp_path, monkeypatch, case):
    monkeypatch.chdir(tmp_path)
    replace, expected = TSRRT[case]
    text = resolve_scene_path("tsrrt-table").read_text()
    for old, new in replace.items():
        text = text.replace(old, new)
    (tmp_path / "scene.toml").write_text(text)
    (tmp_path / "run.toml").write_text(
        'name = "hostile"\nscene = "scene.toml"\n[simulator]\nname = "pymunk"\n[controller]\nname = "contact"\n'
        '[learner]\nname = "push-models"\n[planner]\nname = "tsrrt"\nstart = "scene"\n')
    line = _one_line_error(capsys, ["run", str(tmp_path / "run.toml")])
    assert expected in line, line
    _nothing_half_written(tmp_path / "out" / "hostile")


def test_a_fixed_obstacle_rotated_out_of_the_plane_is_one_error_line(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    text = resolve_scene_path("tsrrt-obstacles").read_text().replace(
        'size = [0.1, 0.1, 0.04]\nposition = [0.5, 0.4, 0.0]',
        'size = [0.1, 0.1, 0.04]\nposition = [0.5, 0.4, 0.0]\norientation = [0.0, 0.382683, 0.0, 0.92388]')
    (tmp_path / "scene.toml").write_text(text)
    (tmp_path / "run.toml").write_text('name = "hostile"\nscene = "scene.toml"\n[simulator]\nname = "pymunk"\n'
                                       '[planner]\nname = "tsrrt"\n')
    line = _one_line_error(capsys, ["run", str(tmp_path / "run.toml")])
    assert "objects[3].orientation: object 'post' is rotated out of the table's plane" in line, line


# --- PIIRL ----------------------------------------------------------------------------------------------------------

UP = [0.7071067811865476, 0.0, 0.0, 0.7071067811865476]


def _demonstrations(tmp_path, far: float = 0.26, objects=("L1", "M1")):
    """A demonstrations file of hollow-cube: one good demonstration, and one whose last waypoint is at z = ``far``."""
    path = [[0.202, 0.202, 0.34, *UP], [0.202, 0.202, 0.3, *UP]]
    task = {"start": path[0], "target": [0.202, 0.202, 0.2], "planes": [], "objects": list(objects)}
    data = {"format": "pliant-demonstrations", "version": 1, "scene": "hollow-cube", "demonstrations": [
        {"task": task, "path": path, "source": "test"},
        {"task": task, "path": path + [[0.202, 0.202, far, *UP]], "source": "test"}]}
    (tmp_path / "demos.json").write_text(json.dumps(data))
    return tmp_path / "demos.json"


PIIRL_RUN = ["run", "learn-hollow-cube", "--set", "learner=piirl", "--set", "learner.samples=5"]


def test_a_demonstration_a_million_metres_away_is_one_error_line_naming_it(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    demos = _demonstrations(tmp_path, far=-1e6)
    line = _one_line_error(capsys, [*PIIRL_RUN, "--set", f"learner.demonstrations='{demos}'"])
    assert f"{demos}:demonstrations[1].path[2]: waypoint 2 lies outside the workspace bounds" in line, line
    assert "[-0.04, -0.04, -0.04] .. [0.444, 0.444, 0.444] m" in line
    _nothing_half_written(tmp_path / "out" / "learn-hollow-cube")


def test_a_demonstration_naming_an_object_the_scene_lacks_is_one_error_line(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    demos = _demonstrations(tmp_path, objects=("L1", "mug"))
    line = _one_line_error(capsys, [*PIIRL_RUN, "--set", f"learner.demonstrations='{demos}'"])
    assert "demonstrations[0].task.objects[1]: names an object the scene 'hollow-cube' lacks" in line
    assert "'mug'" in line


def test_lower_above_upper_is_one_error_line_naming_both(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    line = _one_line_error(capsys, [*PIIRL_RUN, "--set", "learner.lower=2000", "--set", "learner.upper=1000"])
    assert "learner.lower: lower (2000) is above upper (1000)" in line, line


def test_importing_a_recording_out_of_the_workspace_writes_nothing(capsys, tmp_path):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    types = store.types
    bag = tmp_path / "far.bag"
    with Writer(bag) as writer:
        connection = writer.add_connection("/probe/pose", "geometry_msgs/msg/PoseStamped", typestore=store)
        for k, z in enumerate([0.3, 0.25, 1e6]):
            pose = types["geometry_msgs/msg/Pose"](position=types["geometry_msgs/msg/Point"](x=0.2, y=0.2, z=z),
                                                   orientation=types["geometry_msgs/msg/Quaternion"](x=0, y=0, z=0,
                                                                                                     w=1))
            header = types["std_msgs/msg/Header"](seq=k, stamp=types["builtin_interfaces/msg/Time"](sec=k, nanosec=0),
                                                  frame_id="world")
            message = types["geometry_msgs/msg/PoseStamped"](header=header, pose=pose)
            writer.write(connection, (k + 1) * 10**8, store.serialize_ros1(message, "geometry_msgs/msg/PoseStamped"))
    out = tmp_path / "demos.json"
    line = _one_line_error(capsys, ["learn", "import", str(bag), "--topic", "/probe/pose", "--scene",
                                    "hollow-cube", "--target", "0.2", "0.2", "0.2", "--output", str(out)])
    assert "/probe/pose:recording[0].path[2]: waypoint 2 lies outside the workspace bounds" in line, line
    assert not out.exists()


# --- metrics --------------------------------------------------------------------------------------------------------

def test_a_metric_refuses_no_problem_and_waypoints_out_of_the_workspace():
    """Through the public API (a pipeline only scores the paths its planner solved, which the core has checked)."""
    from pliant.interfaces import PlanningProblem
    from pliant.pipeline import Pipeline
    from pliant.results import Path

    pipeline = Pipeline.from_file("passage-select", overrides=["metric.particles=20"])
    context = pipeline.build()
    metric, problem, rng = context.extras["metric"], PlanningProblem.from_context(context), np.random.default_rng(0)
    good = Path(np.array([context.scene.start, context.scene.goal]))
    for path, where, words in [(good, None, "problem: a metric scores a path in the PlanningProblem"),
                               (Path(np.array([context.scene.start, [0.2375, 1e6, 0.0]])), problem,
                                "path[1]: waypoint 1 is not valid")]:
        with pytest.raises(PliantError) as info:
            metric.evaluate(path, where, rng)
        assert words in str(info.value) and "\n" not in str(info.value)
