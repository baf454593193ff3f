"""Pipelines: a scene plus one component of each kind, wired and run.

A pipeline is built from Python, a dict, or a TOML file::

    name = "demo"
    scene = "triple-wall"          # bundled name or a path relative to this file
    seed = 0
    [planner]
    name = "astar"
    p = 0.5

Components are given as a name (``planner = "straight"``) or a table with ``name`` and options.
Overrides such as ``planner.max_time=5``, ``simulator=pybullet`` or ``scene.variant=soft`` change one
value without editing the file (``pliant run FILE --set ...``).  :meth:`Pipeline.run` plans,
scores and writes a report (``result.json``, ``report.md`` and figures) under ``output``.

Every run ends with a typed :class:`~pliant.results.Outcome` (planned, reached, not planned, stuck, failed, error,
interrupted) and each outcome has one exit status (docs/outcomes.md).  The run folder holds one run only: once the
pipeline is built, a run removes the files the previous run into it wrote (listed in its ``.pliant-files.json``;
nothing else) and writes ``run.json``, then ``result.json`` as soon as planning ends, and ``execution.json`` and
``report.md`` at the end of every outcome -- including an execution that raised (its partial record) and Ctrl-C.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import logging
import os
import re
import time
import tomllib
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pliant.components import KINDS, Component, Context, Driver, Planner, PlanningProblem, check_planner
from pliant.errors import ConfigError, PipelineError, PliantError
from pliant.execution.loop import ExecutionRecord, StepListener, capture, follow, strategy_for
from pliant.execution.strategy import TrajectoryStrategy
from pliant.files import write_json, write_text
from pliant.registry import Registry, default_registry
from pliant.results import Outcome, PlanResult
from pliant.scene import Scene, load_scene
from pliant.seeds import Streams
from pliant.task import resolve_task, scaled_options
from pliant.termination import Budget, interrupted_by
from pliant.validation import check_number, read_toml, safe_name

log = logging.getLogger(__name__)

#: the order in which components are built; each sees the ones before it in its Context
BUILD_ORDER = ("robot", "cost", "simulator", "controller", "planner", "metric", "learner", "driver")
TOP_LEVEL = {"name", "description", "scene", "seed", "output", "disable", "execution", "planning", "trajectory",
             "goal"}
EXECUTION_KEYS = {"period": 0.1, "time_limit": 60.0, "action_limit": 100}
#: ``[execution]`` keys that are not numbers: the world to execute in (a simulator or a driver; ``simulator`` is
#: the older spelling of ``world``), and the scene variant a simulator simulates
EXECUTION_WORLD_KEYS = ("world", "simulator", "variant")
DEFAULT_ROBOT = {"rigid": "rigid", "urdf": "pinocchio"}
#: the run folder's list of the files its run wrote (relative names): what the next run into the folder removes
MANIFEST = ".pliant-files.json"
#: what pliant writes into a run folder under fixed names (a folder from before the manifest is cleared of these)
RUN_FILES = ("run.json", "result.json", "execution.json", "learned.json", "report.md", "view-cache.npz",
             "trajectory.json")


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C (or a cancel) stopped a :meth:`Pipeline.run`; ``record`` is the run so far (outcome ``interrupted``),
    already on file when written.  A :class:`KeyboardInterrupt`, so a script stops as the user asked."""

    def __init__(self, record: RunRecord) -> None:
        self.record = record
        super().__init__(record.error or "interrupted")


@dataclass
class ComponentSpec:
    """A component named in a pipeline: registry ``name`` and its ``options``."""

    name: str
    options: dict[str, Any] = field(default_factory=dict)


@dataclass
class RunRecord:
    """Everything one :meth:`Pipeline.run` produced; handed to report hooks.

    context: the built components (``None`` when building failed: outcome ``error``).
    result: the planner's result (``None`` if the pipeline has no planner).
    metrics: the metric's named scores of the path.
    files: every file the run wrote.
    execution: the execution's record; for an execution that raised, its partial record (outcome ``failed`` or
        ``interrupted``, with ``error``).
    learned: what the learner fitted (``None`` without a learner).
    outcome: how the run ended (:class:`~pliant.results.Outcome`); ``exit_status`` is ``pliant run``'s for it.
    error: what failed or stopped the run, in words (empty when it planned / reached).
    stage: the stage running when the run ended (``build``, ``learn``, ``plan``, ``metric``, ``execute``, ``done``).
    """

    pipeline: Pipeline
    context: Context | None
    result: PlanResult | None
    problem: PlanningProblem | None
    metrics: dict[str, float]
    output: Path
    timings: dict[str, float]
    files: list[Path] = field(default_factory=list)
    execution: ExecutionRecord | None = None
    learned: dict | None = None
    outcome: Outcome = Outcome.PLANNED
    error: str = ""
    stage: str = "build"
    #: the planned path's time parameterisation (:class:`pliant.planning.trajectory.Trajectory`), with a
    #: ``[trajectory]`` table
    trajectory: Any = None
    #: the goal configurations ``(k, d)`` inverse kinematics found for a ``[goal]`` pose
    goal_states: Any = None

    @property
    def exit_status(self) -> int:
        """The exit status of ``pliant run`` for this run: 0 planned / reached, 1 not planned, 2 error, 3 stuck /
        failed, 130 interrupted (:attr:`Outcome.exit_status <pliant.results.Outcome.exit_status>`)."""
        return self.outcome.exit_status

    def summary_rows(self) -> list[tuple[str, str]]:
        """``(quantity, value)`` rows for the report table."""
        rows = [("pipeline", self.pipeline.name), ("outcome", self.outcome.value)]
        if self.error:
            rows.append(("what failed" if self.outcome is not Outcome.INTERRUPTED else "interrupted", self.error))
        if self.context is None:
            scene = self.pipeline.scene_spec
            rows.append(("scene", str(scene.name if isinstance(scene, Scene) else scene)))
        else:
            rows.append(("scene", self.context.scene.name +
                         (f" ({self.context.scene.variant})" if self.context.scene.variant else "")))
        for kind in BUILD_ORDER:
            if kind in self.pipeline.components:
                rows.append((kind, self.pipeline.components[kind].name))
        if self.result is not None:
            r = self.result
            rows += [("status", r.status.value), ("result cost", f"{r.cost:.6g}"), ("seed", str(r.seed))]
            if r.path is not None and self.context is not None:
                rows.append(("waypoints", str(len(r.path))))
                rows.append(("path length", f"{self.context.space.path_length(r.path.configurations):.6g}"))
            limits, used = r.statistics.get("budget"), r.statistics.get("planning_time")
            if isinstance(limits, dict) and used is not None:       # recorded by the core (contracts.checked_plan)
                cap, most = limits.get("max_time"), limits.get("max_iterations")
                text = "no time limit" if cap is None else f"{cap:g} s"
                rows.append(("budget", text + (f" or {most} {limits.get('unit') or 'iterations'}" if most else "")
                             + f", used {used:.2f} s"))
                binding = limits.get("binding")
                if binding:
                    rows.append(("budget binding", "time: wall-clock budget, the result depends on the machine and "
                                 "its load" if binding == "time" else str(binding)))
            for key, value in sorted(r.statistics.items()):
                if isinstance(value, (int, float, str, np.integer, np.floating)):
                    rows.append((key, f"{value:.6g}" if isinstance(value, (float, np.floating)) else str(value)))
        for key, value in sorted(self.metrics.items()):
            rows.append((f"metric {key}", f"{value:.6g}"))
        for key, value in (self.learned or {}).items():
            scalars = value.items() if isinstance(value, dict) else [("", value)]
            for name, x in scalars:
                if isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool):
                    rows.append((f"learned {key} {name}".rstrip(), f"{x:.6g}"))
        if self.execution is not None:
            e = self.execution
            rows += [("execution", e.outcome), ("execution world", e.world),
                     ("execution time (s)", f"{e.times[-1] if len(e.times) else 0.0:.2f}")]
            if e.details is not None:
                rows += e.details.summary()
            rows.append(("steps in contact", f"{int(e.contacts.sum())} of {max(len(e.contacts) - 1, 0)}"))
        for key, value in self.timings.items():
            rows.append((f"time {key} (s)", f"{value:.3f}"))
        return rows


class Pipeline:
    """A scene and its components; see the module docstring for the file format.

    Parameters
    ----------
    scene:
        A :class:`~pliant.scene.Scene`, a bundled scene name, a path, or ``{"name": ..., "variant": ...}``.
    name, seed, output, disable:
        Report name; the seed of the run's generator; the report directory (default ``out/<name>``);
        plugin names not to use.
    **components:
        One per kind (``planner=...``): a name, ``{"name": ..., **options}``, a
        :class:`ComponentSpec` or a ready :class:`~pliant.interfaces.Component`.
    """

    def __init__(self, scene: Any = None, *, name: str = "pipeline", seed: int = 0, output: str | Path | None = None,
                 disable: tuple[str, ...] | list[str] = (), description: str = "", execution: dict | None = None,
                 planning: dict | Budget | None = None, source: str = "<python>",
                 base_dir: Path | None = None, registry: Registry | None = None, trajectory: dict | None = None,
                 goal: dict | None = None, **components: Any) -> None:
        self.source = source
        self.base_dir = base_dir or Path.cwd()
        self.registry = registry or default_registry()
        self.name = name
        self.description = description
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise PipelineError("must be a non-negative integer", source=source, field="seed", value=seed)
        self.seed = int(seed)
        if output is not None and (not isinstance(output, (str, Path)) or not str(output).strip()
                                   or "\0" in str(output)):
            raise PipelineError("must be a directory path (omit it for out/<name>)", source=source, field="output",
                                value=output)
        # a name may hold "/" or ".."; the default folder is made from it safely (an explicit output is the user's)
        self.output = Path(output) if output is not None else Path("out") / safe_name(name)
        if not isinstance(disable, (list, tuple, set, frozenset)) or not all(isinstance(d, str) for d in disable):
            raise PipelineError("must be a list of plugin names", source=source, field="disable", value=disable)
        self.disable = frozenset(disable)
        self.execution, self.world_settings = _execution_settings(execution, source)
        try:        # the request's budget ([planning]: max_iterations, max_time, stop_on_first; docs/determinism.md)
            self.budget = Budget.from_table(planning, source)
        except ConfigError as exc:
            raise PipelineError(exc.message, source=source, field=exc.field,
                                **({"value": exc.value} if exc.has_value else {})) from None
        self.trajectory = _trajectory_settings(trajectory, source)
        self.goal = _goal_settings(goal, source)
        self.scene_spec = scene
        self.components: dict[str, ComponentSpec] = {}
        self.instances: dict[str, Component] = {}
        for kind, spec in components.items():
            if kind not in KINDS:
                raise PipelineError(f"unknown component kind (kinds: {', '.join(KINDS)})", source=source,
                                    field=kind, value=spec)
            if isinstance(spec, Component):
                self.instances[kind] = spec
                self.components[kind] = ComponentSpec(type(spec).__name__, {})
            elif spec is not None:
                self.components[kind] = _component_spec(spec, source, kind)
        if scene is None:
            raise PipelineError("a pipeline needs a scene", source=source, field="scene")

    # --- construction from data ---------------------------------------------------------------

    @classmethod
    def from_dict(cls, data: dict, *, source: str = "<dict>", base_dir: Path | None = None,
                  overrides: list[str] | dict[str, Any] | None = None, registry: Registry | None = None) -> Pipeline:
        """Build from a parsed pipeline table, after applying ``overrides``."""
        if not isinstance(data, dict):
            raise PipelineError("a pipeline must be a table", source=source, field="<top>", value=data)
        data = apply_overrides(data, overrides or [], source)
        unknown = sorted(set(data) - TOP_LEVEL - set(KINDS))
        if unknown:
            raise PipelineError(f"not a known field (fields: {', '.join(sorted(TOP_LEVEL | set(KINDS)))})",
                                source=source, field=unknown[0], value=data[unknown[0]])
        name = data.get("name", Path(source).stem if source.endswith(".toml") else "pipeline")
        if not isinstance(name, str) or not name:
            raise PipelineError("must be a non-empty string", source=source, field="name", value=name)
        description = data.get("description", "")
        if not isinstance(description, str):
            raise PipelineError("must be a string", source=source, field="description", value=description)
        output = data.get("output")
        if output is not None and not isinstance(output, str):
            raise PipelineError("must be a path string", source=source, field="output", value=output)
        components = {k: data[k] for k in KINDS if k in data}
        return cls(data.get("scene"), name=name, seed=data.get("seed", 0), output=output,
                   disable=data.get("disable", ()), description=description, execution=data.get("execution"),
                   planning=data.get("planning"), source=source, trajectory=data.get("trajectory"),
                   goal=data.get("goal"),
                   base_dir=base_dir, registry=registry, **components)

    @classmethod
    def from_file(cls, path: str | Path, overrides: list[str] | dict[str, Any] | None = None,
                  registry: Registry | None = None) -> Pipeline:
        """Read a pipeline TOML file (a bundled pipeline may be named without ``.toml``)."""
        path = _resolve_pipeline_path(path)
        data = read_toml(path, PipelineError)
        if isinstance(data.get("robot"), dict) and "kind" in data["robot"]:
            data = _scene_pipeline(data, path)
        return cls.from_dict(data, source=str(path), base_dir=path.parent, overrides=overrides, registry=registry)

    # --- building and running -----------------------------------------------------------------

    def load_scene(self) -> Scene:
        """The pipeline's scene (loaded, with its variant)."""
        spec = self.scene_spec
        if isinstance(spec, Scene):
            return spec
        variant = None
        if isinstance(spec, dict):
            unknown = sorted(set(spec) - {"name", "variant"})
            if unknown:
                raise PipelineError("scene table takes only name and variant", source=self.source,
                                    field=f"scene.{unknown[0]}", value=spec[unknown[0]])
            variant = spec.get("variant")
            spec = spec.get("name")
        if not isinstance(spec, (str, Path)) or not str(spec):
            raise PipelineError("must be a scene name, a path, or {name, variant}", source=self.source,
                                field="scene", value=spec)
        if variant is not None and not isinstance(variant, str):
            raise PipelineError("must be a string", source=self.source, field="scene.variant", value=variant)
        candidate = self.base_dir / str(spec)
        try:
            target = candidate if candidate.is_file() else spec
        except (OSError, ValueError):  # a name the OS rejects is no file; load_scene explains
            target = spec
        return load_scene(target, variant=variant)

    def check_execution(self) -> None:
        """The ``[execution]`` table against the pipeline, before anything is built: a named world must exist (as a
        simulator or a driver) and something must execute in it (a controller).  Settings nothing would use are an
        error, not silently ignored."""
        settings = self.world_settings
        if not settings.get("world") and "variant" not in settings:
            return
        if "controller" not in self.components and "controller" not in self.instances:
            field = "execution.world" if settings.get("world") else "execution.variant"
            raise PipelineError("an execution world needs a controller to execute with; add a [controller] table "
                                "(e.g. name = \"contact\") or remove this setting", source=self.source, field=field,
                                value=settings["world"].name if settings.get("world") else settings["variant"])
        self._world_kind(self.world_spec().name)

    def build(self) -> Context:
        """Load the scene and create every component, in :data:`BUILD_ORDER`, bound to one context."""
        self.check_execution()
        scene = self.load_scene()
        context = Context(scene=scene, seed=self.seed)
        specs = dict(self.components)
        if "robot" not in specs and "robot" not in self.instances:
            specs["robot"] = ComponentSpec(DEFAULT_ROBOT[scene.robot.kind])
        elif "robot" in specs and not specs["robot"].name:
            specs["robot"] = ComponentSpec(DEFAULT_ROBOT[scene.robot.kind], specs["robot"].options)
        for kind in BUILD_ORDER:
            if kind in self.instances:
                component = self.instances[kind]
                component.bind(context)
            elif kind in specs:
                spec = specs[kind]
                options = scaled_options(spec.options, context.robot, self.source, kind)   # {robot = ...} values
                component = self.registry.create(kind, spec.name, context, source=self.source,
                                                 disabled=self.disable, **options)
            else:
                continue
            if kind == "robot":             # a robot-independent task: this robot's start and goal (pliant.task)
                context.scene = _resolve_task(context.scene, component, self.seed)
            if kind in ("robot", "cost", "simulator", "controller"):
                setattr(context, kind, component)
            else:
                context.extras[kind] = component
            if kind == "planner" and isinstance(component, Planner):
                check_planner(component, context, source=self.source)     # an impossible pipeline fails here
        self._check_simulator_used(context)
        return context

    def _check_simulator_used(self, context: Context) -> None:
        """A simulator nothing would use is an error, not silently ignored (``--set simulator=pybullet`` on a pipeline
        that only plans): nothing executes in it without a controller, and the planner does not simulate.  Metrics
        and learners may simulate without declaring it, so a pipeline with either is not judged."""
        simulator = context.simulator
        if simulator is None or context.controller is not None or "simulator" in self.instances:
            return
        if "metric" in context.extras or "learner" in context.extras:
            return
        planner = context.extras.get("planner")
        if isinstance(planner, Planner) and planner.specs.needs_simulator:
            return
        name = self.components["simulator"].name
        planner_name = f" '{self.components['planner'].name}'" if "planner" in self.components else ""
        raise PipelineError(f"nothing would use the simulator '{name}': no [controller] executes the plan in it "
                            f"and the planner{planner_name} does not simulate; add a controller to execute in it "
                            "(--set controller=NAME, `pliant plugins` lists them) or remove the simulator",
                            source=self.source, field="simulator", value=name)

    def run(self, *, write: bool = True, on_step: StepListener | None = None) -> RunRecord:
        """Build, plan, score, execute and (if ``write``) write the report; returns the :class:`RunRecord`.

        The execution world (``[execution] world``: a simulator, or a robot driver) is created before planning, so
        a wrong name or option fails at once; a driver connects only after planning and disconnects (stopping the
        robot within its limits) when the execution ends for any reason.  ``on_step`` receives every control step
        of the execution (:class:`~pliant.execution.loop.ExecutionStep`).

        Every run ends with a typed ``record.outcome`` (docs/outcomes.md).  An execution that fails (a watchdog, a
        driver fault, a simulator error: any exception) does not raise: the record comes back with outcome
        ``failed``, ``error`` saying what failed and ``execution`` holding the steps executed up to the failure;
        ``stuck`` and ``not planned`` come back the same way.  Two things raise, after the run's files are written:
        an error before execution (bad input, a component refusing the problem: outcome ``error``, the
        :class:`~pliant.errors.PliantError` itself), and Ctrl-C (:class:`RunInterrupted`, a
        :class:`KeyboardInterrupt` carrying the record; also when an anytime planner returned early on Ctrl-C).
        With ``write``, the output folder is checked before anything is built (:meth:`prepare_output`), and once the
        pipeline is built it is cleared of the previous run's files (:meth:`clear_previous_run`) and ``run.json`` is
        written; bad input found while building writes nothing and leaves the previous run's files as they were.
        """
        record = RunRecord(self, None, None, None, {}, self.output, {})
        if write:
            self.prepare_output()
        try:
            self._run_stages(record, on_step, write)
        except KeyboardInterrupt as exc:
            record.outcome = Outcome.INTERRUPTED
            record.error = record.error or f"{interrupted_by()} during {record.stage}"
            if write and record.files:                  # the folder holds this run: finish it
                self._write_report_after(record)
            raise (exc if isinstance(exc, RunInterrupted) else RunInterrupted(record)) from None
        except Exception as exc:
            record.outcome = Outcome.ERROR
            record.error = f"{type(exc).__name__}: {exc}"
            if write and record.files:
                self._write_report_after(record)
            raise
        if write:
            self.write_report(record)
        if record.outcome is Outcome.INTERRUPTED:     # an anytime planner returned its best result on Ctrl-C
            raise RunInterrupted(record)
        return record

    def _run_stages(self, record: RunRecord, on_step: StepListener | None, write: bool) -> None:
        """The stages of :meth:`run`, filling ``record`` as they go (and writing ``result.json`` as soon as planning
        ends); sets ``record.outcome`` unless a stage raises."""
        timings = record.timings
        t0 = time.perf_counter()
        context = record.context = self.build()
        world = None
        if context.controller is not None and (context.simulator is not None or self.world_settings.get("world")):
            world = self.execution_world(context)
        timings["build"] = time.perf_counter() - t0
        if write:                   # built: the input holds; from here on the folder is this run's
            self.clear_previous_run(record.output)
            self._write_run_json(record, "running")
        # one SeedSequence per run, one independent stream per stage (pliant.seeds): adding or removing a stage (a
        # metric, a learner) changes no other stage's numbers
        streams = Streams(self.seed)
        learner = context.extras.get("learner")
        if learner is not None:
            record.stage = "learn"
            t0 = time.perf_counter()
            log.info("learning with %s on %s", self.components["learner"].name, context.scene.name)
            # the learner's own options say where its data come from
            record.learned = learner.fit(None, streams.rng("learning"))
            timings["learn"] = time.perf_counter() - t0
            if write:
                self._write_file(record, "learned.json", lambda path: write_json(path, record.learned, default=str))
        planner = context.extras.get("planner")
        result = None
        if planner is not None:
            record.stage = "plan"
            goal = self._goal_configuration(record, context, streams) if self.goal is not None else None
            problem = record.problem = PlanningProblem.from_context(context, goal=goal, budget=self.budget)
            if goal is not None:
                problem.goal_states = record.goal_states
            elif context.scene.task is not None and context.scene.task.goal_states is not None:
                record.goal_states = problem.goal_states = context.scene.task.goal_states   # its IK solutions
            t0 = time.perf_counter()
            log.info("planning with %s on %s", self.components["planner"].name, context.scene.name)
            result = record.result = planner.plan(problem, streams.rng("planning"))
            timings["plan"] = time.perf_counter() - t0
            if result.seed is None:
                result.seed = self.seed
            if record.goal_states is not None:
                result.statistics["goal_states"] = record.goal_states.tolist()
            result.streams = streams.stages()
            if self.trajectory is not None and result.solved and result.path is not None:
                record.trajectory = self._time_parameterize(result, context.robot)
            if write:                                # the plan is on file before anything else can go wrong
                self._write_file(record, "result.json", result.save)
                if record.trajectory is not None:
                    self._write_file(record, "trajectory.json", lambda path: write_json(
                        path, record.trajectory.to_dict(self.trajectory["rate"])))
            if result.statistics.get("interrupted") is True:
                record.stage, record.outcome = "plan", Outcome.INTERRUPTED
                record.error = (f"{interrupted_by()} during planning; the planner's best result so far "
                                f"({result.status.value}) is kept, nothing was executed")
                return
            metric = context.extras.get("metric")
            if metric is not None and result.path is not None and result.solved:   # a refused path is not scored
                record.stage = "metric"
                t0 = time.perf_counter()
                record.metrics = dict(metric.evaluate(result.path, problem, streams.rng("metrics")))
                timings["metric"] = time.perf_counter() - t0
            if not result.solved:
                record.stage, record.outcome = "done", Outcome.NOT_PLANNED
                record.error = f"the planner returned status '{result.status.value}'" + \
                               (f": {result.message}" if result.message else "")
                return
        if result is not None and (result.path is not None or result.policy is not None) and world is not None:
            record.stage = "execute"
            self._execute(record, world, streams.rng("execution"), on_step)
        record.stage = "done"
        execution = record.execution
        if execution is None:
            record.outcome = Outcome.PLANNED
        elif execution.success:
            record.outcome = Outcome.REACHED
        elif execution.outcome == "failed":
            record.outcome = Outcome.FAILED
            record.error = f"the execution in {execution.world} failed: {execution.error}"
        else:
            record.outcome = Outcome.STUCK
            last = execution.events[-1] if execution.events else ""
            record.error = f"the execution in {execution.world} ended {execution.outcome}" + \
                           (f" ({last})" if last else "") + " short of the goal"

    def _goal_configuration(self, record: RunRecord, context: Context, streams) -> np.ndarray:
        """The ``[goal]`` table's pose solved by the robot's inverse kinematics (valid for the scene's and robot's
        collision checker): its solutions in ``record.goal_states``; the goal is the one nearest the start."""
        from pliant.components.validity import ValidityChecker

        pose = self.goal["pose"]
        checker = ValidityChecker.from_context(context)
        valid = (lambda q: checker.states_valid(q)) if checker is not None else None
        try:
            found = context.robot.inverse_kinematics(
                pose["frame"], pose["position"], pose.get("orientation"), rng=streams.rng("planning", "goal"),
                solutions=pose["solutions"], position_tolerance=pose["position_tolerance"],
                orientation_tolerance=pose["orientation_tolerance"], valid=valid)
        except ConfigError as exc:
            raise PipelineError(exc.message, source=self.source, field=f"goal.pose.{exc.field}",
                                **({"value": exc.value} if exc.has_value else {})) from None
        if len(found) == 0:
            raise PipelineError("inverse kinematics found no valid configuration at this pose (unreachable, out of "
                                "the joint limits or in collision)", source=self.source, field="goal.pose",
                                value=pose)
        record.goal_states = found
        start = np.asarray(context.scene.start, dtype=np.float64)
        return found[int(np.argmin(context.space.distance(found, start)))]

    def _time_parameterize(self, result: PlanResult, robot=None):
        """The ``[trajectory]`` table's time parameterisation of the solved path (its duration in the result's
        statistics)."""
        from pliant.planning.trajectory import time_parameterize

        settings = dict(self.trajectory)
        if settings["limits"] == "robot":                 # the robot's own limits (URDF robots), unless given here
            for key in ("velocity", "acceleration", "jerk"):
                own = getattr(robot, f"{key}_limits", None)
                if settings.get(key) is None and own is None and key != "jerk":
                    raise PipelineError(f"the robot ({type(robot).__name__}) declares no {key} limits: give "
                                        f"trajectory.{key}", source=self.source, field="trajectory.limits",
                                        value="robot")
                if settings.get(key) is None:
                    settings[key] = own
        elif settings["limits"] is not None:              # a limits file: its joints' numbers, unless given here
            from pliant.hardware.limits import load_limits

            path = Path(settings["limits"])
            limits = load_limits(path if path.is_absolute() else self.base_dir / path)
            for key in ("velocity", "acceleration", "jerk"):
                if settings.get(key) is None:
                    settings[key] = getattr(limits, key)
        try:
            trajectory = time_parameterize(result.path.configurations, settings["velocity"],
                                           settings["acceleration"], settings.get("jerk"))
        except ConfigError as exc:
            raise PipelineError(exc.message, source=self.source, field=f"trajectory.{exc.field}",
                                **({"value": exc.value} if exc.has_value else {})) from None
        result.statistics["trajectory"] = {"duration": trajectory.duration, "rest_points": len(trajectory.knots),
                                           "file": "trajectory.json"}
        return trajectory

    def _execute(self, record: RunRecord, world, rng: np.random.Generator, on_step: StepListener | None) -> None:
        """Execute the record's path or policy in ``world``; an exception becomes the partial record of what was
        executed (outcome ``failed``; Ctrl-C: ``interrupted``, then re-raised)."""
        context, result, settings = record.context, record.result, self.execution
        name = self.world_spec().name
        t0 = time.perf_counter()
        with capture() as captured:
            try:
                with world if isinstance(world, Driver) else nullcontext():
                    strategy = strategy_for(result, context, settings)
                    if record.trajectory is not None and result.policy is None:     # [trajectory]: follow it in time
                        strategy = TrajectoryStrategy(record.trajectory, settings["period"], context.space)
                    record.execution = follow(world, context.controller, strategy, rng, period=settings["period"],
                                              time_limit=settings["time_limit"], on_step=on_step, world_name=name)
            except KeyboardInterrupt:
                record.execution = captured.partial("interrupted", "Ctrl-C", name, context.space.dim)
                record.error = f"{interrupted_by()} during the execution; execution.json holds the steps executed"
                raise
            except Exception as exc:
                # any error of the world or the controller ends this execution, not the run: the plan and the steps
                # executed so far are written with a report that names it (a bug's traceback goes to the log)
                error = f"{type(exc).__name__}: {exc}"
                record.execution = captured.partial("failed", error, name, context.space.dim)
                log.error("execution in %s failed: %s", name, error, exc_info=not isinstance(exc, PliantError))
            finally:
                record.timings["execute"] = time.perf_counter() - t0

    # --- the run folder -----------------------------------------------------------------------

    def _track(self, record: RunRecord, *paths: Path) -> None:
        """Add ``paths`` to the run's files and write the folder's manifest (before the files themselves, so that a
        run killed half-way still names everything it may have written)."""
        for path in paths:
            if path not in record.files:
                record.files.append(path)
        out = record.output
        names = set()
        for path in record.files:
            try:
                names.add(Path(path).resolve().relative_to(out.resolve()).as_posix())
            except ValueError:                       # a hook's file outside the folder is not the folder's
                continue
        write_json(out / MANIFEST, {"files": sorted(names)})

    def _write_file(self, record: RunRecord, name: str, writer) -> None:
        path = record.output / name
        self._track(record, path)
        writer(path)

    def _write_run_json(self, record: RunRecord, outcome: str) -> None:
        data = {"pipeline": self.to_dict(), "seed": self.seed, "streams": Streams(self.seed).stages(),
                "outcome": outcome, "error": record.error, "stage": record.stage,
                "metrics": record.metrics, "timings": record.timings}
        self._write_file(record, "run.json", lambda path: write_json(path, data, default=str))

    def _write_report_after(self, record: RunRecord) -> None:
        """:meth:`write_report` for a run that raised; a failure to write is logged, the run's error stays the one
        raised."""
        try:
            self.write_report(record)
        except Exception as exc:  # the disk, or a second Ctrl-C: never hide the run's own error behind it
            log.error("the report of %s could not be written: %s: %s", self.name, type(exc).__name__, exc)
        except KeyboardInterrupt:
            log.error("the report of %s was interrupted", self.name)

    def clear_previous_run(self, out: Path) -> list[Path]:
        """Remove from ``out`` the files an earlier run into it wrote, so that the folder never mixes two runs; returns
        them.  Only files pliant wrote go: those in the folder's manifest (``.pliant-files.json``, every file the
        earlier run wrote, figures and hooks' files included); for a folder from before the manifest whose
        ``run.json`` is a pliant run's, pliant's fixed names (:data:`RUN_FILES`) and the figures its ``report.md``
        shows.  Anything else in the folder (a user's files) stays; so does a folder pliant never wrote."""
        root = out.resolve()
        names: list[str] = []
        manifest = out / MANIFEST
        if manifest.is_file():
            try:
                listed = json.loads(manifest.read_text()).get("files", [])
                names = [n for n in listed if isinstance(n, str)]
            except (OSError, ValueError, AttributeError):
                names = []                           # a torn manifest: fall back to the fixed names below
            names += list(RUN_FILES)
        elif _is_pliant_run_json(out / "run.json"):
            names = list(RUN_FILES)
            try:
                report = (out / "report.md").read_text()
                names += re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", report)
            except (OSError, UnicodeDecodeError):
                pass
        removed = []
        for name in dict.fromkeys(names):
            path = out / name
            try:
                inside = root in path.resolve().parents       # never a file outside the folder ("../x", a link)
                regular = path.is_file() or path.is_symlink()
            except (OSError, ValueError):
                continue
            if not inside or not regular:
                continue
            try:
                path.unlink()
                removed.append(path)
            except OSError as exc:
                raise PipelineError(f"holds a file of an earlier run that cannot be removed ({exc.strerror})",
                                    source=self.source, field="output", value=str(path)) from None
        manifest.unlink(missing_ok=True)
        return removed

    def prepare_output(self) -> Path:
        """Create the report directory now, before any work, so that a directory that cannot be written (a file of
        that name, no permission, a full disk) fails at once instead of after planning; returns it.  Nothing in it
        is touched (:meth:`run` clears the previous run's files once the pipeline is built)."""
        out = self.output
        try:
            if out.exists() and not out.is_dir():
                raise PipelineError("is an existing file, not a directory", source=self.source, field="output",
                                    value=str(out))
            out.mkdir(parents=True, exist_ok=True)
            probe = out / f".pliant-write-test-{os.getpid()}"
            probe.write_bytes(b"")
            probe.unlink()
        except PipelineError:
            raise
        except (OSError, ValueError) as exc:
            reason = getattr(exc, "strerror", None) or exc
            raise PipelineError(f"cannot be created or written ({reason})", source=self.source, field="output",
                                value=str(out)) from None
        return out

    def world_spec(self) -> ComponentSpec:
        """The execution world's name and options: ``[execution] world`` (or its older spelling ``simulator``),
        else the pipeline's simulator."""
        spec = self.world_settings.get("world")
        if spec is None and "simulator" not in self.components:
            raise PipelineError("executing needs a simulator in the pipeline or an [execution] world",
                                source=self.source, field="execution.world")
        return spec if spec is not None else self.components["simulator"]

    def execution_world(self, context: Context):
        """The world executions run in (:class:`~pliant.execution.loop.ExecutionWorld`): the pipeline's simulator, or
        the ``[execution]`` table's ``world`` -- a simulator (with the robot rebuilt for it, on the pipeline's scene
        or its ``variant``) or a robot driver (not yet connected; it checks that it commands the robot's joints).
        """
        settings = self.world_settings
        if not settings.get("world") and "variant" not in settings:
            return context.simulator
        spec = self.world_spec()
        kind = self._world_kind(spec.name)
        scene = self.load_scene()
        if "variant" in settings:
            if kind == "driver":
                raise PipelineError("a scene variant changes a simulated world; a robot driver executes in the real "
                                    "one", source=self.source, field="execution.variant", value=settings["variant"])
            base = self.scene_spec
            name = base.get("name") if isinstance(base, dict) else base
            candidate = self.base_dir / str(name)
            scene = load_scene(candidate if candidate.is_file() else name, variant=settings["variant"])
        world_context = Context(scene=scene, seed=self.seed)
        robot_spec = self.components.get("robot", ComponentSpec(""))
        if not robot_spec.name:
            robot_spec = ComponentSpec(DEFAULT_ROBOT[scene.robot.kind], robot_spec.options)
        world_context.robot = self.registry.create("robot", robot_spec.name, world_context, source=self.source,
                                                   disabled=self.disable, **robot_spec.options)
        if scene.task is not None and getattr(context.scene, "task", None) is not None:    # the planned start and goal
            world_context.scene = dataclasses.replace(scene, start=context.scene.start, goal=context.scene.goal,
                                                      task=context.scene.task)
        return self.registry.create(kind, spec.name, world_context, source=self.source, disabled=self.disable,
                                    **scaled_options(spec.options, world_context.robot, self.source,
                                                     "execution.world"))

    def _world_kind(self, name: str) -> str:
        """``"simulator"`` or ``"driver"``: the kind registered under ``name``."""
        kinds = [kind for kind in ("simulator", "driver") if name in self.registry.available(kind)]
        if len(kinds) == 1:
            return kinds[0]
        if kinds:
            raise PipelineError("names both a simulator and a driver; rename one of the plugins' components",
                                source=self.source, field="execution.world", value=name)
        raise PipelineError(f"no simulator or driver of that name (simulators: "
                            f"{', '.join(self.registry.available('simulator'))}; drivers: "
                            f"{', '.join(self.registry.available('driver')) or 'none'})", source=self.source,
                            field="execution.world", value=name)

    def write_report(self, record: RunRecord) -> None:
        """Write ``run.json`` (with the outcome), ``result.json``, ``learned.json`` and ``execution.json`` (those not
        written yet), figures from report hooks and ``report.md`` -- for every outcome; the folder's manifest lists
        them all."""
        out = record.output
        out.mkdir(parents=True, exist_ok=True)
        written = {Path(p).name for p in record.files if Path(p).parent == out}
        if record.result is not None and "result.json" not in written:
            self._write_file(record, "result.json", record.result.save)
        self._write_run_json(record, record.outcome.value)
        if record.learned is not None and "learned.json" not in written:
            self._write_file(record, "learned.json", lambda path: write_json(path, record.learned, default=str))
        if record.execution is not None:
            self._write_file(record, "execution.json",
                             lambda path: write_json(path, record.execution.to_dict(), indent=None))
        figures: list[Path] = []
        if record.context is not None:          # hooks draw a built run; a run that failed to build has none
            for produced in self.registry.report_hook()(run=record, directory=out):
                figures.extend(Path(p) for p in (produced or []))
        self._track(record, *figures, out / "report.md")
        lines = [f"# {self.name}", ""]
        if self.description:
            lines += [self.description, ""]
        lines += [_outcome_sentence(record), ""]
        lines += ["| quantity | value |", "| --- | --- |"]
        lines += [f"| {k} | {_cell(v)} |" for k, v in record.summary_rows()]
        if figures:
            lines += [""] + [f"![{p.stem}]({p.name})" for p in figures]
        write_text(out / "report.md", "\n".join(lines) + "\n")

    def to_dict(self) -> dict:
        """The pipeline as a table (what a file would contain)."""
        scene = self.scene_spec.name if isinstance(self.scene_spec, Scene) else self.scene_spec
        out: dict[str, Any] = {"name": self.name, "scene": str(scene) if isinstance(scene, Path) else scene,
                               "seed": self.seed, "output": str(self.output)}
        if self.disable:
            out["disable"] = sorted(self.disable)
        planning = {k: v for k, v in self.budget.to_dict().items() if v is not None}
        if planning:
            out["planning"] = planning
        out["execution"] = dict(self.execution)
        if "world" in self.world_settings:
            spec = self.world_settings["world"]
            out["execution"]["world"] = {"name": spec.name, **spec.options}
        if "variant" in self.world_settings:
            out["execution"]["variant"] = self.world_settings["variant"]
        for kind, spec in self.components.items():
            out[kind] = {"name": spec.name, **spec.options} if spec.name else dict(spec.options)
        return out


def _cell(text: str) -> str:
    """``text`` as one markdown table cell (a ``|`` or a line break in an error message would break the table)."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _outcome_sentence(record: RunRecord) -> str:
    """The report's first line: the outcome, its exit status, what failed, and what is on file."""
    outcome = record.outcome
    head = f"**Outcome: {outcome.value}** (exit status {outcome.exit_status})"
    what = {Outcome.PLANNED: "planned; nothing was asked to execute the plan" if record.result is not None
            else "every stage ran",
            Outcome.REACHED: "planned, and the execution reached the goal"}.get(outcome, record.error)
    on_file = []
    if record.result is not None:
        on_file.append("the plan in result.json")
    if record.execution is not None:
        steps = max(len(record.execution.times) - 1, 0)
        on_file.append(f"the execution ({steps} control steps"
                       + (", up to the failure" if record.execution.outcome in ("failed", "interrupted") else "")
                       + ") in execution.json")
    text = f"{head}: {_cell(what)}."
    if outcome not in (Outcome.PLANNED, Outcome.REACHED):
        text += f" Stopped during {record.stage}." if record.stage not in ("done",) else ""
        text += (" On file: " + "; ".join(on_file) + ".") if on_file else " No plan was made."
    return text


def _is_pliant_run_json(path: Path) -> bool:
    """Whether ``path`` is the ``run.json`` of a pliant run (a table with the pipeline's name, scene and seed)."""
    try:
        if not path.is_file() or path.stat().st_size > 10_000_000:
            return False
        pipeline = json.loads(path.read_text()).get("pipeline")
    except (OSError, ValueError, AttributeError, UnicodeDecodeError):
        return False
    return isinstance(pipeline, dict) and {"name", "scene", "seed"} <= set(pipeline)


def _resolve_task(scene: Scene, robot, seed: int) -> Scene:
    """The scene with its robot-independent task (pliant.task) resolved for ``robot``: inverse kinematics on the
    seed's ``task`` stream (the same start and goal in every build of the run), valid for the scene's checker."""
    if scene.task is None:
        return scene
    from pliant.components.validity import ValidityChecker

    return resolve_task(scene, robot, Streams(seed).rng("task"), ValidityChecker(scene, robot))


def check_scene(spec: str | Path, registry: Registry | None = None) -> Scene:
    """Load a scene and check everything a run would check before planning, without planning: the file, every
    variant (each must load), and the robot model a pipeline would build for it (the URDF is found and parsed, the
    model and joint group exist).  Returns the scene; raises the first :class:`~pliant.errors.PliantError`."""
    registry = registry or default_registry()
    scene = load_scene(spec)
    for variant in scene.variants:
        load_scene(spec, variant=variant)
    context = Context(scene=scene)
    context.robot = registry.create("robot", DEFAULT_ROBOT[scene.robot.kind], context, source=str(scene.source))
    _resolve_task(scene, context.robot, 0)          # a task's poses are reachable
    return scene


def _scene_pipeline(scene_data: dict, path: Path) -> dict:
    """The pipeline a scene file recommends in its ``[pipeline]`` table, run on that scene."""
    table = scene_data.get("pipeline")
    if not isinstance(table, dict) or not table:
        raise PipelineError("this is a scene file without a [pipeline] table; add one, or run a pipeline file "
                            "that names it as scene = \"...\"", source=str(path), field="pipeline")
    if "scene" in table:
        raise PipelineError("a scene's own pipeline runs on that scene; remove 'scene'", source=str(path),
                            field="pipeline.scene", value=table["scene"])
    return {"name": scene_data.get("name", path.stem), "scene": path.name, **table}


def _override_execution(table: Any, rest: str, value: Any, source: str, key: str) -> dict:
    """``execution.KEY=value``, ``execution.world=NAME`` (a simulator or a driver; it replaces the world and its
    options, whichever spelling the file used) or ``execution.world.OPTION=value``."""
    table = dict(table) if isinstance(table, dict) else {}
    head, _, option = rest.partition(".")
    if head in ("world", "simulator"):
        current = table.pop("world", None)
        older = table.pop("simulator", None)
        current = current if current is not None else older
        if option:
            if current is None:
                raise PipelineError("set execution.world=NAME before its options", source=source, field=key,
                                    value=value)
            world = dict(current) if isinstance(current, dict) else {"name": current}
            world[option] = value
            table["world"] = world
        else:
            table["world"] = value
    else:
        table[rest] = value
    return table


def _goal_settings(table: Any, source: str) -> dict | None:
    """The ``[goal]`` table: ``pose``, a frame's pose the goal configuration must put it at -- ``frame`` (a link or
    frame of the robot), ``position`` (m, world), optional ``orientation`` (quaternion ``[qx, qy, qz, qw]``),
    ``position_tolerance`` (m, default 0.001), ``orientation_tolerance`` (rad, default 0.01), ``solutions`` (how many
    diverse configurations inverse kinematics looks for, default 4).  ``None`` without the table."""
    if table is None:
        return None
    if not isinstance(table, dict) or set(table) != {"pose"} or not isinstance(table["pose"], dict):
        raise PipelineError("must be a table with a pose table (frame, position, orientation, ...)", source=source,
                            field="goal", value=table)
    pose = dict(table["pose"])
    known = {"frame", "position", "orientation", "position_tolerance", "orientation_tolerance", "solutions"}
    unknown = sorted(set(pose) - known)
    if unknown:
        raise PipelineError(f"unknown field (fields: {', '.join(sorted(known))})", source=source,
                            field=f"goal.pose.{unknown[0]}", value=pose[unknown[0]])
    if not isinstance(pose.get("frame"), str) or not pose["frame"]:
        raise PipelineError("must name a link or frame of the robot", source=source, field="goal.pose.frame",
                            value=pose.get("frame"))
    for key, size in (("position", 3), ("orientation", 4)):
        value = pose.get(key)
        if value is None and key == "orientation":
            continue
        if (not isinstance(value, (list, tuple)) or len(value) != size
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
            raise PipelineError(f"must be {size} numbers", source=source, field=f"goal.pose.{key}", value=value)
    for key, default in (("position_tolerance", 1e-3), ("orientation_tolerance", 1e-2), ("solutions", 4)):
        value = pose.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0 or (
                key == "solutions" and not float(value).is_integer()):
            raise PipelineError("must be a positive " + ("integer" if key == "solutions" else "number"),
                                source=source, field=f"goal.pose.{key}", value=value)
        pose[key] = int(value) if key == "solutions" else float(value)
    return {"pose": pose}


def _trajectory_settings(table: Any, source: str) -> dict | None:
    """The ``[trajectory]`` table: ``velocity`` and ``acceleration`` limits (one number for every coordinate, or one
    per coordinate; per second, squared), an optional ``jerk`` limit, and the ``rate`` (Hz, default 100) of the
    samples written to ``trajectory.json``; or ``limits``: ``"robot"`` for the robot's own (a URDF robot's
    ``velocity_limits``, ``acceleration_limits``, ``jerk_limits``) or a robot's limits file
    (:mod:`pliant.hardware.limits`: its joints' velocity, acceleration and jerk), which the numbers given replace
    (docs/trajectories.md).  ``None`` without the table."""
    if table is None:
        return None
    if not isinstance(table, dict):
        raise PipelineError("must be a table (velocity, acceleration, jerk, rate)", source=source,
                            field="trajectory", value=table)
    known = {"velocity", "acceleration", "jerk", "rate", "limits"}
    unknown = sorted(set(table) - known)
    if unknown:
        raise PipelineError(f"unknown field (fields: {', '.join(sorted(known))})", source=source,
                            field=f"trajectory.{unknown[0]}", value=table[unknown[0]])
    out = {"rate": 100.0, "jerk": None, "limits": None}
    limits = table.get("limits")
    if limits is not None:
        if not isinstance(limits, str) or not limits.strip():
            raise PipelineError("must be the path of a limits file", source=source, field="trajectory.limits",
                                value=limits)
        out["limits"] = limits
    for key in ("velocity", "acceleration", "jerk", "rate"):
        if key not in table:
            if key in ("velocity", "acceleration") and limits is None:
                raise PipelineError("is required (a number, or one per coordinate)", source=source,
                                    field=f"trajectory.{key}")
            continue
        value = table[key]
        if isinstance(value, str):
            try:
                value = [float(v) for v in value.split(",")] if "," in value else float(value)
            except ValueError:
                raise PipelineError("must be a positive number or a list of them", source=source,
                                    field=f"trajectory.{key}", value=table[key]) from None
        array = np.asarray(value, dtype=object)
        try:
            numbers = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            numbers = None
        if (numbers is None or numbers.ndim > (0 if key == "rate" else 1) or numbers.size == 0
                or any(isinstance(v, bool) for v in array.ravel()) or not np.all(np.isfinite(numbers))
                or np.any(numbers <= 0)):
            raise PipelineError("must be a positive number" + ("" if key == "rate" else " or a list of them"),
                                source=source, field=f"trajectory.{key}", value=table[key])
        out[key] = float(numbers) if numbers.ndim == 0 else numbers
    return out


def _execution_settings(table: Any, source: str) -> tuple[dict[str, float], dict[str, Any]]:
    """The ``[execution]`` table: control ``period`` and ``time_limit`` (s), a policy's ``action_limit``;
    optionally the ``world`` to execute in -- a simulator or a robot driver, a name or a table with options (default
    the pipeline's simulator; ``simulator`` is accepted as the older spelling) -- and the scene ``variant`` a
    simulated world runs (e.g. an obstacle added during execution, thesis 5.4.3)."""
    if table is None:
        return dict(EXECUTION_KEYS), {}
    if not isinstance(table, dict):
        raise PipelineError("must be a table with period and time_limit", source=source, field="execution",
                            value=table)
    out: dict[str, float] = dict(EXECUTION_KEYS)
    world: dict[str, Any] = {}
    for key, value in table.items():
        if key in ("world", "simulator"):
            if "world" in world:
                raise PipelineError("give the world once (simulator is the older spelling of world)", source=source,
                                    field=f"execution.{key}", value=value)
            world["world"] = _component_spec(value, source, f"execution.{key}")
        elif key == "variant":
            if not isinstance(value, str) or not value:
                raise PipelineError("must be a scene variant name", source=source, field="execution.variant",
                                    value=value)
            world["variant"] = value
        elif key not in EXECUTION_KEYS:
            raise PipelineError(f"unknown field (fields: {', '.join([*EXECUTION_KEYS, *EXECUTION_WORLD_KEYS])})",
                                source=source, field=f"execution.{key}", value=value)
        elif key == "action_limit":
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise PipelineError("must be a positive integer", source=source, field="execution.action_limit",
                                    value=value)
            out[key] = value
        else:
            out[key] = check_number(value, source, f"execution.{key}", positive=True, error=PipelineError)
    return out, world


def _component_spec(spec: Any, source: str, kind: str) -> ComponentSpec:
    if isinstance(spec, ComponentSpec):
        return spec
    if isinstance(spec, str):
        if not spec:
            raise PipelineError("component name must not be empty", source=source, field=kind, value=spec)
        return ComponentSpec(spec)
    if isinstance(spec, dict):
        options = dict(spec)
        name = options.pop("name", None)
        if kind == "robot" and name is None:
            return ComponentSpec("", options)       # options of the scene's default robot component
        if not isinstance(name, str) or not name:
            raise PipelineError("component table needs a 'name' (a registered component)", source=source,
                                field=f"{kind}.name", value=name)
        return ComponentSpec(name, options)
    raise PipelineError("must be a component name or a table with 'name' and options", source=source,
                        field=kind, value=spec)


def parse_override(text: str, source: str = "<overrides>") -> tuple[str, Any]:
    """``"planner.max_time=5"`` -> ``("planner.max_time", 5)``; values parse as TOML, else strings."""
    if not isinstance(text, str) or "=" not in text:
        raise PipelineError("an override must look like key=value (e.g. planner.max_time=5)", source=source,
                            field="--set", value=text)
    key, _, raw = text.partition("=")
    key = key.strip()
    if not key or any(not part for part in key.split(".")):
        raise PipelineError("an override needs a key before '='", source=source, field="--set", value=text)
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    return key, value


def apply_overrides(data: dict, overrides: list[str] | dict[str, Any], source: str) -> dict:
    """A copy of pipeline ``data`` with overrides applied.

    ``kind=name`` replaces a component (dropping its old options); ``kind.option=value`` sets one
    option; ``scene.variant=v`` picks a scene variant; top-level keys (``seed=3``) are set directly.
    """
    out = copy.deepcopy(data)
    items = overrides.items() if isinstance(overrides, dict) else (parse_override(o, source) for o in overrides)
    for key, value in items:
        head, _, rest = key.partition(".")
        if head not in TOP_LEVEL and head not in KINDS:
            fields = ", ".join(sorted(TOP_LEVEL | set(KINDS)))
            raise PipelineError(f"override names no pipeline field (fields: {fields})", source=source, field=key,
                                value=value)
        if not rest:
            out[head] = value
            continue
        if head == "scene":
            if rest not in ("name", "variant"):
                raise PipelineError("scene overrides are scene=NAME or scene.variant=VARIANT", source=source,
                                    field=key, value=value)
            current = out.get("scene")
            table = dict(current) if isinstance(current, dict) else {"name": current}
            table[rest] = value
            out["scene"] = table
            continue
        if head == "execution":
            out["execution"] = _override_execution(out.get("execution"), rest, value, source, key)
            continue
        if head in ("planning", "trajectory", "goal"):   # planning.max_iterations=N, goal.pose={...}: tables
            current = out.get(head)
            out[head] = {**(current if isinstance(current, dict) else {}), rest: value}
            continue
        if head in TOP_LEVEL:
            raise PipelineError("this field has no sub-fields", source=source, field=key, value=value)
        current = out.get(head)
        if current is None and head == "robot":
            current = {}                     # robot.OPTION=value: an option of the scene's default robot
        if current is None:
            raise PipelineError(f"the pipeline has no {head}; set {head}=NAME first", source=source, field=key,
                                value=value)
        if not isinstance(current, (str, dict)):
            raise PipelineError("must be a component name or a table with 'name' and options", source=source,
                                field=head, value=current)
        table = {"name": current} if isinstance(current, str) else dict(current)
        table[rest] = value
        out[head] = table
    return out


def bundled_pipelines_dir() -> Path:
    """Directory of the pipelines shipped with pliant (``scenes/pipelines``)."""
    from pliant.scene import bundled_scenes_dir

    return bundled_scenes_dir() / "pipelines"


def available_pipelines() -> list[str]:
    """The names of the bundled pipelines (the ``*.toml`` files of :func:`bundled_pipelines_dir`, without the suffix),
    sorted."""
    return sorted(p.stem for p in bundled_pipelines_dir().glob("*.toml"))


def _resolve_pipeline_path(path: str | Path) -> Path:
    if not isinstance(path, (str, Path)) or not str(path):
        raise PipelineError("must be a pipeline file or a bundled pipeline name", field="<file>", value=path)
    p = Path(path)
    try:
        if p.is_file():
            return p
        candidate = bundled_pipelines_dir() / f"{path}.toml"
        if p.suffix != ".toml" and candidate.is_file():
            return candidate
    except (OSError, ValueError):
        pass
    raise PipelineError(f"no pipeline file or bundled pipeline of that name (bundled: "
                        f"{', '.join(available_pipelines()) or 'none'})", source=str(path), field="<file>",
                        value=str(path))


__all__ = ["Pipeline", "ComponentSpec", "RunRecord", "RunInterrupted", "Outcome", "apply_overrides", "check_scene",
           "parse_override",
           "ConfigError",
           "PliantError"]
