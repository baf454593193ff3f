"""The ``pliant`` command's tree (framework/pliant/cli): at most ten top-level commands, plugins' sub-commands declared
through one hook (``pliant_commands``), every old spelling still working with one deprecation line, and the live
view of ``pliant run --view`` through a hook the core calls (docs/cli.md)."""

from __future__ import annotations

import argparse
import types

import pytest
from pliant import cli
from pliant.api import Alias, Command, add_common_arguments, hookimpl
from pliant.cli.commands import GROUPS
from pliant.registry import default_registry


def _top_level(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices


def test_help_lists_at_most_ten_commands_the_groups_and_no_old_spelling(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    top = _top_level(cli.build_parser())
    assert list(top) == list(GROUPS) and len(top) <= 10
    listed = [line.split()[0] for line in out.split("positional arguments:")[1].split("options:")[0].splitlines()
              if line.startswith("    ") and not line.startswith("     ")]
    assert listed == list(GROUPS)
    for old in ("pareto", "learn-table", "metric-table", "belief-experiment", "ros-peer", "canopen-peer", "capture",
                "import-demonstration", "reproduce", "driver"):
        assert f"    {old} " not in out


def _aliases() -> list[Alias]:
    return cli._declarations()[1]


OLD = sorted({a.old for a in _aliases()}) + ["driver", "driver baxter-ros --check", "reproduce LIST"]


@pytest.mark.parametrize("old", OLD)
def test_every_old_spelling_works_with_one_deprecation_line_naming_the_new(old, capsys):
    words = old.split()
    argv, note = cli.rewrite([*words, "--help"], _aliases())
    assert note is not None and note.startswith(f"pliant {words[0]}") and "is deprecated: use pliant " in note
    new = note.split("use pliant ")[1].split()
    assert argv[:len(new)] == new and argv[-1] == "--help"
    with pytest.raises(SystemExit) as info:             # the new spelling parses (its --help)
        cli.main([*words, "--help"])
    assert info.value.code == 0
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines() == [note]
    assert f"usage: pliant {' '.join(new)}" in " ".join(captured.out.split())


def test_old_spellings_map_to_their_one_new_home():
    new = {a.old: a.new for a in _aliases()}
    assert new["learn-table"] == "experiment table-4.1"      # the table once had two commands: now one
    assert new["belief-experiment table-5.1"] == "experiment table-5.1"
    assert new["reproduce"] == "experiment" and new["pareto"] == "experiment pareto"
    assert cli.rewrite(["-v", "pareto", "triple-wall"], _aliases())[0] == ["-v", "experiment", "pareto",
                                                                          "triple-wall"]
    assert cli.rewrite(["driver"], _aliases())[0] == ["robot", "list"]
    assert cli.rewrite(["driver", "x", "--check", "--set", "a=1"], _aliases())[0] == ["robot", "check", "x", "--set",
                                                                                      "a=1"]
    assert cli.rewrite(["run", "demo"], _aliases()) == (["run", "demo"], None)


def test_an_old_spelling_runs_the_new_command(capsys):
    assert cli.main(["reproduce", "list"]) == 0
    captured = capsys.readouterr()
    assert captured.err == "pliant reproduce is deprecated: use pliant experiment\n"
    assert "figure-3.5" in captured.out and "pareto" in captured.out     # a reproduction and a plugin experiment


@pytest.mark.parametrize("argv, choices", [(["nope"], "'run', 'scenes'"),
                                           (["experiment", "nope"], "'list', 'figure-3.5'"),
                                           (["robot", "nope"], "'list', 'check'"),
                                           (["learn", "nope"], "'capture'")])
def test_an_unknown_command_names_the_choices(argv, choices, capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'nope'" in err and choices in err


def test_each_table_has_one_home():
    parser = cli.build_parser()
    experiments = _top_level(_top_level(parser)["experiment"])
    assert len(experiments) == len(set(experiments))
    for table in ("table-4.1", "table-4.2", "table-5.1", "table-8.1"):     # with the knobs its old command had
        assert table in experiments
    args = parser.parse_args(["experiment", "table-4.1", "--quick", "--plans", "2", "--max-iterations", "100",
                              "--no-straight"])
    assert args.reproduction_options and {"plans", "max_iterations", "straight", "jobs"} <= set(
        args.reproduction_options)
    assert (args.plans, args.max_iterations, args.straight, args.max_time) == (2, 100, False, None)
    assert "table-5.1" not in parser.parse_args(["experiment", "belief", "maze"]).name


class _ThirdParty:
    """A plugin object as a third party writes it: a sub-command under a group, an alias, a broken one."""

    calls: list = []

    @hookimpl
    def pliant_register(self, registrar):
        pass

    @hookimpl
    def pliant_commands(self):
        def arguments(parser):
            parser.add_argument("what")
            add_common_arguments(parser, seed=7, jobs="sweeps")

        def run(args):
            _ThirdParty.calls.append((args.what, args.seed, args.jobs >= 1))
            return 0

        def broken(parser):
            raise RuntimeError("no arguments today")

        return [Command("experiment", "sweep-demo", "a third party's experiment", run=run, arguments=arguments),
                Command("robot", "demo-arm", "a third party's emulated arm", run=lambda args: 5),
                Command("learn", "broken", "arguments that raise", run=run, arguments=broken),
                Command("nowhere", "lost", "an unknown group", run=run),
                Alias("old-sweep", "experiment sweep-demo"),
                Alias("run", "experiment sweep-demo")]                  # would hide the core's run: refused


@pytest.fixture
def third_party():
    registry = default_registry()
    plugin = _ThirdParty()
    assert registry.add_plugin(plugin, "third-party-cli", "third-party-dist")
    _ThirdParty.calls.clear()
    yield plugin
    registry.manager.unregister(plugin)
    registry._plugins.pop("third-party-cli", None)


def test_a_third_party_plugin_adds_sub_commands_under_groups(third_party, capsys):
    assert cli.main(["experiment", "sweep-demo", "corner"]) == 0
    assert _ThirdParty.calls == [("corner", 7, True)]
    assert cli.main(["robot", "demo-arm"]) == 5
    assert cli.rewrite(["run", "x"], cli._declarations()[1]) == (["run", "x"], None)
    assert cli.main(["old-sweep", "again", "--seed", "3"]) == 0
    assert _ThirdParty.calls[-1] == ("again", 3, True)
    assert capsys.readouterr().err == "pliant old-sweep is deprecated: use pliant experiment sweep-demo\n"
    top = _top_level(cli.build_parser())
    assert "lost" not in top and "nowhere" not in top                   # a plugin adds no top-level command
    assert "broken" not in _top_level(top["learn"])                     # its parser raised: skipped
    assert "capture" in _top_level(top["learn"])                        # the others' commands stay


class _FakeView:
    def __init__(self, pipeline, args):
        self.steps, self.finished, self.port = 0, [], args.view_port

    def on_step(self, *step):
        self.steps += 1

    def finish(self, record):
        self.finished.append(record)


def test_run_view_is_the_cores_flag_and_a_hook_the_viewer_answers(tmp_path, monkeypatch, capsys):
    """The viewer patches no parser: ``run``'s handler is the core's, ``--view`` and its page options are the
    core's, and the live view comes from the ``pliant_run_view`` hook (here the viewer's, with its page faked)."""
    import pliant_viewer.commands

    parser = cli.build_parser()
    run = _top_level(parser)["run"]
    assert run.get_default("handler") is cli.cmd_run
    args = parser.parse_args(["run", "straight-demo", "--view", "--view-port", "0", "--view-hold", "0"])
    assert args.view and args.view_hold == 0 and args.view_robot_meshes == "collision"
    views = []
    monkeypatch.setattr(pliant_viewer.commands, "LiveView", lambda p, a: views.append(_FakeView(p, a)) or views[-1])
    assert cli.main(["run", "straight-demo", "--output", str(tmp_path), "--view", "--view-hold", "0"]) == 0
    assert len(views) == 1 and views[0].finished and views[0].finished[0].output == tmp_path
    assert cli.main(["run", "straight-demo", "--output", str(tmp_path)]) == 0
    assert len(views) == 1                                                # no --view: no view


def test_run_view_without_a_viewer_or_with_a_broken_one_is_one_clear_error(tmp_path, monkeypatch, capsys):
    import pliant_viewer.commands

    monkeypatch.setattr(pliant_viewer.commands, "LiveView", lambda pipeline, args: None)   # declines: none answers
    assert cli.main(["run", "straight-demo", "--output", str(tmp_path), "--view"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --view:") and "no plugin offers a live view" in err and "\n" not in err

    def broken(pipeline, args):
        raise ZeroDivisionError("a bug in the view")

    monkeypatch.setattr(pliant_viewer.commands, "LiveView", broken)
    assert cli.main(["run", "straight-demo", "--output", str(tmp_path), "--view"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --view: the live view failed: ZeroDivisionError") and "\n" not in err


def test_a_plugin_module_still_implementing_the_old_hook_loads(monkeypatch):
    module = types.ModuleType("old_style")
    module.pliant_register = lambda registrar: None
    module.pliant_add_commands = lambda subparsers: subparsers.add_parser("patched")
    registry = default_registry()
    try:
        with pytest.warns(DeprecationWarning, match="pliant_commands"):
            assert registry.add_plugin(module, "old-style")
        assert "patched" not in _top_level(cli.build_parser())           # never called: nothing is patched
    finally:
        registry.manager.unregister(module)
        registry._plugins.pop("old-style", None)


def test_the_robot_group_holds_the_drivers_tools_and_the_ros_demo(capsys):
    robot = _top_level(_top_level(cli.build_parser())["robot"])
    assert {"list", "check", "ros-peer", "canopen-peer", "ros-demo"} <= set(robot)
    args = cli.build_parser().parse_args(["robot", "ros-demo", "iiwa-policy", "--seed", "2", "--set", "a=1"])
    assert (args.pipeline, args.seed, args.set) == ("iiwa-policy", 2, ["a=1"])
    from pliant_ros1.demo import main as demo_main  # python -m pliant_ros1.demo: the same command

    with pytest.raises(SystemExit) as info:
        demo_main(["--help"])
    assert info.value.code == 0 and "usage: pliant robot ros-demo" in capsys.readouterr().out


def test_view_without_the_viewer_plugin_is_listed_and_one_clear_error():
    import os
    import subprocess
    import sys

    env = {**os.environ, "PLIANT_DISABLE": "viewer"}
    done = subprocess.run([sys.executable, "-m", "pliant.cli", "view", "triple-wall"], capture_output=True, text=True,
                          env=env, check=False)
    assert done.returncode == 2
    assert done.stderr.strip().startswith("error: pliant view:") and "pliant_viewer" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


@pytest.mark.slow
def test_a_tables_own_options_reach_its_runner_and_its_report(tmp_path, capsys):
    """``pliant experiment table-4.2 --ci --max-iterations 600 --seed 3`` (once ``learn-planar``): the options
    override the mode's settings (12,000 iterations, seed 0) and the report's settings record them.  600 iterations
    keep it to seconds; the headlines may then be out of range (exit status 3), which is not what this tests."""
    import json

    assert cli.main(["experiment", "table-4.2", "--ci", "--max-iterations", "600", "--seed", "3",
                     "--output", str(tmp_path)]) in (0, 3)
    outcome = json.loads((tmp_path / "table-4.2" / "ci" / "outcome.json").read_text())
    assert outcome["settings"] == {"max_iterations": 600, "seed": 3}
    summary = json.loads((tmp_path / "table-4.2" / "ci" / "learn-table-4.2" / "summary.json").read_text())
    assert summary["max_iterations"] == 600 and summary["seed"] == 3


def test_bench_runs_a_script_as_its_own_program_and_returns_its_status(tmp_path, monkeypatch, capfd):
    (tmp_path / "bench_probe.py").write_text("import sys\nprint('argv', sys.argv[1:])\nsys.exit(4)\n")
    monkeypatch.setenv("PLIANT_BENCHMARKS", str(tmp_path))
    import sys

    before = list(sys.argv)
    assert cli.main(["bench", "probe", "--repeats", "2"]) == 4
    assert "argv ['--repeats', '2']" in capfd.readouterr().out
    assert sys.argv == before                  # this process's argv untouched


def test_the_command_runs_blas_on_one_thread_unless_the_user_chose(monkeypatch, capsys):
    """``pliant`` pins BLAS and OpenMP to one thread (docs/benchmarking.md, "BLAS threads"): the variables are set
    for the libraries loaded later, and a variable the user set keeps its value with the others left unset."""
    import os

    from pliant.experiments import executor

    for name in executor.THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    assert cli.main(["plugins"]) == 0
    assert {os.environ.get(name) for name in executor.THREAD_VARIABLES} == {"1"}
    for name in executor.THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    assert cli.main(["plugins"]) == 0
    assert os.environ["OPENBLAS_NUM_THREADS"] == "2" and os.environ.get("OMP_NUM_THREADS") is None
    capsys.readouterr()


class _Lopsided:
    """A third party's controller whose command has the wrong shape: the conformance kit must say so."""

    @hookimpl
    def pliant_register(self, registrar):
        import numpy as np
        from pliant.api import Controller

        class Lopsided(Controller):
            def command(self, q, target, dt):
                return np.zeros(len(q) + 1)

        class Crashing(Controller):
            def command(self, q, target, dt):
                return None + q                     # a bug, not a contract's error: the check reports it too

        registrar.add("controller", "lopsided", Lopsided, description="commands one value too many")
        registrar.add("controller", "crashing", Crashing, description="raises a TypeError")


@pytest.fixture
def lopsided():
    registry = default_registry()
    plugin = _Lopsided()
    assert registry.add_plugin(plugin, "lopsided-plugin", "lopsided-dist")
    yield plugin
    registry.manager.unregister(plugin)
    registry._plugins.pop("lopsided-plugin", None)
    registry._entries.pop(("controller", "lopsided"), None)
    registry._entries.pop(("controller", "crashing"), None)


def test_plugins_check_runs_the_conformance_kit_and_fails_on_a_broken_component(lopsided, capsys):
    assert cli.main(["plugins", "--check", "--kind", "cost"]) == 0
    out = capsys.readouterr().out
    assert "[1/1] cost 'voxel' (voxel): ok" in out and "1 of 1 components conform" in out
    assert cli.main(["plugins", "--check", "--kind", "controller"]) == 1
    out = capsys.readouterr().out
    assert "controller 'contact' (contact): ok" in out and "controller 'lopsided' (lopsided-plugin): FAILED" in out
    assert "command() returns (tangent_dim,)" in out and "1 of 3 components conform" in out
    assert "controller 'crashing' (lopsided-plugin): FAILED" in out and "TypeError" in out
    assert cli.main(["plugins", "--check", "--kind", "nope"]) == 2             # a bad kind, as without --check
    assert "--kind" in capsys.readouterr().err
