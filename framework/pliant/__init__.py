"""pliant: motion planning and execution where contact, deformation and uncertainty matter.

The core defines configuration spaces, scenes, the component interfaces, results, the plugin
registry and pipelines; algorithms, robots and simulators arrive as plugins (entry-point group
``pliant``).  ``import pliant`` stays light: heavy libraries load inside plugin factories.

Quick use::

    import pliant
    scene = pliant.load_scene("triple-wall")
    pliant.registry.available("planner")
    record = pliant.Pipeline.from_file("demo").run()
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

from pliant.version import __version__

_LAZY = {
    "load_scene": ("pliant.scene", "load_scene"),
    "Scene": ("pliant.scene", "Scene"),
    "Pipeline": ("pliant.pipeline", "Pipeline"),
    "PlanResult": ("pliant.results", "PlanResult"),
    "Status": ("pliant.results", "Status"),
    "Outcome": ("pliant.results", "Outcome"),
    "Path": ("pliant.results", "Path"),
    "PliantError": ("pliant.errors", "PliantError"),
    "Termination": ("pliant.termination", "Termination"),
    "PlanningProblem": ("pliant.interfaces", "PlanningProblem"),
}

if TYPE_CHECKING:
    from pliant import registry
    from pliant.components import PlanningProblem
    from pliant.errors import PliantError
    from pliant.pipeline import Pipeline
    from pliant.results import Outcome, Path, PlanResult, Status
    from pliant.scene import Scene, load_scene
    from pliant.termination import Termination


def __getattr__(name: str):
    if name == "registry":
        return import_module("pliant.registry")
    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(import_module(module), attr)
    raise AttributeError(f"module 'pliant' has no attribute {name!r}")


__all__ = [
    "Outcome", "Path", "PlanResult", "PlanningProblem", "PliantError", "Pipeline", "Scene", "Status", "Termination",
    "__version__", "load_scene", "registry",
]
