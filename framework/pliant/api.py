"""The plugin API: everything a pliant plugin may import from the core, and nothing else.

A plugin (built in under ``plugins/`` or a third-party package registered under the ``pliant`` entry-point group)
imports the core only through this module::

    from pliant.api import Planner, PlannerSpecs, PlanningProblem, PlanResult, Status, hookimpl, option

An import-linter contract (``pyproject.toml``) and a test (``tests/framework/test_api.py``) keep every plugin to it;
the core's other modules are private and may move between releases.  The names below are grouped as a plugin
author meets them (docs/writing-plugins.md): errors; options, validation and files; budgets; spaces, geometry and
scenes; the component interfaces and results; planning and execution helpers; the hardware layer; the registry,
hooks and pipelines; experiments.

Importing this module is cheap: each name loads its core module on first use (PEP 562), so an entry-point module
that imports a few names does not load the experiment machinery.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

from pliant import __version__ as __version__

# name -> (core module, attribute), by group
_NAMES: dict[str, tuple[str, str]] = {
    # --- execution
    "ActuationNoise": ("pliant.execution.noise", "ActuationNoise"),
    "actuator_limits": ("pliant.execution.actuation", "actuator_limits"),
    "angular_mask": ("pliant.execution.actuation", "angular_mask"),
    "ControlLaw": ("pliant.execution.actuation", "ControlLaw"),
    "Done": ("pliant.execution.strategy", "Done"),
    "Drive": ("pliant.execution.strategy", "Drive"),
    "execute_path": ("pliant.execution.loop", "execute"),
    "ExecutionDetails": ("pliant.execution.record", "ExecutionDetails"),
    "ExecutionOutcome": ("pliant.execution.record", "ExecutionOutcome"),
    "ExecutionRecord": ("pliant.execution.record", "ExecutionRecord"),
    "ExecutionStrategy": ("pliant.execution.strategy", "ExecutionStrategy"),
    "ExecutionWorld": ("pliant.execution.loop", "ExecutionWorld"),
    "follow": ("pliant.execution.loop", "follow"),
    "Move": ("pliant.execution.strategy", "Move"),
    "Observation": ("pliant.execution.strategy", "Observation"),
    "Place": ("pliant.execution.strategy", "Place"),
    "ScriptedStrategy": ("pliant.execution.strategy", "ScriptedStrategy"),
    "limit_velocity": ("pliant.execution.actuation", "limit_velocity"),
    "NOISE_MODELS": ("pliant.execution.noise", "NOISE_MODELS"),
    "StepListener": ("pliant.execution.record", "StepListener"),
    "SteppedOptions": ("pliant.execution.stepping", "SteppedOptions"),
    "SteppedSimulator": ("pliant.execution.stepping", "SteppedSimulator"),
    "truncated_normal": ("pliant.execution.noise", "truncated_normal"),
    "VoxelStartCheck": ("pliant.execution.starts", "VoxelStartCheck"),
    # --- budgets
    "BudgetExpired": ("pliant.termination", "BudgetExpired"),
    "checkpoint": ("pliant.termination", "checkpoint"),
    "Condition": ("pliant.termination", "Condition"),
    "Termination": ("pliant.termination", "Termination"),
    "time_left": ("pliant.termination", "time_left"),
    "Budget": ("pliant.termination", "Budget"),
    "budget_deprecation": ("pliant.termination", "budget_deprecation"),
    # --- random streams per stage (one SeedSequence per run)
    "Streams": ("pliant.seeds", "Streams"),
    "derived_seed": ("pliant.seeds", "derived_seed"),
    "stream": ("pliant.seeds", "stream"),
    # --- registry, hooks and pipelines
    "add_executor_arguments": ("pliant.experiments.executor", "add_executor_arguments"),
    "add_common_arguments": ("pliant.cli.commands", "add_common_arguments"),
    "add_page_arguments": ("pliant.cli.commands", "add_page_arguments"),
    "cli_main": ("pliant.cli", "main"),
    "Alias": ("pliant.cli.commands", "Alias"),
    "Command": ("pliant.cli.commands", "Command"),
    "LOOPBACK": ("pliant.cli.commands", "LOOPBACK"),
    "CATALOGUE": ("pliant.experiments.reproduce", "CATALOGUE"),
    "check_settings": ("pliant.experiments.runs", "check_settings"),
    "create": ("pliant.registry", "create"),
    "current_executor": ("pliant.experiments.executor", "current"),
    "DEFAULT_ROBOT": ("pliant.pipeline", "DEFAULT_ROBOT"),
    "Headline": ("pliant.experiments.reproduce", "Headline"),
    "hookimpl": ("pliant.hookspecs", "hookimpl"),
    "LocalExecutor": ("pliant.experiments.executor", "LocalExecutor"),
    "ompl_database": ("pliant.experiments.ompl", "ompl_database"),
    "open_log": ("pliant.experiments.runs", "open_log"),
    "parse_override": ("pliant.pipeline", "parse_override"),
    "Pipeline": ("pliant.pipeline", "Pipeline"),
    "PlannerRuns": ("pliant.experiments.ompl", "PlannerRuns"),
    "Reproduction": ("pliant.experiments.reproduce", "Reproduction"),
    "ReproductionOutcome": ("pliant.experiments.reproduce", "Outcome"),
    "ReproductionRun": ("pliant.experiments.reproduce", "ReproductionRun"),
    "Row": ("pliant.experiments.reproduce", "Row"),
    "run_properties": ("pliant.experiments.ompl", "run_properties"),
    "run_tasks": ("pliant.experiments.runs", "run_tasks"),
    "RunInterrupted": ("pliant.pipeline", "RunInterrupted"),
    "write_ompl_log": ("pliant.experiments.ompl", "write_ompl_log"),
    # --- planning helpers
    "ac_connected": ("pliant.planning.clustering", "ac_connected"),
    "cluster_particles": ("pliant.planning.clustering", "cluster_particles"),
    "ClusteringContext": ("pliant.planning.clustering", "ClusteringContext"),
    "matches": ("pliant.planning.clustering", "matches"),
    "perturb": ("pliant.planning.shortcut", "perturb"),
    "shortcut": ("pliant.planning.shortcut", "shortcut"),
    "time_parameterize": ("pliant.planning.trajectory", "time_parameterize"),
    "Trajectory": ("pliant.planning.trajectory", "Trajectory"),
    "Tree": ("pliant.planning.tree", "Tree"),
    "warm_up": ("pliant.planning.warmup", "warm_up"),
    # --- spaces, geometry and scenes
    "arc_margin": ("pliant.geometry.topology", "arc_margin"),
    "box_tetrahedra": ("pliant.geometry.tetmesh", "box_tetrahedra"),
    "box_ticks": ("pliant.geometry.tetmesh", "box_ticks"),
    "CompoundSpace": ("pliant.spaces", "CompoundSpace"),
    "FREE_VOXEL": ("pliant.geometry.voxelgrid", "FREE"),
    "load_scene": ("pliant.scene", "load_scene"),
    "matrix_to_quat": ("pliant.geometry.rotations", "matrix_to_quat"),
    "point_runs": ("pliant.geometry.broad_phase", "point_runs"),
    "spatial_order": ("pliant.geometry.broad_phase", "spatial_order"),
    "spatial_runs": ("pliant.geometry.broad_phase", "spatial_runs"),
    "PunctureChecker": ("pliant.geometry.topology", "PunctureChecker"),
    "quat_angle": ("pliant.geometry.rotations", "quat_angle"),
    "quat_conjugate": ("pliant.geometry.rotations", "quat_conjugate"),
    "quat_from_axis_angle": ("pliant.geometry.rotations", "quat_from_axis_angle"),
    "quat_multiply": ("pliant.geometry.rotations", "quat_multiply"),
    "quat_slerp": ("pliant.geometry.rotations", "quat_slerp"),
    "quat_to_matrix": ("pliant.geometry.rotations", "quat_to_matrix"),
    "quat_to_rotvec": ("pliant.geometry.rotations", "quat_to_rotvec"),
    "RealVectorSpace": ("pliant.spaces", "RealVectorSpace"),
    "RobotSpec": ("pliant.scene", "RobotSpec"),
    "rotation_z": ("pliant.geometry.rotations", "rotation_z"),
    "Scene": ("pliant.scene", "Scene"),
    "BodyPhysics": ("pliant.physics", "BodyPhysics"),
    "footprint_mean_radius": ("pliant.physics", "footprint_mean_radius"),
    "inertia_diagonal": ("pliant.physics", "inertia_diagonal"),
    "report_ignored": ("pliant.physics", "report_ignored"),
    "ScenePhysics": ("pliant.physics", "ScenePhysics"),
    "support_limits": ("pliant.physics", "support_limits"),
    "SE2Space": ("pliant.spaces", "SE2Space"),
    "SE3Space": ("pliant.spaces", "SE3Space"),
    "Space": ("pliant.spaces", "Space"),
    "space_from_dict": ("pliant.spaces", "space_from_dict"),
    "tetrahedron_volumes": ("pliant.geometry.tetmesh", "tetrahedron_volumes"),
    "VoxelGrid": ("pliant.geometry.voxelgrid", "VoxelGrid"),
    "wrap_angle": ("pliant.geometry.rotations", "wrap_angle"),
    "write_vtk": ("pliant.geometry.tetmesh", "write_vtk"),
    # --- errors
    "ConfigError": ("pliant.errors", "ConfigError"),
    "ConnectionLost": ("pliant.errors", "ConnectionLost"),
    "DimensionError": ("pliant.errors", "DimensionError"),
    "DriverError": ("pliant.errors", "DriverError"),
    "EmergencyStop": ("pliant.errors", "EmergencyStop"),
    "LimitViolation": ("pliant.errors", "LimitViolation"),
    "PipelineError": ("pliant.errors", "PipelineError"),
    "PlanningError": ("pliant.errors", "PlanningError"),
    "PliantError": ("pliant.errors", "PliantError"),
    "RobotDisabled": ("pliant.errors", "RobotDisabled"),
    "RobotNotReady": ("pliant.errors", "RobotNotReady"),
    "SceneError": ("pliant.errors", "SceneError"),
    "SimulationError": ("pliant.errors", "SimulationError"),
    # --- component interfaces and results
    "check_batch": ("pliant.components", "check_batch"),
    "Context": ("pliant.components", "Context"),
    "Controller": ("pliant.components", "Controller"),
    "CostModel": ("pliant.components", "CostModel"),
    "Driver": ("pliant.components", "Driver"),
    "DriverOptions": ("pliant.components", "DriverOptions"),
    "Learner": ("pliant.components", "Learner"),
    "Path": ("pliant.results", "Path"),
    "PathMetric": ("pliant.components", "PathMetric"),
    "Planner": ("pliant.components", "Planner"),
    "PlannerSpecs": ("pliant.components", "PlannerSpecs"),
    "PlanningProblem": ("pliant.components", "PlanningProblem"),
    "PlanResult": ("pliant.results", "PlanResult"),
    "Policy": ("pliant.results", "Policy"),
    "RobotModel": ("pliant.components", "RobotModel"),
    "RobotTask": ("pliant.task", "RobotTask"),
    "resolve_task": ("pliant.task", "resolve_task"),
    "robot_scaled": ("pliant.task", "robot_scaled"),
    "Task": ("pliant.task", "Task"),
    "TaskPose": ("pliant.task", "TaskPose"),
    "SelfContacts": ("pliant.components", "SelfContacts"),
    "SimulationBatch": ("pliant.components", "SimulationBatch"),
    "Simulator": ("pliant.components", "Simulator"),
    "Status": ("pliant.results", "Status"),
    "UrdfDescription": ("pliant.components", "UrdfDescription"),
    # --- options and validation
    "build_options": ("pliant.options", "build_options"),
    "cached_arrays": ("pliant.cache", "cached_arrays"),
    "example_robot_data_dir": ("pliant.robot_data", "example_robot_data_dir"),
    "Fields": ("pliant.validation", "Fields"),
    "fingerprint": ("pliant.cache", "fingerprint"),
    "ProcessMemo": ("pliant.cache", "ProcessMemo"),
    "option": ("pliant.options", "option"),
    "OptionDeprecationWarning": ("pliant.options", "OptionDeprecationWarning"),
    "ProgressLine": ("pliant.progress", "ProgressLine"),
    "read_json": ("pliant.files", "read_json"),
    "read_jsonl": ("pliant.files", "read_jsonl"),
    "read_toml": ("pliant.validation", "read_toml"),
    "rewrite_jsonl": ("pliant.files", "rewrite_jsonl"),
    "safe_name": ("pliant.validation", "safe_name"),
    "write_json": ("pliant.files", "write_json"),
    "write_text": ("pliant.files", "write_text"),
    # --- hardware
    "JointLimits": ("pliant.hardware.limits", "JointLimits"),
    "JointState": ("pliant.hardware.state", "JointState"),
    "load_limits": ("pliant.hardware.limits", "load_limits"),
    "RobotStatus": ("pliant.hardware.state", "RobotStatus"),
}

if TYPE_CHECKING:
    pass


def __getattr__(name: str):
    if name == "registry":
        return import_module("pliant.registry")
    if name in _NAMES:
        module, attr = _NAMES[name]
        value = getattr(import_module(module), attr)
        globals()[name] = value                 # later lookups skip this function
        return value
    raise AttributeError(f"pliant.api has no name {name!r} (the plugin API is listed in pliant.api.__all__)")


def __dir__() -> list[str]:
    return sorted(__all__)


__all__ = sorted([*_NAMES, "registry", "__version__"])
