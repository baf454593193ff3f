"""The plugin registry: components by kind and name, from entry points or Python.

Plugins are modules named by entry points in the group ``pliant`` (see :mod:`pliant.hookspecs`).
They load on first use, not at ``import pliant``.  A plugin that fails to import or register is
recorded with its error (``pliant plugins`` shows it) and does not break the others.  Plugins named
in the environment variable ``PLIANT_DISABLE`` (comma separated) are not loaded.

Public surface::

    pliant.registry.available("planner")            # ['astar', 'straight', ...]
    pliant.registry.create("planner", "straight", step=0.01)
    pliant.registry.register("cost", "mine", MyCost)  # without packaging, from Python
"""

from __future__ import annotations

import importlib
import inspect
import logging
import os
import threading
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any

import pluggy

from pliant.components import BASES, KINDS, Component, Context
from pliant.errors import PliantError, PluginError
from pliant.hookspecs import PROJECT, PliantSpec
from pliant.results import Policy

ENTRY_POINT_GROUP = "pliant"
#: the distribution whose plugins are the built-ins: they load first and win every name collision
BUILTIN_DISTRIBUTION = "pliant"
log = logging.getLogger(__name__)


class _PliantPluginManager(pluggy.PluginManager):
    """A plugin manager that also takes undecorated module functions named ``pliant_*`` as hook implementations
    (as pytest does with ``pytest_*``), so that a misspelled hook name is caught by ``check_pending`` instead of
    being silently ignored."""

    def parse_hookimpl_opts(self, plugin, name: str):
        opts = super().parse_hookimpl_opts(plugin, name)
        if opts is None and name.startswith(f"{PROJECT}_") and inspect.ismodule(plugin):
            function = getattr(plugin, name, None)
            if inspect.isfunction(function):
                return {}
        return opts


def _distribution(ep) -> str:
    dist = getattr(ep, "dist", None)
    return dist.name if dist is not None else ""
DISABLE_ENV = "PLIANT_DISABLE"


@dataclass
class ComponentEntry:
    """One registered component.

    target: the class (or factory) or a lazy ``"module:attr"`` string.
    plugin: the plugin (entry point name) that registered it; ``"<python>"`` for :func:`register`.
    """

    kind: str
    name: str
    target: Any
    description: str = ""
    plugin: str = ""
    distribution: str = ""

    def load(self) -> Any:
        """The class or factory, importing it now if it was registered as a string."""
        if not isinstance(self.target, str):
            return self.target
        module_name, _, attr = self.target.partition(":")
        try:
            obj = importlib.import_module(module_name)
            for part in attr.split("."):
                obj = getattr(obj, part)
        except Exception as exc:  # any import failure of a plugin is reported, not fatal
            raise PluginError(f"cannot load {self.kind} '{self.name}' from plugin '{self.plugin}': "
                              f"{type(exc).__name__}: {exc}", field=f"{self.kind}.name", value=self.name) from exc
        self.target = obj
        return obj


@dataclass
class PluginStatus:
    """What happened to one plugin: ``loaded``, ``failed`` (with ``error``) or ``disabled``."""

    name: str
    distribution: str
    status: str
    error: str = ""


class Registrar:
    """Handed to a plugin's ``pliant_register`` hook; adds components on the plugin's behalf."""

    def __init__(self, registry: Registry, plugin: str, distribution: str) -> None:
        self._registry = registry
        self._plugin = plugin
        self._distribution = distribution

    def add(self, kind: str, name: str, target: Any, description: str = "") -> None:
        """Register ``target`` (a class, factory or ``"module:Class"``) as ``kind``/``name``."""
        self._registry._add(ComponentEntry(kind, name, target, description, self._plugin, self._distribution))


class Registry:
    """Components by kind and name; loads entry-point plugins lazily on first query."""

    def __init__(self) -> None:
        self._entries: dict[tuple[str, str], ComponentEntry] = {}
        self._plugins: dict[str, PluginStatus] = {}
        self._loaded = False
        self._lock = threading.RLock()
        self.manager = _PliantPluginManager(PROJECT)
        self.manager.add_hookspecs(PliantSpec)

    # --- loading ------------------------------------------------------------------------------

    def _disabled_from_env(self) -> set[str]:
        return {n.strip() for n in os.environ.get(DISABLE_ENV, "").split(",") if n.strip()}

    def load(self) -> None:
        """Load every entry-point plugin once (called implicitly by the queries).

        The plugins of pliant's own distribution load first, so a built-in keeps every name it registers: a
        third-party plugin registering the same kind and name fails (named, with the reason, in
        :meth:`plugins`) and none of its components are used.  Between third-party plugins, the one whose entry
        point sorts first keeps the name.
        """
        with self._lock:
            if self._loaded:
                return
            self._loaded = True
            disabled = self._disabled_from_env()
            points = sorted(entry_points(group=ENTRY_POINT_GROUP),
                            key=lambda e: (_distribution(e) != BUILTIN_DISTRIBUTION, e.name))
            for ep in points:
                dist = _distribution(ep)
                if ep.name in disabled:
                    self._plugins[ep.name] = PluginStatus(ep.name, dist, "disabled", f"listed in {DISABLE_ENV}")
                    continue
                try:
                    module = ep.load()
                except Exception as exc:  # a broken plugin is reported, never fatal
                    self._fail(ep.name, dist, f"cannot import: {type(exc).__name__}: {exc}")
                    continue
                self.add_plugin(module, ep.name, dist)

    def add_plugin(self, module: Any, name: str, distribution: str = "") -> bool:
        """Register plugin ``module`` under ``name``: validate its hooks against :class:`PliantSpec` (a misspelled
        ``pliant_*`` hook is an error, as pluggy's ``check_pending``), then call its ``pliant_register`` through
        the plugin manager.  Any failure marks the plugin failed (see :meth:`plugins`), removes what it
        registered and leaves everything else working; returns whether it loaded."""
        with self._lock:
            try:
                self.manager.register(module, name=name)
            except Exception as exc:
                self._fail(name, distribution, f"{type(exc).__name__}: {exc}")
                return False
            try:
                self.manager.check_pending()
                if not any(impl.plugin is module for impl in self.manager.hook.pliant_register.get_hookimpls()):
                    raise PluginError("the plugin module has no pliant_register hook", field="entry point",
                                      value=name)
                self._call_one("pliant_register", module, registrar=Registrar(self, name, distribution))
            except Exception as exc:  # a broken plugin is reported, never fatal
                self.manager.unregister(module)
                self._fail(name, distribution, f"{type(exc).__name__}: {exc}")
                return False
            self._plugins[name] = PluginStatus(name, distribution, "loaded")
            return True

    def _fail(self, name: str, distribution: str, error: str) -> None:
        self._plugins[name] = PluginStatus(name, distribution, "failed", error)
        self._entries = {k: v for k, v in self._entries.items() if v.plugin != name}

    def _call_one(self, hook: str, plugin: Any, **kwargs: Any) -> list[Any]:
        """Call ``hook`` of one plugin only, through the plugin manager."""
        others = [p for p in self.manager.get_plugins() if p is not plugin]
        return self.manager.subset_hook_caller(hook, remove_plugins=others)(**kwargs)

    def call_isolated(self, hook: str, **kwargs: Any) -> list[Any]:
        """Call ``hook`` of every loaded plugin, one at a time: a plugin whose hook raises is logged, marked failed
        (``pliant plugins`` shows which hook failed and why) and skipped; the others' results are returned."""
        self.load()
        results: list[Any] = []
        for plugin in list(self.manager.get_plugins()):
            name = self.manager.get_name(plugin) or repr(plugin)
            if not any(impl.plugin is plugin for impl in getattr(self.manager.hook, hook).get_hookimpls()):
                continue
            try:
                results.extend(self._call_one(hook, plugin, **kwargs))
            except Exception as exc:  # isolate: one plugin's failure must not break the run or the others
                log.warning("plugin '%s' failed in %s: %s: %s", name, hook, type(exc).__name__, exc)
                status = self._plugins.get(name)
                self._plugins[name] = PluginStatus(name, status.distribution if status else "", "failed",
                                                   f"{hook} raised {type(exc).__name__}: {exc}")
        return results

    def _add(self, entry: ComponentEntry) -> None:
        if entry.kind not in KINDS:
            raise PluginError(f"unknown component kind (kinds: {', '.join(KINDS)})", source=entry.plugin,
                              field="kind", value=entry.kind)
        if not entry.name or not isinstance(entry.name, str):
            raise PluginError("component names must be non-empty strings", source=entry.plugin, field="name",
                              value=entry.name)
        key = (entry.kind, entry.name)
        if key in self._entries and self._entries[key].plugin != entry.plugin:
            other = self._entries[key].plugin
            raise PluginError(f"{entry.kind} '{entry.name}' is already registered by plugin '{other}'",
                              source=entry.plugin, field="name", value=entry.name)
        self._entries[key] = entry

    # --- queries ------------------------------------------------------------------------------

    def register(self, kind: str, name: str, target: Any, description: str = "") -> None:
        """Register a component from Python (no packaging needed); plugin name ``<python>``."""
        self.load()
        self._add(ComponentEntry(kind, name, target, description, "<python>", ""))

    def unregister(self, kind: str, name: str) -> None:
        """Remove a component registered with :meth:`register`."""
        self._entries.pop((kind, name), None)

    def available(self, kind: str) -> list[str]:
        """Sorted names of the registered components of ``kind``."""
        self._check_kind(kind)
        self.load()
        return sorted(n for (k, n) in self._entries if k == kind)

    def entry(self, kind: str, name: str) -> ComponentEntry:
        """The entry of ``kind``/``name``; raises :class:`PluginError` listing the alternatives."""
        self._check_kind(kind)
        self.load()
        try:
            return self._entries[(kind, name)]
        except KeyError:
            known = ", ".join(self.available(kind)) or "none registered"
            failed = [p.name for p in self._plugins.values() if p.status != "loaded"]
            hint = f"; plugins not loaded: {', '.join(failed)} (see `pliant plugins`)" if failed else ""
            raise PluginError(f"unknown {kind} (available: {known}){hint}", field=kind, value=name) from None

    def entries(self) -> list[ComponentEntry]:
        self.load()
        return sorted(self._entries.values(), key=lambda e: (e.kind, e.name))

    def plugins(self) -> list[PluginStatus]:
        """Status of every entry-point plugin (loaded, failed with its error, or disabled)."""
        self.load()
        return sorted(self._plugins.values(), key=lambda p: p.name)

    def create(self, kind: str, name: str, context: Context | None = None, *, source: str = "<options>",
               disabled: set[str] | frozenset[str] = frozenset(), **options: Any) -> Component:
        """Build the component ``kind``/``name`` with ``options``; bind it to ``context`` if given.

        ``disabled`` names plugins whose components must not be used (a pipeline's ``disable``).
        Raises :class:`PluginError` for unknown names and :class:`~pliant.errors.ConfigError` for bad
        options.
        """
        if context is not None and not isinstance(context, Context):
            raise PluginError("the third argument is the pipeline's Context; pass options as keywords: "
                              f"create({kind!r}, {name!r}, **options)", field="context",
                              value=type(context).__name__)
        entry = self.entry(kind, name)
        if entry.plugin in disabled:
            raise PluginError(f"plugin '{entry.plugin}' is disabled in this pipeline", field=kind, value=name)
        target = entry.load()
        where = f"{kind} '{name}' from plugin '{entry.plugin}'"
        try:
            if isinstance(target, type) and issubclass(target, Component):
                component = target(dict(options), source=source)
            else:
                component = target(**options)
        except PliantError:
            raise
        except Exception as exc:  # a plugin's own bug: say whose, keep the original as the cause
            raise PluginError(f"{where} failed to build: {type(exc).__name__}: {exc}", field=kind,
                              value=name) from exc
        base = BASES[kind]
        if not isinstance(component, base):
            raise PluginError(f"{where} is not a {base.__name__}", field=kind, value=type(component).__name__)
        if context is not None:
            try:
                component.bind(context)
            except PliantError:
                raise
            except Exception as exc:
                raise PluginError(f"{where} failed to bind to the pipeline: {type(exc).__name__}: {exc}",
                                  field=kind, value=name) from exc
        return component

    def report_hook(self):
        """A callable ``(run=..., directory=...)`` calling every plugin's ``pliant_report``, each isolated
        (:meth:`call_isolated`)."""
        return lambda **kwargs: self.call_isolated("pliant_report", **kwargs)

    @staticmethod
    def _check_kind(kind: str) -> None:
        if kind not in KINDS:
            raise PluginError(f"unknown component kind (kinds: {', '.join(KINDS)})", field="kind", value=kind)


_REGISTRY = Registry()


def default_registry() -> Registry:
    """The process-wide registry used by :func:`available`, :func:`create` and the pipeline."""
    return _REGISTRY


def available(kind: str) -> list[str]:
    """Names of the registered components of ``kind`` (one of :data:`pliant.interfaces.KINDS`)."""
    return _REGISTRY.available(kind)


def create(kind: str, name: str, context: Context | None = None, **options: Any) -> Component:
    """Build a registered component by kind and name; see :meth:`Registry.create`."""
    return _REGISTRY.create(kind, name, context, **options)


def register(kind: str, name: str, target: Any, description: str = "") -> None:
    """Register a component from Python code; see :meth:`Registry.register`."""
    _REGISTRY.register(kind, name, target, description)


def plugins() -> list[PluginStatus]:
    """Status of every entry-point plugin."""
    return _REGISTRY.plugins()


def entries() -> list[ComponentEntry]:
    """Every registered component."""
    return _REGISTRY.entries()


def _load_policy_kinds() -> None:
    """Import every planner plugin's component (policy kinds register when their module is imported), so that a
    policy file can be read in a fresh process; plugins that fail to load are skipped (the registry reports them)."""
    for entry in default_registry().entries():
        if entry.kind == "planner":
            try:
                entry.load()
            except Exception:  # a broken plugin: `pliant plugins` names it; here its policies stay unknown
                continue


Policy.kind_loader = _load_policy_kinds
