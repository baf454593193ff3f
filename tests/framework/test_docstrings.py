"""The project's rule: a docstring on every public class and function.  Every module-level ``def``, ``async def``
and ``class`` in ``framework/`` and ``plugins/`` whose name does not start with ``_`` has one (read with :mod:`ast`,
nothing is imported)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TREES = ("framework", "plugins")


def missing_docstrings(root: Path = ROOT) -> list[str]:
    """``file:line name`` (the file relative to ``root``) of every public module-level function or class without a
    docstring."""
    out = []
    for tree in TREES:
        for path in sorted((root / tree).rglob("*.py")):
            module = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            for node in module.body:
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) \
                        and not node.name.startswith("_") and ast.get_docstring(node) is None:
                    out.append(f"{path.relative_to(root).as_posix()}:{node.lineno} {node.name}")
    return out


def test_every_public_function_and_class_has_a_docstring():
    missing = missing_docstrings()
    assert not missing, f"{len(missing)} public functions / classes without a docstring:\n" + "\n".join(missing)
