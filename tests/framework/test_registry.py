"""The plugin registry: entry points, Python registration, failures, disabling."""

from __future__ import annotations

import sys
import types
from dataclasses import dataclass

import pytest
from pliant import registry
from pliant.errors import ConfigError, PluginError
from pliant.hookspecs import hookimpl
from pliant.interfaces import PathMetric
from pliant.options import option
from pliant.registry import Registry


@dataclass(frozen=True)
class _Opts:
    scale: float = option(1.0, "scale", minimum=0.0)


class ConstantMetric(PathMetric):
    """A metric for tests."""

    Options = _Opts

    def evaluate(self, path, problem, rng):
        return {"constant": self.options.scale}


def test_builtins_are_available():
    assert "straight" in registry.available("planner")
    assert "rigid" in registry.available("robot")
    assert "voxel" in registry.available("cost")
    assert {p.name for p in registry.plugins() if p.status == "loaded"} >= {"rigid", "straight", "voxel", "astar"}


def test_unknown_kind_and_name():
    with pytest.raises(PluginError, match="unknown component kind"):
        registry.available("gizmo")
    with pytest.raises(PluginError, match=r"unknown planner \(available: .*straight"):
        registry.create("planner", "teleport")


def test_register_from_python_and_create_with_options():
    registry.register("metric", "constant-test", ConstantMetric, "a constant")
    try:
        metric = registry.create("metric", "constant-test", scale=2.5)
        assert metric.options.scale == 2.5
        with pytest.raises(ConfigError, match=r"metric\.scale"):
            registry.create("metric", "constant-test", scale=-1.0)
        with pytest.raises(ConfigError, match="unknown option"):
            registry.create("metric", "constant-test", colour="red")
    finally:
        registry.default_registry().unregister("metric", "constant-test")


def test_wrong_base_class_is_refused():
    registry.register("planner", "not-a-planner-test", ConstantMetric)
    try:
        with pytest.raises(PluginError, match="is not a Planner"):
            registry.create("planner", "not-a-planner-test")
    finally:
        registry.default_registry().unregister("planner", "not-a-planner-test")


class _EntryPoint:
    def __init__(self, name, module):
        self.name = name
        self._module = module
        self.dist = types.SimpleNamespace(name=f"dist-{name}")

    def load(self):
        if isinstance(self._module, Exception):
            raise self._module
        return self._module


def _fake_plugins(monkeypatch, plugins):
    import pliant.registry as reg_module

    monkeypatch.setattr(reg_module, "entry_points", lambda group: plugins)


def _good_module():
    module = types.ModuleType("good_plugin")

    @hookimpl
    def pliant_register(registrar):
        registrar.add("metric", "good", ConstantMetric, "good metric")

    module.pliant_register = pliant_register
    return module


def test_a_broken_plugin_is_reported_and_others_still_load(monkeypatch):
    bad_register = types.ModuleType("bad_register")

    def pliant_register(registrar):
        registrar.add("metric", "half", ConstantMetric)
        raise RuntimeError("boom while registering")

    bad_register.pliant_register = pliant_register
    _fake_plugins(monkeypatch, [_EntryPoint("good", _good_module()),
                                _EntryPoint("broken-import", ImportError("no module named heavy_dep")),
                                _EntryPoint("broken-register", bad_register)])
    reg = Registry()
    assert reg.available("metric") == ["good"]          # the half-registered component was withdrawn
    status = {p.name: p for p in reg.plugins()}
    assert status["good"].status == "loaded"
    assert status["broken-import"].status == "failed" and "heavy_dep" in status["broken-import"].error
    assert status["broken-register"].status == "failed" and "boom" in status["broken-register"].error
    with pytest.raises(PluginError, match="plugins not loaded: broken-import, broken-register"):
        reg.entry("metric", "missing")


def test_disable_by_environment(monkeypatch):
    _fake_plugins(monkeypatch, [_EntryPoint("good", _good_module())])
    monkeypatch.setenv("PLIANT_DISABLE", "good, other")
    reg = Registry()
    assert reg.available("metric") == []
    assert reg.plugins()[0].status == "disabled"


def test_disable_in_a_pipeline():
    from pliant import Pipeline

    with pytest.raises(PluginError, match="disabled in this pipeline"):
        Pipeline("triple-wall", planner="straight", disable=["straight"]).build()


def test_name_clash_between_plugins_is_refused(monkeypatch):
    other = types.ModuleType("other")
    other.pliant_register = lambda registrar: registrar.add("metric", "good", ConstantMetric)
    _fake_plugins(monkeypatch, [_EntryPoint("a", _good_module()), _EntryPoint("b", other)])
    reg = Registry()
    status = {p.name: p.status for p in reg.plugins()}
    assert status == {"a": "loaded", "b": "failed"}


def test_string_targets_load_lazily(monkeypatch):
    module = types.ModuleType("lazy_plugin")
    module.pliant_register = lambda registrar: registrar.add("metric", "lazy", "lazy_target_module:Metric")
    _fake_plugins(monkeypatch, [_EntryPoint("lazy", module)])
    reg = Registry()
    assert "lazy_target_module" not in sys.modules
    assert reg.available("metric") == ["lazy"]
    with pytest.raises(PluginError, match="cannot load metric 'lazy'"):
        reg.create("metric", "lazy")


class _Dist(_EntryPoint):
    def __init__(self, name, module, dist):
        super().__init__(name, module)
        self.dist = types.SimpleNamespace(name=dist)


class OtherMetric(ConstantMetric):
    """An impostor."""


def test_a_builtin_keeps_its_name_whatever_the_load_order(monkeypatch):
    impostor = types.ModuleType("impostor")
    impostor.pliant_register = lambda registrar: (registrar.add("metric", "extra", OtherMetric),
                                                  registrar.add("metric", "good", OtherMetric))
    # the impostor's entry point sorts first; the built-in's distribution is pliant's own
    _fake_plugins(monkeypatch, [_Dist("aaa-impostor", impostor, "evil"),
                                _Dist("zzz-builtin", _good_module(), "pliant")])
    reg = Registry()
    assert reg.entry("metric", "good").plugin == "zzz-builtin"
    assert type(reg.create("metric", "good")) is ConstantMetric
    assert reg.available("metric") == ["good"]           # nothing of the failed impostor stays
    status = {p.name: p for p in reg.plugins()}
    assert status["zzz-builtin"].status == "loaded"
    assert status["aaa-impostor"].status == "failed"
    assert "already registered by plugin 'zzz-builtin'" in status["aaa-impostor"].error


@pytest.mark.parametrize("decorated", [True, False])
def test_a_misspelled_hook_fails_the_plugin_and_nothing_else(monkeypatch, decorated):
    typo = types.ModuleType("typo")

    def pliant_regster(registrar):
        registrar.add("metric", "typo", ConstantMetric)

    def pliant_register(registrar):
        registrar.add("metric", "typo-ok", ConstantMetric)

    typo.pliant_regster = hookimpl(pliant_regster) if decorated else pliant_regster
    typo.pliant_register = pliant_register
    _fake_plugins(monkeypatch, [_EntryPoint("good", _good_module()), _EntryPoint("typo", typo)])
    reg = Registry()
    status = {p.name: p for p in reg.plugins()}
    assert status["good"].status == "loaded"
    assert status["typo"].status == "failed" and "pliant_regster" in status["typo"].error
    assert reg.available("metric") == ["good"]


def test_a_plugin_without_a_register_hook_is_failed(monkeypatch):
    _fake_plugins(monkeypatch, [_EntryPoint("empty", types.ModuleType("empty"))])
    reg = Registry()
    assert reg.plugins()[0].status == "failed" and "no pliant_register hook" in reg.plugins()[0].error


def _reporting_module(name, *, fails):
    module = types.ModuleType(name)
    module.pliant_register = lambda registrar: registrar.add("metric", f"{name}-metric", ConstantMetric)

    def pliant_report(run, directory):
        if fails:
            raise ValueError(f"{name} cannot draw")
        return [f"{directory}/{name}.png"]

    def pliant_commands():
        if fails:
            raise RuntimeError(f"{name} has no commands today")
        return [f"{name}-command"]

    module.pliant_report = pliant_report
    module.pliant_commands = pliant_commands
    return module


def test_a_failing_report_or_command_hook_is_isolated_and_reported(monkeypatch):
    _fake_plugins(monkeypatch, [_EntryPoint("bad", _reporting_module("bad", fails=True)),
                                _EntryPoint("fine", _reporting_module("fine", fails=False))])
    reg = Registry()
    assert reg.report_hook()(run=None, directory="out") == [["out/fine.png"]]     # one result per plugin
    assert reg.call_isolated("pliant_commands") == [["fine-command"]]
    status = {p.name: p for p in reg.plugins()}
    assert status["fine"].status == "loaded"
    assert status["bad"].status == "failed"
    assert "pliant_commands raised RuntimeError: bad has no commands today" in status["bad"].error
    assert reg.available("metric") == ["bad-metric", "fine-metric"]    # its components loaded fine


def test_a_dict_where_the_context_goes_is_a_clear_error():
    with pytest.raises(PluginError, match=r"context: .*pass options as keywords") as info:
        registry.create("planner", "straight", {"step": 0.1})
    assert info.value.value == "dict"


def test_a_factory_that_raises_names_its_plugin_and_keeps_the_cause():
    def factory(**options):
        raise ZeroDivisionError("a plugin bug")

    def pliant_factory(**options):
        raise ConfigError("a deliberate error", field="x", value=1)

    registry.register("metric", "raising-test", factory)
    registry.register("metric", "config-test", pliant_factory)
    try:
        with pytest.raises(PluginError, match=r"metric 'raising-test' from plugin '<python>' failed to build: "
                                              r"ZeroDivisionError: a plugin bug") as info:
            registry.create("metric", "raising-test")
        assert isinstance(info.value.__cause__, ZeroDivisionError)
        with pytest.raises(ConfigError, match="a deliberate error"):
            registry.create("metric", "config-test")
    finally:
        registry.default_registry().unregister("metric", "raising-test")
        registry.default_registry().unregister("metric", "config-test")


def test_the_command_line_starts_without_the_compiled_kernels():
    """``pliant --help`` (every plugin's commands listed) loads no numba: the collision checker's and the other
    kernels load on their first call, so a command that plans nothing starts about 0.2 s sooner."""
    import subprocess

    probe = ("import io, sys, contextlib\nfrom pliant.cli import main\n"
             "with contextlib.redirect_stdout(io.StringIO()):\n"
             "    try:\n        main(['--help'])\n    except SystemExit:\n        pass\n"
             "print(sorted(m for m in sys.modules if m == 'numba' or m.endswith('_kernels')))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
