"""A hostile user at the command line: every malformed command, option, override and file is answered with one
line ``error: ...`` naming the field and exit status 2 -- never a traceback, never a silent success.

Hand-written cases cover each command; hypothesis throws random overrides (known keys with junk values, junk
keys) at a pipeline, checking that building it either works or raises a PliantError.

The viewer's and the experiment executor's hostile options (issue 31: ports out of range or in use, hosts that are
no address, run folders cut off, exports to directories, Ray heads where nothing answers) run ``python -m
pliant.cli`` in a subprocess: some of them used to never exit, so each gets a timeout -- as a safety net only;
nothing asserts on elapsed time.  Each must end with exit status 2, one ``error:`` line on stderr naming the option
and its value, no traceback, and nothing written (the output folder absent, the run folder unchanged)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import cli
from pliant.errors import PliantError
from pliant.pipeline import Pipeline

#: a work budget, should a bad command line ever get as far as planning (never a wall-clock one: docs/testing.md)
FAST = ["--set", "planning.max_iterations=2"]


def _files(tmp) -> dict[str, str]:
    """Malformed files, by label -> path."""
    files = {
        "empty": "",
        "invalid toml": "name = \n[planner\n",
        "binary": "\x00\x01\x02\xff" * 50,
        "deep nesting": "a = " + "[" * 50000 + "]" * 50000 + "\n",
        "unknown top-level key": 'scene = "triple-wall"\nbogus = 1\n[planner]\nname = "straight"\n',
        "planner without a name": 'scene = "triple-wall"\n[planner]\nstep = 0.1\n',
        "planner is a number": 'scene = "triple-wall"\nplanner = 5\n',
        "scene is a number": "scene = 5\nplanner = \"straight\"\n",
        "no scene": 'planner = "straight"\n',
        "seed is a string": 'scene = "triple-wall"\nseed = "zero"\nplanner = "straight"\n',
        "execution is a list": 'scene = "triple-wall"\nplanner = "straight"\nexecution = [1, 2]\n',
        "unknown component kind": 'scene = "triple-wall"\n[teleporter]\nname = "x"\n',
        "option of the wrong type": 'scene = "triple-wall"\n[planner]\nname = "straight"\nstep = "small"\n',
        "nan option": 'scene = "triple-wall"\n[planner]\nname = "straight"\nstep = nan\n',
        "negative option": 'scene = "triple-wall"\n[planner]\nname = "straight"\nstep = -0.1\n',
        "unknown option": 'scene = "triple-wall"\n[planner]\nname = "straight"\nwarp = 9\n',
        "scene file missing": 'scene = "no-such-scene.toml"\nplanner = "straight"\n',
        "disable is a string": 'scene = "triple-wall"\nplanner = "straight"\ndisable = "straight"\n',
        "output is a number": 'scene = "triple-wall"\nplanner = "straight"\noutput = 7\n',
        "name with a path": 'name = "../../escape"\nscene = "triple-wall"\nplanner = "straight"\noutput = 7\n',
    }
    paths = {}
    for label, text in files.items():
        path = tmp / (label.replace(" ", "-") + ".toml")
        path.write_text(text, errors="surrogateescape") if "\xff" not in text else path.write_bytes(
            text.encode("latin-1"))
        paths[label] = str(path)
    return paths


CASES = [
    ["run", "no-such-pipeline"],
    ["run", ""],
    ["run", "straight-demo", "--set", ""],
    ["run", "straight-demo", "--set", "="],
    ["run", "straight-demo", "--set", "planner"],
    ["run", "straight-demo", "--set", "planner.step=-1"],
    ["run", "straight-demo", "--set", "planner.step=nan"],
    ["run", "straight-demo", "--set", "planner.step=inf"],
    ["run", "straight-demo", "--set", "planner.step=1e-12"],
    ["run", "straight-demo", "--set", "planner.step='x'"],
    ["run", "straight-demo", "--set", "planner.step=[1, 2]"],
    ["run", "straight-demo", "--set", "planner=no-such-planner"],
    ["run", "straight-demo", "--set", "planner.warp=1"],
    ["run", "straight-demo", "--set", "seed=-1"],
    ["run", "straight-demo", "--set", "seed=1.5"],
    ["run", "straight-demo", "--set", "seed=true"],
    ["run", "straight-demo", "--set", "scene=no-such-scene"],
    ["run", "straight-demo", "--set", "scene.variant=no-such-variant"],
    ["run", "straight-demo", "--set", "scene.bogus=1"],
    ["run", "straight-demo", "--set", "bogus=1"],
    ["run", "straight-demo", "--set", "name.x=1"],
    ["run", "straight-demo", "--set", "robot=no-such-robot"],
    ["run", "straight-demo", "--set", "disable=5"],
    ["run", "straight-demo", "--set", "name=''"],
    ["run", "straight-demo", "--set", "execution.world=pybullet"],
    ["run", "straight-demo", "--set", "execution.world.frequency=5"],
    ["run", "straight-demo", "--output", ""],
    ["run", "straight-demo", "--output", "/proc/no/such/dir"],
    ["run", "maze-policy", "--set", "execution.period=0", *FAST],
    ["run", "maze-policy", "--set", "execution.time_limit=-1", *FAST],
    ["run", "maze-policy", "--set", "execution.action_limit=1.5", *FAST],
    ["run", "maze-policy", "--set", "execution.world=no-such-world", *FAST],
    ["run", "maze-policy", "--set", "execution.bogus=1", *FAST],
    ["run", "maze-policy", "--set", "controller.gain=-1", *FAST],
    ["run", "maze-policy", "--set", "controller=no-such-controller", *FAST],
    ["run", "maze-policy", "--set", "simulator.frequency=0", *FAST],
    ["run", "maze-policy", "--set", "simulator=no-such-simulator", *FAST],
    ["run", "maze-policy", "--set", "planner.particles=0", *FAST],
    ["plugins", "--options", "planner", "no-such-planner"],
    ["plugins", "--options", "no-such-kind", "x"],
    ["scenes", "no-such-scene"],
    ["scenes", "/dev/null"],
    ["robot", "list", "no-such-driver"],
    ["robot", "check", "baxter-ros", "--set", "side=middle"],
    ["robot", "list", "baxter-ros", "--set", "command_rate=-5"],
    ["robot", "check", "baxter-ros", "--set", "no_such_option=1"],
    ["robot", "list", "baxter-ros", "--set", "speed_scale=2"],
    ["bench", "no-such-benchmark"],
    ["experiment", "table-5.2", "--ci", "--only", "no-such-row"],
]


def _one_line_error(capsys, argv) -> str:
    code = cli.main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, f"{argv}: exit {code}, stderr {err!r}"
    lines = [line for line in err.splitlines() if line.startswith("error: ")]
    assert len(lines) == 1 and "Traceback" not in err, f"{argv}: {err!r}"
    return lines[0]


@pytest.mark.parametrize("argv", CASES, ids=[" ".join(c)[:60] for c in CASES])
def test_a_bad_command_line_is_one_error_line_and_exit_2(capsys, tmp_path, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    _one_line_error(capsys, argv)


def test_malformed_pipeline_files_are_one_error_line_and_exit_2(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name, path in _files(tmp_path).items():
        line = _one_line_error(capsys, ["run", path])
        assert ":" in line, (name, line)
    assert not (tmp_path / "escape").exists() and not (tmp_path.parent / "escape").exists()


def test_a_directory_or_a_fifo_as_a_pipeline_file_is_an_error(capsys, tmp_path):
    _one_line_error(capsys, ["run", str(tmp_path)])
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    _one_line_error(capsys, ["run", str(fifo)])


KEYS = st.sampled_from(["seed", "name", "scene", "scene.variant", "planner", "planner.step", "planner.max_time",
                        "robot", "robot.resolution", "output", "disable", "execution.period", "execution.world",
                        "cost", "metric", "simulator.frequency", "x", "planner.", ".step", "execution.world.x"])
VALUES = st.sampled_from(["1", "-1", "0", "nan", "inf", "-inf", "1e308", "1e-308", "true", '"x"', '""', "[]",
                          "[1, 2]", "{a = 1}", '"../.."', "'straight'", "straight", "[[]]", "1.5", '"\\u0000"'])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(KEYS, VALUES), min_size=1, max_size=3))
def test_random_overrides_build_or_raise_a_pliant_error(overrides):
    texts = [f"{k}={v}" for k, v in overrides]
    try:
        pipeline = Pipeline.from_file("straight-demo", overrides=texts)
        pipeline.check_execution()
        pipeline.build()
    except PliantError as exc:
        assert str(exc).strip() and "\n" not in str(exc).strip()



# --- the viewer, the executor and reproduce, as a user runs them (a subprocess each) ---------------------------------

#: a safety net for commands that used to hang; never an assertion on time
SAFETY = 300


def _pliant(argv: list[str], cwd: Path) -> tuple[int, str, str]:
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0", "PYTHONWARNINGS": "ignore"}
    done = subprocess.run([sys.executable, "-m", "pliant.cli", *argv], cwd=cwd, capture_output=True, text=True,
                          timeout=SAFETY, env=env)
    return done.returncode, done.stdout, done.stderr


def _snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _refused(argv: list[str], cwd: Path, option: str, value) -> str:
    """Run ``pliant argv`` in ``cwd``: exit 2, one error line naming ``option`` and ``value`` (``(got value)``; None:
    a file's text, not checked), no traceback, and ``cwd`` exactly as it was."""
    before = _snapshot(cwd)
    code, _, err = _pliant(argv, cwd)
    lines = err.strip().splitlines()
    assert code == 2, f"{argv}: exit {code}, stderr {err[-2000:]!r}"
    assert "Traceback" not in err and len(lines) == 1 and lines[0].startswith("error: "), (argv, err[-2000:])
    shown = value is None or f"(got {value!r})" in lines[0] or f"(got {value})" in lines[0]
    assert option in lines[0] and shown, (argv, lines[0])
    assert _snapshot(cwd) == before, f"{argv} wrote {set(_snapshot(cwd)) ^ set(before)}"
    return lines[0]


def _run_folder(root: Path) -> Path:
    """A run folder as ``pliant run`` writes it (run.json, result.json, execution.json) on triple-wall."""
    import pliant

    scene = pliant.load_scene("triple-wall")
    path = [scene.start.tolist(), scene.goal.tolist()]
    folder = root / "run"
    folder.mkdir()
    (folder / "run.json").write_text(json.dumps({"pipeline": {"name": "r", "scene": "triple-wall"}}, indent=1))
    (folder / "result.json").write_text(json.dumps({"status": "solved", "planner": "straight", "statistics": {},
                                                    "path": {"configurations": path}}, indent=1))
    (folder / "execution.json").write_text(json.dumps({"times": [0.0, 1.0], "configurations": path,
                                                       "outcome": "reached", "world": "kinematic"}, indent=1))
    return folder


VIEW_OPTIONS = [
    (["--port", "70000"], "--port", "70000"),
    (["--port", "-1"], "--port", "-1"),
    (["--port", "65536"], "--port", "65536"),
    (["--host", "999.1.1.1"], "--host", "999.1.1.1"),
    (["--host", ""], "--host", ""),
    (["--host", "203.0.113.7"], "--host", "203.0.113.7"),        # TEST-NET-3: not this machine's (bind only)
    (["--hold", "-5"], "--hold", "-5.0"),
    (["--hold", "nan"], "--hold", "nan"),
    (["--frames", "0", "--export", "v.html"], "--frames", "0"),
    (["--frames", "1", "--export", "v.html"], "--frames", "1"),
    (["--frames", "-3", "--export", "v.html"], "--frames", "-3"),
    (["--export", "."], "--export", "."),
    (["--export", "folder"], "--export", "folder"),
    (["--export", ""], "--export", ""),
    (["--export", "file.txt/v.html"], "--export", "file.txt/v.html"),
    (["--export", "/dev/null"], "--export", "/dev/null"),
]


@pytest.mark.parametrize("options, option, value", VIEW_OPTIONS, ids=[" ".join(o[0]) or "empty" for o in VIEW_OPTIONS])
def test_hostile_view_options_are_one_error_line_exit_2_and_write_nothing(tmp_path, options, option, value):
    (tmp_path / "folder").mkdir()
    (tmp_path / "file.txt").write_text("kept")
    _refused(["view", "triple-wall", *options], tmp_path, option, value)


def test_a_view_port_in_use_is_refused_not_moved(tmp_path):
    """viser silently served on the next port; the printed address was the taken one's."""
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = str(taken.getsockname()[1])
        _refused(["view", "triple-wall", "--port", port, "--hold", "0"], tmp_path, "--port", int(port))


@pytest.mark.parametrize("name", ["run.json", "result.json", "execution.json"])
def test_viewing_a_run_folder_whose_file_is_cut_off_names_the_file(tmp_path, name):
    """It ended in a JSONDecodeError traceback."""
    folder = _run_folder(tmp_path)
    text = (folder / name).read_text()
    (folder / name).write_text(text[: len(text) // 2])
    line = _refused(["view", str(folder), "--hold", "0"], tmp_path, name, None)
    assert "cut off" in line and f"{folder / name}:line " in line
    if name != "run.json":                        # the file itself as the target, the scene from run.json
        _refused(["view", str(folder / name), "--hold", "0"], tmp_path, name, None)


def test_viewing_run_files_of_the_wrong_form_names_the_field(tmp_path):
    folder = _run_folder(tmp_path)
    (folder / "run.json").write_text(json.dumps({"pipeline": [1]}))
    _refused(["view", str(folder), "--hold", "0"], tmp_path, "run.json:pipeline", "list")
    (folder / "run.json").write_text(json.dumps({"pipeline": {"scene": "triple-wall"}}))
    (folder / "result.json").write_text(json.dumps({"status": "solved", "path": {"configurations": [[0, 1, 2, 3]]}}))
    _refused(["view", str(folder), "--hold", "0"], tmp_path, "result.json:path.configurations", "[1, 4]")
    (folder / "result.json").write_text(json.dumps(["status"]))
    _refused(["view", str(folder / "result.json"), "--hold", "0"], tmp_path, "result.json:<top level>", "list")


@pytest.mark.parametrize("options, option, value", [
    (["--view-port", "70000"], "--view-port", "70000"),
    (["--view-host", "999.1.1.1"], "--view-host", "999.1.1.1"),
    (["--view-hold", "-1"], "--view-hold", "-1.0"),
])
def test_hostile_live_view_options_refuse_before_the_run_writes_anything(tmp_path, options, option, value):
    _refused(["run", "straight-demo", "--output", "out", "--view", *options], tmp_path, option, value)
    assert not (tmp_path / "out").exists()


class _Listener:
    """A loopback TCP server answering each connection with ``reply`` (None: it answers nothing)."""

    def __init__(self, reply: bytes | None) -> None:
        self.reply = reply
        self.server = socket.create_server(("127.0.0.1", 0))
        self.address = f"127.0.0.1:{self.server.getsockname()[1]}"
        self.held: list = []

    def _serve(self) -> None:
        while True:
            try:
                connection, _ = self.server.accept()
            except OSError:
                return
            self.held.append(connection)
            if self.reply is not None:
                connection.sendall(self.reply)

    def __enter__(self) -> _Listener:
        threading.Thread(target=self._serve, daemon=True).start()
        return self

    def __exit__(self, *exc) -> None:
        self.server.close()
        for connection in self.held:
            connection.close()


def _closed_port() -> int:
    with socket.socket() as s:                  # bound, never listening: a connection is refused at once
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("address, why", [
    ("not-a-host:port", "must be HOST:PORT"), ("127.0.0.1:0", "must be HOST:PORT"), ("127.0.0.1", "must be HOST:PORT"),
    ("127.0.0.1:{closed}", "cannot reach the Ray head"), ("ray://127.0.0.1:{closed}", "cannot reach the Ray head"),
    ("{web}", "not a Ray head"), ("{mute}", "does not answer"),
])
def test_a_ray_address_where_no_head_answers_fails_within_seconds_writing_nothing(tmp_path, address, why):
    """``--executor ray --address 127.0.0.1:1`` never exited (ray.init retries for minutes), ``not-a-host:port``
    exited 0.  Now the command stops before its reproduction writes anything."""
    with _Listener(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n") as web, _Listener(None) as mute:
        address = address.format(closed=_closed_port(), web=web.address, mute=mute.address)
        line = _refused(["experiment", "figure-3.5", "--ci", "--output", "out", "--executor", "ray", "--address",
                         address], tmp_path, "--address", address)
        assert why in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("output", ["", " ", "file.txt", "file.txt/below"])
def test_reproduce_to_an_output_that_is_no_directory_writes_nothing(tmp_path, output):
    """``pliant experiment NAME --output ""`` wrote the report into the current directory and exited 0."""
    (tmp_path / "file.txt").write_text("kept")
    _refused(["experiment", "figure-3.5", "--ci", "--output", output], tmp_path, "--output", output)


@pytest.mark.parametrize("command", [["experiment", "metric-tables"], ["experiment", "table-5.1"],
                                     ["experiment", "table-4.1"], ["experiment", "active-learning"],
                                     ["experiment", "belief", "maze"], ["experiment", "pareto", "triple-wall"]])
def test_every_command_refuses_an_empty_output_before_writing(tmp_path, command):
    """An empty ``--output`` is the current directory to ``Path``: these commands started hour-long experiments
    writing into it."""
    _refused([*command, "--output", ""], tmp_path, "--output", "")
