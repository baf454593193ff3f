"""A hostile user at the command line: every malformed command, option, override and file is answered with one
line ``error: ...`` naming the field and exit status 2 -- never a traceback, never a silent success.

Hand-written cases cover each command; hypothesis throws random overrides (known keys with junk values, junk
keys) at a pipeline, checking that building it either works or raises a PliantError."""

from __future__ import annotations

import os

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import cli
from pliant.errors import PliantError
from pliant.pipeline import Pipeline

FAST = ["--set", "planner.max_time=0.5"]


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
    ["driver", "no-such-driver"],
    ["driver", "baxter-ros", "--set", "side=middle"],
    ["driver", "baxter-ros", "--set", "command_rate=-5"],
    ["driver", "baxter-ros", "--set", "no_such_option=1"],
    ["driver", "baxter-ros", "--set", "speed_scale=2"],
    ["bench", "no-such-benchmark"],
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
