"""The import graphs of the core and of every built-in plugin have no cycle, deferred (function-level) imports
included; imports under ``if TYPE_CHECKING:`` never run and are not counted.  (import-linter's contracts in
pyproject.toml keep the direction between the core's layers and between plugins; this keeps each acyclic inside.)"""

from __future__ import annotations

import pathlib

import grimp
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
PLUGINS = sorted(p.name for p in ROOT.glob("plugins/*/pliant_*") if (p / "__init__.py").exists())


def strongly_connected(graph) -> list[list[str]]:
    """The import cycles of ``graph``: its strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.find_modules_directly_imported_by(v):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for module in sorted(graph.modules):
        if module not in index:
            visit(module)
    return cycles


def test_the_cycle_finder_finds_a_known_cycle():
    graph = grimp.ImportGraph()
    for name in ("a", "a.x", "a.y", "a.z"):
        graph.add_module(name)
    graph.add_import(importer="a.x", imported="a.y")
    graph.add_import(importer="a.y", imported="a.x")
    graph.add_import(importer="a.z", imported="a.x")
    assert strongly_connected(graph) == [["a.x", "a.y"]]


@pytest.mark.parametrize("package", ["pliant", *PLUGINS])
def test_the_import_graph_has_no_cycle(package):
    graph = grimp.build_graph(package, include_external_packages=False, exclude_type_checking_imports=True)
    # a package's __init__ importing its own modules is not a cycle among modules: drop those edges
    for module in list(graph.modules):
        for imported in list(graph.find_modules_directly_imported_by(module)):
            if imported.startswith(module + "."):
                graph.remove_import(importer=module, imported=imported)
    assert strongly_connected(graph) == []
