"""The contracts between pliant's components.

Every built-in and third-party component derives from one of the abstract classes below, declares
an ``Options`` dataclass (see :mod:`pliant.options`) and is registered under a *kind* and a *name*
(see :mod:`pliant.registry`).  Components meet only through these interfaces: a planner asks the
:class:`CostModel` for costs and the :class:`Simulator` for outcomes, never a concrete plugin.

Array conventions (docs/conventions.md): float64, batch first.  ``d`` is the space's coordinate
count (``space.dim``), ``t`` its tangent dimension (``space.tangent_dim``: 6 for SE(3)), ``n`` a
batch size, ``m`` a number of body points.  SI units throughout.
"""

from __future__ import annotations

import itertools
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pliant.contracts import (
    checked_command,
    checked_evaluate,
    checked_plan,
    checked_reset,
    checked_simulate,
    checked_step,
)
from pliant.errors import DimensionError, DriverError, JointMismatch, LimitViolation, PlanningError, SimulationError
from pliant.hardware.limits import JointLimits
from pliant.hardware.state import JointState, RobotStatus
from pliant.options import NoOptions, build_options, option
from pliant.results import Path, PlanResult, Status
from pliant.spaces import Space
from pliant.termination import Termination

if TYPE_CHECKING:
    from pliant.execution.actuation import ControlLaw
    from pliant.scene import Scene

KINDS = ("simulator", "robot", "controller", "planner", "metric", "cost", "learner", "driver")


@dataclass
class Context:
    """What the components of one pipeline share; filled in dependency order by the pipeline.

    Order: scene -> robot -> cost -> simulator -> controller -> planner / metric / learner / driver.
    A component's :meth:`Component.bind` sees everything built before it.
    """

    scene: Scene | None = None
    robot: RobotModel | None = None
    cost: CostModel | None = None
    simulator: Simulator | None = None
    controller: Controller | None = None
    seed: int = 0
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def space(self) -> Space:
        if self.robot is None:
            raise PlanningError("this component needs a robot (and its configuration space) in the pipeline",
                                field="robot")
        return self.robot.space


class Component(ABC):  # noqa: B024 - ABCMeta enforces the abstract methods of the kinds below
    """Base of every pluggable component.

    Subclasses set :attr:`Options` to a frozen dataclass of documented options; the constructor
    validates keyword options against it (unknown names and bad values raise
    :class:`~pliant.errors.ConfigError`).  :meth:`bind` receives the pipeline's :class:`Context`.
    """

    kind: ClassVar[str] = ""
    Options: ClassVar[type] = NoOptions
    #: a bundled scene in which the conformance kit exercises this component (None: the default)
    example_scene: ClassVar[str | None] = None
    #: other components the conformance kit should create alongside, by kind (``{"cost": "voxel"}``)
    example_components: ClassVar[dict[str, str]] = {}

    def __init__(self, options: Any = None, *, source: str = "<options>", **kwargs: Any) -> None:
        if options is not None and kwargs:
            raise TypeError("pass either an Options instance or keyword options, not both")
        if isinstance(options, self.Options):
            self.options = options
        else:
            self.options = build_options(self.Options, options if options is not None else kwargs,
                                         source=source, prefix=self.kind)
        self.context: Context | None = None

    def bind(self, context: Context) -> None:
        """Attach to a pipeline's context.  Override to prepare (and call ``super().bind``)."""
        self.context = context

    def require(self, attribute: str):
        """The context's ``attribute`` (``"scene"``, ``"robot"``...), or a clear error if absent."""
        value = getattr(self.context, attribute, None) if self.context is not None else None
        if value is None:
            raise PlanningError(f"{type(self).__name__} needs a {attribute}; bind it to a context that has one",
                                field=attribute)
        return value


def check_batch(q: Any, space: Space, field: str = "configurations") -> tuple[np.ndarray, bool]:
    """``q`` as ``(n, d)`` float64 plus whether the input was a single ``(d,)`` configuration.

    Raises :class:`DimensionError` for a wrong width or non-finite entries.
    """
    arr = np.asarray(q, dtype=np.float64)
    single = arr.ndim == 1
    arr = np.atleast_2d(arr)
    if arr.ndim != 2 or arr.shape[1] != space.dim:
        raise DimensionError(f"must be (n, {space.dim}) or ({space.dim},) for this {space.kind} space",
                             field=field, value=list(np.shape(q)))
    if not np.all(np.isfinite(arr)):
        raise DimensionError("must be finite", field=field, value=np.asarray(q).tolist())
    return arr, single


@dataclass
class SelfContacts:
    """Contacts between a robot's own links at one configuration (``c`` contacts, ``d`` joints).

    point_a / point_b: ``(c, 3)`` world points (m) on the two links; normal: ``(c, 3)`` unit, from
    link a toward link b; depth: ``(c,)`` penetration (m, >= 0); mass_a / mass_b: ``(c,)`` mass (kg)
    of each link with everything it carries further down the chain (thesis app. B); jacobian_a /
    jacobian_b: ``(c, 3, d)`` Jacobians of the two points.
    """

    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    mass_a: np.ndarray
    mass_b: np.ndarray
    jacobian_a: np.ndarray
    jacobian_b: np.ndarray

    def __len__(self) -> int:
        return len(self.depth)


@dataclass(frozen=True)
class UrdfDescription:
    """How to load an articulated robot into a simulator that reads URDF (e.g. pybullet).

    urdf: the URDF file (a path).  package_dirs: directories that ``package://`` mesh paths are
    relative to.  joint_names: the planned joints, in the order of the configuration vector ``(d,)``.
    posture: the fixed value (rad or m) of every other single-DoF joint, by name.
    velocity_limits / effort_limits: ``(d,)`` per planned joint (rad/s or m/s; N m or N).
    """

    urdf: Any
    package_dirs: tuple[Any, ...]
    joint_names: tuple[str, ...]
    posture: dict[str, float]
    velocity_limits: np.ndarray
    effort_limits: np.ndarray


class RobotModel(Component):
    """A robot: its configuration space and the points of its body.

    The body is a set of ``m`` sample points (voxel centres at the scene resolution, thesis 3.2.1),
    each with a deformability and a sensitivity.
    """

    kind = "robot"

    @property
    @abstractmethod
    def space(self) -> Space:
        """The configuration space (bounds from joint limits or the scene)."""

    @abstractmethod
    def body_points(self, q: np.ndarray, indices: np.ndarray | None = None) -> np.ndarray:
        """World positions of the body points, ``(n, m, 3)`` for ``q`` ``(n, d)``; metres.

        ``indices`` ``(k,)`` selects a subset of the points (then ``(n, k, 3)``).
        """

    @abstractmethod
    def point_materials(self) -> np.ndarray:
        """``(m, 2)``: deformability and sensitivity of each body point."""

    @abstractmethod
    def point_jacobians(self, q: np.ndarray, indices: np.ndarray | None = None) -> np.ndarray:
        """``(n, m, 3, t)``: d(point position)/d(tangent motion) at each configuration.

        ``indices`` ``(k,)`` selects a subset of the points (then ``(n, k, 3, t)``).
        """

    def surface_indices(self) -> np.ndarray:
        """Indices of the body points on the body's surface (contact happens there first).

        The default is every point; robots that know their interior override it.
        """
        return np.arange(self.point_count())

    def surface_faces(self) -> np.ndarray | None:
        """Which body-frame axis directions leave the body at each surface point, or ``None``.

        Bool ``(k, 6)`` in the order of :meth:`surface_indices`, columns ``-x, +x, -y, +y, -z, +z``
        (body frame): the outward normals of the faces the point lies on (one for a point inside a face,
        two on an edge, three at a corner).  Contact resolution uses them to tell a robot face sliding
        past an obstacle's edge from a robot corner hitting a face (thesis app. B).  The default,
        ``None``, means the robot cannot tell (the simulator then traces points along their motion only).
        """
        return None

    def point_count(self) -> int:
        return len(self.point_materials())

    def self_contacts(self, q: np.ndarray) -> SelfContacts | None:
        """Contacts between the robot's own links at one configuration ``(d,)``; ``None`` if it has no links."""
        return None

    def rigid_placement(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """For a single rigid body: ``(R (n, 3, 3), t (n, 3), local (m, 3))`` with points ``R @ local + t``.

        Lets hot paths (cost evaluation, simulation) fuse the transform into their kernels.
        Articulated robots return ``None`` (the default) and are used through :meth:`body_points`.
        """
        return None

    def collisions(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: whether the robot's own collision model (its geometry, not its body points) collides at
        configurations ``(n, d)`` with the scene's obstacles or with itself.

        The core's validity checker (:mod:`pliant.planning.validity`) checks every robot's body points against the
        scene's voxels, and calls this too when a robot overrides it (URDF robots: their collision meshes and
        self-collision).  The default, never, is for robots whose body points are their whole geometry.
        """
        return np.zeros(len(np.atleast_2d(q)), dtype=bool)

    def urdf_description(self) -> UrdfDescription | None:
        """The URDF, joint order and fixed posture of an articulated robot; ``None`` (the default) otherwise.

        Dynamic simulators load the same robot from it, so the configuration vector means the same
        joints in every backend.
        """
        return None


class CostModel(Component):
    """A state cost over configurations (e.g. the cost of deformation, thesis eq. 3.1).

    ``cost`` may return NaN for infeasible states, where the method defines it (documented by the
    plugin).  Costs are dimensionless unless the plugin states units.
    """

    kind = "cost"
    #: whether :meth:`gradient` is implemented
    has_gradient: ClassVar[bool] = False

    @abstractmethod
    def cost(self, q: np.ndarray) -> np.ndarray:
        """State cost ``(n,)`` of configurations ``(n, d)``; equal to ``n`` single calls."""

    def gradient(self, q: np.ndarray) -> np.ndarray:
        """Tangent-space gradient ``(n, t)`` of :meth:`cost` (thesis eq. 3.2)."""
        raise NotImplementedError(f"{type(self).__name__} has no gradient")

    def breakdown(self, q: np.ndarray) -> np.ndarray:
        """Per-feature costs ``(n, k)`` summing to :meth:`cost` (e.g. one column per object)."""
        return self.cost(q)[:, None]

    def feature_names(self) -> list[str]:
        """Names of the :meth:`breakdown` columns."""
        return ["cost"]

    def is_valid(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: feasible where the cost is finite."""
        return np.isfinite(self.cost(q))

    def translation_costs(self, origin: np.ndarray, spacing: float, shape: tuple[int, ...],
                          base: np.ndarray | None = None) -> np.ndarray:
        """State costs of every pure translation on a lattice, ``shape`` ``(nx, ny, nz)``.

        Configuration ``(i, j, k)`` is ``origin + spacing * (i, j, k)`` in the first three
        coordinates (``base`` supplies the remaining coordinates, e.g. a fixed orientation).  The
        default evaluates :meth:`cost` in batches; cost models may override it with something
        faster (the voxel model correlates the robot with the environment, thesis 3.2.3).
        """
        origin = np.asarray(origin, dtype=np.float64)
        axes = [origin[i] + spacing * np.arange(n) for i, n in enumerate(shape)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(shape))
        if base is not None:
            base = np.asarray(base, dtype=np.float64)
            grid = np.concatenate([grid, np.broadcast_to(base[len(shape):], (len(grid), base.size - len(shape)))],
                                  axis=1)
        out = np.concatenate([self.cost(grid[s:s + 8192]) for s in range(0, len(grid), 8192)])
        return out.reshape(shape)


@dataclass
class SimulationBatch:
    """Outcome of forward-simulating ``n`` particles.

    final: ``(n, d)`` configurations at the end.
    in_contact / stuck / reached: bool ``(n,)``.
    trajectories: optional ``(n, k, d)`` recorded states.
    steps: microsteps taken (total over the batch).
    """

    final: np.ndarray
    in_contact: np.ndarray
    stuck: np.ndarray
    reached: np.ndarray
    trajectories: np.ndarray | None = None
    steps: int = 0


class Simulator(Component):
    """Moves the robot among the scene's objects under commands, with contact.

    Two ways in: :meth:`simulate` (a batch of particles toward targets; the belief planner's
    workhorse) and the stepping API :meth:`reset` / :meth:`step` used by
    :func:`pliant.execution.loop.execute` to run a controller in closed loop.
    """

    kind = "simulator"

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # the core checks reset's configuration, simulate's starts and step's velocity, dt and rng (and the state a
        # first step starts from) before the plugin's code runs; starts inside an obstacle are refused
        super().__init_subclass__(**kwargs)
        if "reset" in cls.__dict__:
            cls.reset = checked_reset(cls.__dict__["reset"])
        if "simulate" in cls.__dict__:
            cls.simulate = checked_simulate(cls.__dict__["simulate"])
        if "step" in cls.__dict__:
            cls.step = checked_step(cls.__dict__["step"])

    #: penetration (m) of a start that still counts as contact, not as inside (:meth:`start_penetration`)
    start_tolerance: float = 0.0

    def start_penetration(self, configurations: np.ndarray) -> np.ndarray | None:
        """How deep (m) the robot would start inside a rigid obstacle at each configuration ``(n, d)``: ``(n,)``,
        0 where it is free.  The core refuses every start deeper than :attr:`start_tolerance` -- in ``reset``,
        in ``simulate`` (naming ``starts[k]``) and in a first ``step`` from the state ``bind`` left -- before the
        plugin's code runs (:func:`pliant.contracts.check_starts`), so that no entry point lets a robot placed
        inside a wall pass through it.  Each simulator measures with its own geometry; it must not change its
        state doing so.

        The default ``None`` means the simulator cannot tell (nothing is refused).
        """
        return None

    def describe_obstacle(self, q: np.ndarray) -> str:
        """Words naming what the robot at configuration ``(d,)`` is inside (e.g. ``"object 'wall-3'"``), for the
        error of a refused start; ``""`` (the default) says "an obstacle"."""
        return ""

    @abstractmethod
    def simulate(self, starts: np.ndarray, targets: np.ndarray, rng: np.random.Generator,
                 duration: float, record: bool = False) -> SimulationBatch:
        """Drive each start ``(n, d)`` toward its target (``(n, d)`` or ``(d,)``) for ``duration`` s.

        With ``record``, the result's ``trajectories`` hold the state after every control step.
        """

    @abstractmethod
    def reset(self, q: np.ndarray) -> None:
        """Place the robot at configuration ``(d,)``, at rest."""

    @abstractmethod
    def step(self, velocity: np.ndarray, dt: float, rng: np.random.Generator) -> np.ndarray:
        """Apply a tangent velocity command ``(t,)`` (m/s, rad/s) for ``dt`` seconds; return the new ``(d,)``."""

    def contact_points(self) -> np.ndarray:
        """The robot's contacts after the last step, ``(k, 7)``: world point (m), unit normal from the other
        body toward the robot, normal force (N; NaN where the simulator has no forces).

        The default ``(0, 7)`` is for simulators that report only :meth:`in_contact`.
        """
        return np.zeros((0, 7))

    def object_poses(self) -> dict[str, np.ndarray]:
        """Current poses of the scene's movable objects by name: ``(x, y, theta)`` in planar scenes, else
        ``(x, y, z, qx, qy, qz, qw)``.

        The default ``{}`` is for simulators that hold every object fixed (the kinematic simulator).
        """
        return {}

    #: whether :meth:`set_object_poses` is implemented (planners that push objects check it when they bind)
    can_place_objects: ClassVar[bool] = False

    def set_object_poses(self, poses: dict[str, np.ndarray]) -> None:
        """Place the named movable objects at ``poses`` (the layout of :meth:`object_poses`), at rest; the robot and
        the objects not named stay where they are.  Object-space planners (TS-RRT, poster ICHR 2010) use it to start
        an execution from a chosen arrangement and to reposition the pusher between pushes (``reset``, which puts
        every object back at its scene pose, then this).

        The default raises :class:`~pliant.errors.SimulationError`: the simulator cannot place objects.
        """
        raise SimulationError(f"{type(self).__name__} cannot place movable objects", field="simulator",
                              value=type(self).__name__)

    @abstractmethod
    def configuration(self) -> np.ndarray:
        """The robot's current configuration ``(d,)``."""

    def in_contact(self) -> bool:
        """Whether the robot touched anything during the last step."""
        return False

    def settle(self) -> np.ndarray:
        """End of an execution: a simulated robot stops with its last command; returns its configuration."""
        return self.configuration()

    def control_law(self) -> ControlLaw | None:
        """The control law :meth:`simulate` applies each step (gains, period, limits, noise), or ``None``.

        Components that predict the simulator's motion without simulating it (the reachable volumes of the
        path metric, thesis 6.4.1) need it; simulators whose motion has no such law return ``None``.
        """
        return None


class Controller(Component):
    """Turns (current configuration, target) into a velocity command (thesis app. C)."""

    kind = "controller"

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # the core checks command's configurations and dt before the plugin's code runs
        super().__init_subclass__(**kwargs)
        if "command" in cls.__dict__:
            cls.command = checked_command(cls.__dict__["command"])

    def reset(self) -> None:
        """Forget internal state (e.g. the stuck-detection window) before a new motion."""

    @abstractmethod
    def command(self, q: np.ndarray, target: np.ndarray, dt: float) -> np.ndarray:
        """Tangent velocity ``(t,)`` to apply for ``dt`` seconds toward ``target``."""

    def reached(self, q: np.ndarray, target: np.ndarray) -> bool:
        """Whether ``q`` is close enough to ``target`` to move on."""
        return False


@dataclass
class PlanningProblem:
    """A query: the space, start, goal and what to consult (cost, simulator, robot, scene).

    goal_tolerance: distance (in the space's metric) within which the goal counts as reached.
    validity: optional extra check ``(n, d) -> bool (n,)``; the cost's NaN also marks infeasible states.
    goal_region: optional ``(n, d) -> bool (n,)`` replacing the goal configuration (task-space goals).
    checker: the scene's and robot's collision checker (:class:`pliant.planning.validity.ValidityChecker`);
    :meth:`from_context` sets it whenever the context has a scene and a robot, so :meth:`is_valid`,
    :meth:`motions_valid` and :meth:`path_verdict` check collisions with or without a cost model.  The core
    re-checks every successful result's path with it (:func:`pliant.contracts.checked_plan`).
    """

    space: Space
    start: np.ndarray
    goal: np.ndarray
    goal_tolerance: float = 0.0
    cost: CostModel | None = None
    robot: RobotModel | None = None
    simulator: Simulator | None = None
    controller: Controller | None = None
    scene: Any = None
    validity: Callable[[np.ndarray], np.ndarray] | None = None
    goal_region: Callable[[np.ndarray], np.ndarray] | None = None
    checker: Any = None

    @classmethod
    def from_context(cls, context: Context, start=None, goal=None) -> PlanningProblem:
        """The scene's task (or the given start/goal) with the context's components and the scene's and robot's
        collision checker."""
        from pliant.planning.validity import ValidityChecker

        scene = context.scene
        space = context.space
        start = scene.start if start is None else start
        goal = scene.goal if goal is None else goal
        return cls(space=space, start=np.asarray(start, dtype=np.float64), goal=np.asarray(goal, dtype=np.float64),
                   goal_tolerance=scene.goal_tolerance if scene is not None else 0.0, cost=context.cost,
                   robot=context.robot, simulator=context.simulator, controller=context.controller, scene=scene,
                   checker=ValidityChecker.from_context(context))

    def is_valid(self, q: np.ndarray, collisions: bool = True) -> np.ndarray:
        """Bool ``(n,)``: in the space's bounds, collision-free (:attr:`checker`), feasible for the cost, and
        passing ``validity``.  ``collisions=False`` leaves the collision check out, for states of a motion that
        :meth:`motions_valid` checks anyway."""
        q = np.atleast_2d(q)
        ok = np.asarray(self.space.is_valid(q), dtype=bool)
        if collisions and self.checker is not None and ok.any():
            ok &= self.checker.states_valid(q)
        if self.cost is not None and ok.any():
            ok &= self.cost.is_valid(q)
        if self.validity is not None and ok.any():
            ok &= np.asarray(self.validity(q), dtype=bool)
        return ok

    def motions_valid(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Bool ``(m,)``: both ends of each motion ``a[i] -> b[i]`` (``(m, d)`` or ``(d,)``, broadcast) are in the
        space's bounds and every instant of the motion (the space's interpolation) is collision-free, at the
        resolution of the scene's voxels (conservative advancement, :mod:`pliant.planning.validity`); only the
        bounds without a :attr:`checker`.  The states' cost feasibility and ``validity`` are :meth:`is_valid`'s
        (a planner checks them on the states it discretises anyway)."""
        a, b = np.broadcast_arrays(np.atleast_2d(np.asarray(a, dtype=np.float64)),
                                   np.atleast_2d(np.asarray(b, dtype=np.float64)))
        ok = np.asarray(self.space.is_valid(a), dtype=bool) & np.asarray(self.space.is_valid(b), dtype=bool)
        if self.checker is not None and ok.any():
            idx = np.nonzero(ok)[0]
            ok[idx] = self.checker.motions_valid(a[idx], b[idx])
        return ok

    def motion_is_valid(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Whether the single motion ``a -> b`` (``(d,)`` each) is valid (:meth:`motions_valid`)."""
        return bool(self.motions_valid(a, b)[0])

    def path_verdict(self, configurations: np.ndarray):
        """The :class:`pliant.planning.validity.Verdict` of a path ``(k, d)``: every state (bounds, collisions,
        cost feasibility, ``validity``) and every motion between consecutive states (collisions at voxel
        resolution)."""
        from pliant.planning.validity import Verdict

        path = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
        if path.ndim != 2 or path.shape[1] != self.space.dim or not np.all(np.isfinite(path)):
            return Verdict(False, 0, "state", f"the path is not a sequence of finite {self.space.dim}-coordinate "
                                              "configurations")
        states = self.is_valid(path)
        if not states.all():
            i = int(np.argmin(states))
            why = self.checker.explain(path[i]) if self.checker is not None else None
            if why is None:
                why = ("outside the space's bounds" if not self.space.is_valid(path[i])
                       else "infeasible for the cost model or the problem's validity check")
            return Verdict(False, i, "state", f"state {i} {np.round(path[i], 6).tolist()} is not valid: {why}",
                           len(path))
        if self.checker is None:
            return Verdict(True, checked_states=len(path))
        return self.checker.path_verdict(path)

    def path_is_valid(self, configurations: np.ndarray) -> bool:
        """Whether every state and every motion of the path ``(k, d)`` is valid (:meth:`path_verdict`)."""
        return self.path_verdict(configurations).valid

    def checked_endpoints(self) -> tuple[np.ndarray, np.ndarray, Status | None]:
        """Start and goal as ``(d,)`` arrays, and ``invalid start`` / ``invalid goal`` if one is infeasible.

        Malformed endpoints (wrong length, NaN) raise :class:`~pliant.errors.DimensionError`.
        """
        start = self.space.check(self.start, field="start")
        goal = self.space.check(self.goal, field="goal")
        if not self.is_valid(start)[0]:
            return start, goal, Status.INVALID_START
        if self.goal_region is None and not self.is_valid(goal)[0]:
            return start, goal, Status.INVALID_GOAL
        return start, goal, None

    def densify(self, configurations: np.ndarray, step: float) -> np.ndarray:
        """The path ``(k, d)`` with states inserted so that consecutive ones are at most ``step`` apart."""
        configurations = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
        if len(configurations) < 2:
            return configurations.copy()
        return np.vstack([configurations[:1]] + [self.space.discretize(a, b, step)[1:]
                                                  for a, b in itertools.pairwise(configurations)])

    def path_cost(self, configurations: np.ndarray, step: float) -> float:
        """The discrete integral of the state cost along a path ``(k, d)``: ``sum_j c(q_j) |q_j - q_{j-1}|``.

        Each segment is discretised at ``step`` (space metric units) first, so the value does not depend
        on how many waypoints a planner kept (thesis Table 3.1: "the integral of costs incurred at each
        state in a trajectory"); 0 without a cost model.  NaN when a state is infeasible.
        """
        dense = self.densify(configurations, step)
        if self.cost is None or len(dense) < 2:
            return 0.0
        steps = np.asarray(self.space.distance(dense[:-1], dense[1:]), dtype=np.float64)
        return float(np.sum(self.cost.cost(dense[1:]) * steps))

    def in_goal(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: within ``goal_tolerance`` of the goal, or inside ``goal_region``."""
        q = np.atleast_2d(q)
        if self.goal_region is not None:
            return np.asarray(self.goal_region(q), dtype=bool)
        return self.space.distance(q, self.goal) <= self.goal_tolerance + 1e-12


@dataclass(frozen=True)
class PlannerSpecs:
    """What a planner handles and needs (after OMPL's ``PlannerSpecs``), so a pipeline that cannot work is rejected
    when it is built (:func:`pliant.contracts.check_planner`) instead of when it plans.

    needs_simulator: plans by forward-simulating (the pipeline must have a ``[simulator]``).
    needs_cost: needs a cost model (``[cost]``); needs_gradient: one whose ``has_gradient`` is true.
    needs_scene: needs the scene itself (e.g. its voxel lattice), not only the space and the checks.
    returns_policy: the result holds a policy rather than (only) a path.
    anytime: keeps improving its result until the termination condition stops it.
    spaces: the configuration spaces it plans in, as ``"r3"`` (a space kind and dimension) or a kind (``"rn"``,
    ``"se2"``, ``"se3"``, ``"compound"``); ``None``: any.
    """

    needs_simulator: bool = False
    needs_cost: bool = False
    needs_gradient: bool = False
    needs_scene: bool = False
    returns_policy: bool = False
    anytime: bool = False
    spaces: tuple[str, ...] | None = None


class Planner(Component):
    """Finds a path (or a policy) for a :class:`PlanningProblem`.

    ``SPECS`` declares what the planner handles and needs (:class:`PlannerSpecs`); a planner whose needs depend on
    its options overrides :attr:`specs`.
    """

    kind = "planner"
    SPECS: ClassVar[PlannerSpecs] = PlannerSpecs()

    @property
    def specs(self) -> PlannerSpecs:
        """This planner's :class:`PlannerSpecs` (with its options applied)."""
        return self.SPECS

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # the core checks plan's problem and rng before the plugin's code runs
        super().__init_subclass__(**kwargs)
        if "plan" in cls.__dict__:
            cls.plan = checked_plan(cls.__dict__["plan"])

    def goal_region(self, problem: PlanningProblem) -> Callable[[np.ndarray], np.ndarray] | None:
        """The goal test the last :meth:`plan` aimed at when the planner replaces ``problem``'s goal (a task-space
        target given as a planner option): ``(n, d) -> bool (n,)``; ``None`` (the default): the problem's own.  The
        core's final check (:func:`pliant.contracts.validated_result`) judges "solved" against it."""
        return None

    @abstractmethod
    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        """Solve ``problem``; never returns ``None`` (see :class:`~pliant.results.Status`).  ``termination``: any
        :class:`pliant.termination.Condition` -- a :class:`Termination` or a combination (``any_of`` / ``all_of``);
        None: the planner's own from its options."""


class PathMetric(Component):
    """Scores a path (e.g. the reachable-volume quality metric of thesis ch. 6).

    The core checks ``evaluate``'s arguments before the plugin's code runs (:func:`pliant.contracts.checked_evaluate`):
    the problem, the rng, and a path whose every waypoint is valid in the problem (:meth:`PlanningProblem.is_valid`:
    in the space's bounds, collision-free, feasible), so that no metric scores waypoints out of the workspace or
    inside an obstacle.
    """

    kind = "metric"

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # the core checks evaluate's problem, rng and path (its waypoints' validity) before the plugin's code runs
        super().__init_subclass__(**kwargs)
        if "evaluate" in cls.__dict__:
            cls.evaluate = checked_evaluate(cls.__dict__["evaluate"])

    @abstractmethod
    def evaluate(self, path: Path, problem: PlanningProblem, rng: np.random.Generator) -> dict[str, float]:
        """Named scores of ``path`` (units documented by the plugin)."""


@dataclass(frozen=True)
class DriverOptions:
    """Options every driver shares (driver plugins extend this dataclass)."""

    limits: str | None = option(None, "limits file (TOML, pliant.hardware.limits); default the plugin's own for "
                                "its robot")
    command_rate: float | None = option(None, "commands per second (Hz); default the limits file's",
                                        minimum=1.0, maximum=10000.0)
    speed_scale: float = option(1.0, "fraction of the velocity limits used (acceleration scales with its square, "
                                "jerk with its cube)", minimum=1e-3, maximum=1.0)
    state_timeout: float | None = option(None, "stale-state watchdog deadline (s); default the limits file's",
                                         minimum=1e-3)
    connect_timeout: float = option(5.0, "seconds to wait for the robot's first state when connecting",
                                    minimum=0.01)
    reach_tolerance: float = option(0.01, "move_to / follow: largest joint error (rad) that counts as arrived",
                                    minimum=1e-6)
    move_timeout: float = option(60.0, "move_to / follow: seconds to wait for arrival beyond the planned "
                                 "duration", minimum=0.0)


class Driver(Component):
    """A real (or emulated) robot, commanded through the core's safety layer (DESIGN rule 9).

    **What users call** (implemented here, in the core): ``with driver: ...`` (connect, and on leaving for any
    reason stop within the limits and disconnect), :meth:`move_to`, :meth:`follow` (a timed path),
    :meth:`stream` (a target that may change every cycle; ruckig blends, no stop), :meth:`stop`,
    :meth:`state`, :meth:`check`.  A driver is also an *execution world*: :meth:`reset`, :meth:`step`,
    :meth:`configuration` are the protocol :func:`pliant.execution.loop.execute` drives simulators through, so a
    controller or a policy runs closed-loop on the robot's measured joint states.

    **What a driver plugin implements** (the transport, nothing else): :meth:`joint_names`,
    :meth:`default_limits_file`, :meth:`open`, :meth:`shutdown`, :meth:`latest_state`, :meth:`write` and,
    where the robot has them, :meth:`robot_status` and :meth:`enable`.  Only the core's command stream calls
    :meth:`write`, and only with commands the safety layer passed.
    """

    kind = "driver"
    Options = DriverOptions

    # --- the transport a plugin implements ----------------------------------------------------------------

    @abstractmethod
    def joint_names(self) -> tuple[str, ...]:
        """The commanded joints, in command order (the robot's URDF names)."""

    @abstractmethod
    def default_limits_file(self) -> Any:
        """The plugin's limits file for its robot (a path), used unless the ``limits`` option names another."""

    @abstractmethod
    def open(self) -> None:
        """Open the connection; raise :class:`~pliant.errors.ConnectionLost` (one line: what is unreachable)."""

    @abstractmethod
    def shutdown(self) -> None:
        """Close the connection and release everything :meth:`open` took; safe to call twice."""

    @abstractmethod
    def latest_state(self) -> JointState | None:
        """The newest joint state received (non-blocking), ``None`` before the first.  May raise a
        :class:`~pliant.errors.DriverError` (the stream treats it as any fault: a controlled stop)."""

    @abstractmethod
    def write(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Put one command on the wire: positions ``(d,)`` and velocities ``(d,)`` in :meth:`joint_names` order.

        Called only by the core's command stream, at the command rate, after the safety checks.
        """

    def robot_status(self) -> RobotStatus:
        """Whether the robot is enabled, e-stopped, faulted or lost; the default is a robot that is always ready."""
        return RobotStatus()

    def enable(self) -> None:
        """Enable the robot's motors where the robot needs it (Baxter, CiA 402 drives); default nothing."""

    # --- what users call ----------------------------------------------------------------------------------

    @property
    def limits(self) -> JointLimits:
        """The limits in force (the limits file, at the ``command_rate`` and ``speed_scale`` options)."""
        if getattr(self, "_limits", None) is None:
            from pliant.hardware.limits import load_limits

            o = self.options
            limits = load_limits(o.limits if o.limits is not None else self.default_limits_file())
            limits = limits.select(self.joint_names())
            if o.command_rate is not None:
                limits = limits.with_rate(o.command_rate)
            if o.state_timeout is not None:
                limits = replace(limits, state_timeout=o.state_timeout)
            self._limits = limits.scaled(o.speed_scale) if o.speed_scale < 1 else limits
        return self._limits

    @property
    def session(self):
        """The running :class:`~pliant.hardware.stream.CommandStream` (connect first)."""
        stream = getattr(self, "_stream", None)
        if stream is None:
            raise DriverError("the driver is not connected; use `with driver:` or call connect()",
                              field="driver", value=type(self).__name__)
        return stream

    def bind(self, context: Context) -> None:
        """Check that the pipeline's robot commands the same joints, in the same order."""
        super().bind(context)
        robot = context.robot
        description = robot.urdf_description() if robot is not None else None
        if description is not None and tuple(description.joint_names) != tuple(self.joint_names()):
            raise JointMismatch(f"the pipeline's robot plans joints {list(description.joint_names)} but this "
                                f"driver commands {list(self.joint_names())}", field="driver")

    def connect(self) -> None:
        """Open the connection, wait for a fresh state, check the robot is ready and start streaming."""
        from pliant.hardware.stream import CommandStream

        if getattr(self, "_stream", None) is not None:
            return
        self.open()
        try:
            stream = CommandStream(self, self.limits, connect_timeout=self.options.connect_timeout,
                                   reach_tolerance=self.options.reach_tolerance,
                                   move_timeout=self.options.move_timeout)
            stream.start()
        except BaseException:
            self.shutdown()
            raise
        self._stream = stream

    def close(self) -> None:
        """Stop within the limits (if moving) and disconnect; safe to call twice."""
        stream = getattr(self, "_stream", None)
        self._stream = None
        try:
            if stream is not None:
                stream.close()
        finally:
            self.shutdown()

    def __enter__(self) -> Driver:
        self.connect()
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def state(self) -> np.ndarray:
        """The measured joint positions ``(d,)`` (rad), in :meth:`joint_names` order."""
        return self.session.measured().positions

    def measured(self):
        """The newest checked measurement: ``positions`` ``(d,)`` rad, ``velocities`` ``(d,)`` rad/s (estimated from
        successive states where the robot reports none) and ``time`` (:func:`time.monotonic`, s)."""
        return self.session.measured()

    def move_to(self, q: np.ndarray, *, wait: bool = True) -> np.ndarray:
        """Move to ``q`` ``(d,)`` and (with ``wait``) return the measured positions once there."""
        return self.session.move_to(q, wait=wait)

    def follow(self, path: Path, *, wait: bool = True) -> np.ndarray:
        """Follow a timed path (``path.times`` in s, ``(k,)``); ruckig keeps it within the limits."""
        return self.session.follow(path, wait=wait)

    def send(self, path: Path) -> None:
        """Execute a timed path and wait until the robot arrives (:meth:`follow`)."""
        self.follow(path)

    def stream(self, target: np.ndarray, velocity: np.ndarray | None = None, *, hold: float | None = None) -> None:
        """Set the streamed target ``(d,)`` (optionally with a target velocity ``(d,)``); returns at once.

        A new target mid-motion blends into the current motion (online ruckig).  With a non-zero velocity the
        target expires after ``hold`` s (default four command periods): then the robot stops.
        """
        self.session.stream(target, velocity, hold=hold)

    def stop(self, *, wait: bool = True) -> np.ndarray:
        """Decelerate to rest within the limits; returns the measured positions."""
        return self.session.stop(wait=wait)

    def check(self, *, enable: bool = False) -> dict[str, Any]:
        """Report state, status, limits and rates, raising the first problem found as a one-line
        :class:`~pliant.errors.DriverError`.  Not connected: look at the robot without commanding it (and enable it
        only with ``enable``); connected: report the running stream (with the measured command rate)."""
        if getattr(self, "_stream", None) is not None:
            return self._stream.report()
        from pliant.hardware.stream import inspect_robot

        return inspect_robot(self, self.limits, connect_timeout=self.options.connect_timeout, enable=enable)

    # --- the execution protocol (the same as a simulator's) -----------------------------------------------

    def reset(self, q: np.ndarray) -> None:
        """Move to ``q`` (a robot cannot be placed; it drives there within its limits).

        A start on a position limit (baxter-reach starts with ``right_s1`` at its URDF limit) is driven to within
        the position margin, the closest configuration a command may hold; a start further out is refused
        (:class:`~pliant.errors.LimitViolation`)."""
        limits = self.limits
        q = np.asarray(q, dtype=np.float64)
        inside = np.clip(q, limits.command_lower, limits.command_upper)
        outside = np.abs(q - inside) > limits.position_margin + 1e-9
        if np.any(outside):
            i = int(np.argmax(outside))
            raise LimitViolation(f"start {q[i]:.6g} rad lies beyond the position limits",
                                 joint=limits.names[i], value=float(q[i]),
                                 limit=[float(limits.lower[i]), float(limits.upper[i])])
        self.move_to(inside)

    def configuration(self) -> np.ndarray:
        return self.state()

    def step(self, velocity: np.ndarray, dt: float, rng: np.random.Generator | None = None) -> np.ndarray:
        """Command ``velocity`` ``(d,)`` (rad/s) for ``dt`` s of real time; return the measured ``(d,)`` after."""
        return self.session.step(velocity, dt)

    def settle(self) -> np.ndarray:
        """End of an execution: decelerate to rest within the limits; returns the measured rest configuration."""
        return self.stop()

    def in_contact(self) -> bool:
        """Drivers do not sense contact; the contact controller notices it from the measured motion."""
        return False

    def object_poses(self) -> dict[str, np.ndarray]:
        return {}


class Learner(Component):
    """Fits parameters from data (demonstrations, action outcomes)."""

    kind = "learner"

    @abstractmethod
    def fit(self, data: Any, rng: np.random.Generator) -> dict[str, Any]:
        """Fit and return the learned parameters (names and units documented by the plugin)."""


BASES: dict[str, type[Component]] = {
    "simulator": Simulator, "robot": RobotModel, "controller": Controller, "planner": Planner,
    "metric": PathMetric, "cost": CostModel, "learner": Learner, "driver": Driver,
}
