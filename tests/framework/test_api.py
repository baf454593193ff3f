"""The plugin API (pliant.api): every plugin under plugins/ imports the core only through it, and every name it
declares resolves."""

from __future__ import annotations

import ast
import pathlib

import pliant.api
import pytest

PLUGINS = pathlib.Path(__file__).resolve().parents[2] / "plugins"


def _core_imports(path: pathlib.Path):
    """(line, module, names) of every import of the core in ``path`` (deferred imports included)."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module and \
                (node.module == "pliant" or node.module.startswith("pliant.")):
            yield node.lineno, node.module, [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "pliant" or alias.name.startswith("pliant."):
                    yield node.lineno, alias.name, []


def test_every_plugin_imports_the_core_only_through_the_plugin_api():
    files = sorted(PLUGINS.rglob("*.py"))
    assert len(files) > 100
    bad = []
    for path in files:
        for line, module, names in _core_imports(path):
            through_api = module == "pliant.api" or (module == "pliant" and names == ["api"])
            if not through_api:
                bad.append(f"{path.relative_to(PLUGINS)}:{line} imports {module} {names}")
            elif module == "pliant.api":
                missing = [n for n in names if n != "*" and n not in pliant.api.__all__]
                if missing:
                    bad.append(f"{path.relative_to(PLUGINS)}:{line}: {missing} not in pliant.api")
    assert not bad, "\n".join(bad)


def test_every_declared_name_resolves_and_unknown_names_are_refused():
    for name in pliant.api.__all__:
        assert getattr(pliant.api, name) is not None, name
    assert pliant.api.registry.available("planner")
    assert pliant.api.PlanningProblem is pliant.PlanningProblem
    with pytest.raises(AttributeError, match=r"pliant\.api has no name 'Nope'"):
        pliant.api.Nope  # noqa: B018
