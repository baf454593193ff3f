"""Robot-independent tasks: a scene's ``[task]`` table (docs/scenes.md, "Robot-independent tasks").

A task states what the robot must do without naming joint values: the **goal** is a pose of a tool frame (position,
optional orientation, tolerances) in the world; every robot the scene supports gets a table ``[task.robots.NAME]``
(``NAME`` a URDF robot model such as ``pr2``) with its joint ``group``, its ``tool`` frame, its ``start`` -- a joint
configuration of the group, or a pose of the tool solved by inverse kinematics -- and its ``base`` placement in the
world.  A task-level ``[task.start]`` pose serves every robot whose table gives no start.

The scene is read without a robot (:func:`read_task`); when a pipeline has built the robot,
:func:`resolve_task` turns the task into that robot's start and goal configurations (the goal: the inverse-kinematics
solution nearest the start among ``solutions`` diverse ones) and returns the scene with them filled in, or refuses
in one line naming the robot and the pose it cannot reach.

:func:`robot_scaled` reads option values given relative to the robot's own limits, e.g.
``joint_velocity_limits = {robot = "velocity_limits", scale = 0.25}`` (a quarter of each joint's limit) or
``speed = {robot = "velocity_limits", scale = 0.25, reduce = "min"}`` (one number: the slowest joint's).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pliant.errors import PipelineError, SceneError
from pliant.validation import Fields

#: a tool position (m) and orientation (rad) the goal accepts by default
DEFAULT_POSITION_TOLERANCE = 1e-3
DEFAULT_ORIENTATION_TOLERANCE = 1e-2
IDENTITY_QUATERNION = (0.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True)
class TaskPose:
    """A pose of a tool frame in the world: ``position`` (3,) m, ``orientation`` (4,) quaternion
    ``(qx, qy, qz, qw)`` or ``None`` (any orientation), and the tolerances (m, rad) inverse kinematics meets."""

    position: np.ndarray
    orientation: np.ndarray | None = None
    position_tolerance: float = DEFAULT_POSITION_TOLERANCE
    orientation_tolerance: float = DEFAULT_ORIENTATION_TOLERANCE

    def describe(self) -> str:
        text = f"position {np.round(self.position, 4).tolist()}"
        if self.orientation is not None:
            text += f" orientation {np.round(self.orientation, 4).tolist()}"
        return text + f" (within {self.position_tolerance:g} m" + (
            f", {self.orientation_tolerance:g} rad)" if self.orientation is not None else ")")


@dataclass(frozen=True)
class RobotTask:
    """How one robot model does the task: joint ``group`` (``None``: the scene's ``robot.group``), ``tool`` frame,
    ``start`` (a configuration ``(d,)``, the name of one of the robot's postures, a :class:`TaskPose`, or ``None``
    for the task's start pose) and the base
    placement in the world (``base_position`` (3,) m, ``base_orientation`` (4,) quaternion)."""

    model: str
    tool: str | dict[str, str]
    group: str | None = None
    start: np.ndarray | str | TaskPose | None = None
    base_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_orientation: np.ndarray = field(default_factory=lambda: np.array(IDENTITY_QUATERNION))

    def tool_for(self, group: str | None, source: str | None = None) -> str:
        """The tool frame for joint ``group`` (``tool`` is one frame, or a table of frames by group)."""
        if isinstance(self.tool, str):
            return self.tool
        if group not in self.tool:
            raise SceneError(f"names no tool frame for {self.model}'s group '{group}' (tools for: "
                             f"{', '.join(sorted(self.tool))})", source=source, field=f"task.robots.{self.model}.tool",
                             value=group)
        return self.tool[group]

    @property
    def placed(self) -> bool:
        """Whether the base is anywhere but the world origin."""
        return bool(np.any(self.base_position != 0.0) or np.any(self.base_orientation != IDENTITY_QUATERNION))


@dataclass(frozen=True)
class Task:
    """A scene's robot-independent task.  After :func:`resolve_task`: ``robot`` names the model it was resolved for
    and ``goal_states`` ``(k, d)`` holds the inverse-kinematics solutions at the goal pose."""

    goal: TaskPose
    robots: dict[str, RobotTask]
    start: TaskPose | None = None
    solutions: int = 4
    robot: str | None = None
    goal_states: np.ndarray | None = None

    def for_robot(self, model: str, source: str | None = None) -> RobotTask:
        """The table of robot ``model``; a :class:`SceneError` naming the robots the task supports otherwise."""
        if model not in self.robots:
            raise SceneError(f"the task has no table for robot '{model}' (task.robots: "
                             f"{', '.join(sorted(self.robots))}); add [task.robots.{model}] with its tool and start",
                             source=source, field="task.robots", value=model)
        return self.robots[model]


# --- reading ------------------------------------------------------------------------------------------------------


def _pose(t: Fields, *, tolerances: bool = True) -> TaskPose:
    position = t.vector("position", 3)
    orientation = t.vector("orientation", 4, None)
    if orientation is not None:
        norm = float(np.linalg.norm(orientation))
        if not 0.99 < norm < 1.01:
            t.fail("orientation", "must be a unit quaternion (qx, qy, qz, qw)", orientation.tolist())
        orientation = orientation / norm
    if not tolerances:
        return TaskPose(position, orientation)
    ptol = t.number("position_tolerance", DEFAULT_POSITION_TOLERANCE, positive=True)
    otol = t.number("orientation_tolerance", DEFAULT_ORIENTATION_TOLERANCE, positive=True)
    return TaskPose(position, orientation, ptol, otol)


def _robot(t: Fields, model: str) -> RobotTask:
    if isinstance(t.raw("tool"), dict):             # one tool frame per joint group
        tools = t.table("tool")
        tool = {group: tools.string(group) for group in tools.data}
        if not tool:
            t.fail("tool", "needs a tool frame (or a table of them by joint group)", {})
        tools.finish()
    else:
        tool = t.string("tool")
    group = t.string("group", None)
    start = None
    if t.has("start"):
        raw = t.raw("start")
        if isinstance(raw, dict):
            sub = t.table("start")
            start = _pose(sub)
            sub.finish()
        elif isinstance(raw, str):
            start = t.string("start")               # a named posture of the robot (e.g. "tuck")
        else:
            start = t.vector("start")
    base = t.table("base", {})
    position = base.vector("position", 3, np.zeros(3))
    orientation = base.vector("orientation", 4, np.array(IDENTITY_QUATERNION))
    norm = float(np.linalg.norm(orientation))
    if not 0.99 < norm < 1.01:
        base.fail("orientation", "must be a unit quaternion (qx, qy, qz, qw)", orientation.tolist())
    base.finish()
    t.finish()
    return RobotTask(model, tool, group, start, np.asarray(position, float), np.asarray(orientation, float) / norm)


def read_task(top: Fields, robot) -> Task | None:
    """The scene's ``[task]`` table (``top`` the scene's top-level fields, ``robot`` its
    :class:`~pliant.scene.RobotSpec`), or ``None`` without one.  A task replaces the top-level ``start`` and
    ``goal`` and needs a URDF robot; every field is checked, errors name the field and the value."""
    if not top.has("task"):
        return None
    t = top.table("task")
    for key in ("start", "goal"):
        if top.has(key):
            top.fail(key, "a scene with a [task] states its start and goal there (task.goal, task.robots.NAME.start); "
                          "remove this one", top.raw(key))
    if robot.kind != "urdf":
        t.fail("robots", "a task needs a URDF robot ([robot] kind = \"urdf\"): a rigid body has no tool frame",
               robot.kind)
    goal_table = t.table("goal")
    goal = _pose(goal_table)
    goal_table.finish()
    start = None
    if t.has("start"):
        start_table = t.table("start")
        start = _pose(start_table)
        start_table.finish()
    solutions = t.integer("solutions", 4, minimum=1)
    robots_table = t.table("robots")
    robots = {}
    for name in robots_table.data:
        robots[name] = _robot(robots_table.table(name), name)
    if not robots:
        t.fail("robots", "needs at least one [task.robots.NAME] table (NAME a robot model: its tool and start)", {})
    for name, entry in robots.items():
        if entry.start is None and start is None:
            robots_table.fail(name, "has no start, and the task has no [task.start] pose: give start = [joint "
                                    "values] or start = {position = [...]}", {"tool": entry.tool})
    if robot.model not in robots and not ("/" in robot.model or robot.model.endswith(".urdf")):
        top.table("robot").fail("model", f"the scene's robot is not one the task supports (task.robots: "
                                f"{', '.join(sorted(robots))})", robot.model)
    t.finish()
    return Task(goal=goal, robots=robots, start=start, solutions=solutions)


# --- resolving for a robot ------------------------------------------------------------------------------------------


class _InLimits:
    """The validity of configurations without a collision checker: inside the joint limits."""

    def __init__(self, space) -> None:
        self.space = space

    def states_valid(self, q) -> np.ndarray:
        return np.asarray(self.space.is_valid(np.atleast_2d(q)), dtype=bool).reshape(-1)

    def explain(self, q) -> str | None:
        return None if self.states_valid(q)[0] else "outside the joint limits"


def _reach(robot, tool: str, pose: TaskPose, rng, solutions: int, valid) -> np.ndarray:
    return np.asarray(robot.inverse_kinematics(
        tool, pose.position, pose.orientation, rng=rng, solutions=solutions,
        position_tolerance=pose.position_tolerance, orientation_tolerance=pose.orientation_tolerance, valid=valid),
        dtype=np.float64).reshape(-1, robot.space.dim)


def _who(model: str, robot, tool: str) -> str:
    group = getattr(robot, "group", None)
    return f"robot '{model}'" + (f" (group '{group}', tool '{tool}')" if group else f" (tool '{tool}')")


def resolve_task(scene, robot, rng: np.random.Generator, checker=None):
    """``scene`` with its task's start and goal as configurations of ``robot`` (a bound URDF robot with
    ``model_name`` and ``inverse_kinematics``), the task's ``goal_states`` filled in; unchanged without a task.
    ``checker`` (the pipeline's :class:`~pliant.components.validity.ValidityChecker` of the scene and robot:
    ``states_valid`` and ``explain``) says which configurations are valid; without it, those in the joint limits.

    Raises :class:`SceneError` in one line naming the robot and the pose when no valid (within the joint limits,
    collision-free) configuration reaches the start or goal pose, or when a start configuration is not valid."""
    task = getattr(scene, "task", None)
    if task is None:
        return scene
    model = getattr(robot, "model_name", None)
    if model is None:
        raise SceneError(f"the scene's task needs a URDF robot with inverse kinematics, not {type(robot).__name__}",
                         source=scene.source, field="task", value=type(robot).__name__)
    entry = task.for_robot(model, scene.source)
    tool = entry.tool_for(getattr(robot, "group", None), scene.source)
    checker = checker if checker is not None else _InLimits(robot.space)
    where = f"task.robots.{model}.start"
    if isinstance(entry.start, (np.ndarray, str)):
        start = entry.start
        if isinstance(start, str):
            postures = dict(getattr(robot, "postures", {}) or {})
            if start not in postures:
                raise SceneError(f"is not a named posture of {model}'s group '{getattr(robot, 'group', '?')}' "
                                 f"(postures: {', '.join(sorted(postures)) or 'none'})", source=scene.source,
                                 field=where, value=start)
            start = np.asarray(postures[start], dtype=np.float64)
        if start.shape != (robot.space.dim,):
            raise SceneError(f"needs one value per joint of {model}'s group '{getattr(robot, 'group', '?')}' "
                             f"({robot.space.dim})", source=scene.source, field=where, value=start.tolist())
        if not checker.states_valid(start)[0]:
            reason = checker.explain(start) or "outside the joint limits"
            raise SceneError(f"is not a valid configuration of {model}: {reason}", source=scene.source, field=where,
                             value=start.tolist())
    else:
        pose = entry.start if entry.start is not None else task.start
        found = _reach(robot, tool, pose, rng, 1, checker.states_valid)
        if len(found) == 0:
            raise SceneError(f"{_who(model, robot, tool)} cannot reach the start pose {pose.describe()}: no "
                             "configuration within the joint limits and collision-free",
                             source=scene.source, field=where if entry.start is not None else "task.start",
                             value=model)
        start = found[0]
    found = _reach(robot, tool, task.goal, rng, task.solutions, checker.states_valid)
    if len(found) == 0:
        raise SceneError(f"{_who(model, robot, tool)} cannot reach the goal pose {task.goal.describe()}: no "
                         "configuration within the joint limits and collision-free", source=scene.source,
                         field="task.goal", value=model)
    goal = found[int(np.argmin(robot.space.distance(found, start)))]
    resolved = dataclasses.replace(task, robot=model, goal_states=found)
    return dataclasses.replace(scene, start=np.array(start, dtype=np.float64), goal=np.array(goal), task=resolved)


# --- options scaled from the robot's limits -------------------------------------------------------------------------

#: robot attributes an option may be scaled from (arrays over the planned joints)
SCALABLE = ("velocity_limits", "acceleration_limits", "jerk_limits")
REDUCTIONS = {"min": np.min, "max": np.max, "mean": np.mean}


def robot_scaled(value: Any, robot, source: str | None, field: str) -> Any:
    """An option ``value`` as given, or -- for a table ``{robot = ATTRIBUTE, scale = S, reduce = "min"}`` -- ``S``
    times the robot's ``ATTRIBUTE`` (one of :data:`SCALABLE`; per joint, or reduced to one number by ``min``,
    ``max`` or ``mean``).  Errors name ``field``."""
    if not (isinstance(value, dict) and "robot" in value):
        return value
    unknown = sorted(set(value) - {"robot", "scale", "reduce"})
    if unknown:
        raise PipelineError("unknown key of a robot-scaled value (keys: robot, scale, reduce)", source=source,
                            field=f"{field}.{unknown[0]}", value=value[unknown[0]])
    name = value["robot"]
    if name not in SCALABLE:
        raise PipelineError(f"must name one of the robot's limits: {', '.join(SCALABLE)}", source=source,
                            field=f"{field}.robot", value=name)
    scale = value.get("scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not np.isfinite(scale) or scale <= 0:
        raise PipelineError("must be a positive number", source=source, field=f"{field}.scale", value=scale)
    reduce = value.get("reduce")
    if reduce is not None and reduce not in REDUCTIONS:
        raise PipelineError(f"must be one of {', '.join(REDUCTIONS)}", source=source, field=f"{field}.reduce",
                            value=reduce)
    limits = getattr(robot, name, None)
    if limits is None:
        raise PipelineError(f"the robot ({type(robot).__name__}) declares no {name}", source=source,
                            field=f"{field}.robot", value=name)
    scaled = float(scale) * np.asarray(limits, dtype=np.float64)
    if reduce is not None:
        return float(REDUCTIONS[reduce](scaled))
    return tuple(float(v) for v in scaled)


def scaled_options(options: dict, robot, source: str | None, prefix: str) -> dict:
    """``options`` with every robot-scaled value (:func:`robot_scaled`) replaced by its number(s)."""
    if robot is None or not any(isinstance(v, dict) and "robot" in v for v in options.values()):
        return options
    return {key: robot_scaled(value, robot, source, f"{prefix}.{key}") for key, value in options.items()}
