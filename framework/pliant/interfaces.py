"""The component interfaces, under their first name: kept so that existing code keeps importing from here.

The kinds now live in :mod:`pliant.components` (one module per kind, each with its argument checks); plugins import
them from :mod:`pliant.api`, core code from :mod:`pliant.components`.
"""

from __future__ import annotations

from pliant.components import (
    BASES,
    KINDS,
    Component,
    Context,
    Controller,
    CostModel,
    Driver,
    DriverOptions,
    Learner,
    PathMetric,
    Planner,
    PlannerSpecs,
    PlanningProblem,
    RobotModel,
    SelfContacts,
    SimulationBatch,
    Simulator,
    UrdfDescription,
    check_batch,
)

__all__ = [
    "BASES", "KINDS", "Component", "Context", "Controller", "CostModel", "Driver", "DriverOptions", "Learner",
    "PathMetric", "Planner", "PlannerSpecs", "PlanningProblem", "RobotModel", "SelfContacts", "SimulationBatch",
    "Simulator", "UrdfDescription", "check_batch",
]
