"""The components layer: the kinds of pluggable component, the planning request and the checks around them.

One module per kind -- :mod:`~pliant.components.robot`, :mod:`~pliant.components.cost`,
:mod:`~pliant.components.simulator`, :mod:`~pliant.components.controller`, :mod:`~pliant.components.planner`,
:mod:`~pliant.components.metric`, :mod:`~pliant.components.driver`, :mod:`~pliant.components.learner` -- each with the
argument checks the core puts in front of its entry points; :mod:`~pliant.components.problem` (the planning request)
with :mod:`~pliant.components.validity` (the scene"s and robot"s collision checker every planner uses);
:mod:`~pliant.components.context` (what one pipeline"s components share).

Every built-in and third-party component derives from one of these abstract classes, declares an ``Options``
dataclass (:mod:`pliant.options`) and is registered under a *kind* and a *name* (:mod:`pliant.registry`).
Components meet only through these interfaces: a planner asks the :class:`CostModel` for costs and the
:class:`Simulator` for outcomes, never a concrete plugin.  Plugins import these names from :mod:`pliant.api`.

Array conventions (docs/conventions.md): float64, batch first.  ``d`` is the space"s coordinate count
(``space.dim``), ``t`` its tangent dimension (``space.tangent_dim``: 6 for SE(3)), ``n`` a batch size, ``m`` a
number of body points.  SI units throughout.
"""

from __future__ import annotations

from pliant.components.base import KINDS, Component, check_batch
from pliant.components.checks import check_duration, check_rng, check_vector, space_label
from pliant.components.context import Context
from pliant.components.controller import Controller, checked_command
from pliant.components.cost import CostModel
from pliant.components.driver import Driver, DriverOptions
from pliant.components.learner import Learner
from pliant.components.metric import PathMetric, checked_evaluate
from pliant.components.planner import Planner, PlannerSpecs, check_planner, checked_plan, validated_result
from pliant.components.problem import PlanningProblem
from pliant.components.robot import RobotModel, SelfContacts, UrdfDescription
from pliant.components.simulator import (
    SimulationBatch,
    Simulator,
    check_starts,
    checked_reset,
    checked_simulate,
    checked_step,
    refused_starts,
)
from pliant.components.validity import ValidityChecker, Verdict

BASES: dict[str, type[Component]] = {
    "simulator": Simulator, "robot": RobotModel, "controller": Controller, "planner": Planner,
    "metric": PathMetric, "cost": CostModel, "learner": Learner, "driver": Driver,
}

__all__ = [
    "BASES", "Component", "Context", "Controller", "CostModel", "Driver", "DriverOptions", "KINDS", "Learner",
    "PathMetric", "Planner", "PlannerSpecs", "PlanningProblem", "RobotModel", "SelfContacts", "SimulationBatch",
    "Simulator", "UrdfDescription", "ValidityChecker", "Verdict", "check_batch", "check_duration",
    "check_planner", "check_rng", "check_starts", "check_vector", "checked_command", "checked_evaluate",
    "checked_plan", "checked_reset", "checked_simulate", "checked_step", "refused_starts", "space_label",
    "validated_result",
]
