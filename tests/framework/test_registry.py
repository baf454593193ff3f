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
