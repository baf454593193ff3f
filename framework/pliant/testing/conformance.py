"""Contract checks for every component kind (see :mod:`pliant.testing`).

Each ``check_*`` function raises :class:`ConformanceFailure` (an ``AssertionError``) naming the
component and the broken rule, and returns the list of rules it verified.
"""

from __future__ import annotations

import time

import numpy as np

from pliant.components import (
    Component,
    Context,
    Controller,
    CostModel,
    Driver,
    Learner,
    PathMetric,
    Planner,
    PlanningProblem,
    RobotModel,
    Simulator,
)
from pliant.errors import PliantError
from pliant.hardware.state import JointState, RobotStatus
from pliant.registry import Registry, default_registry
from pliant.results import Path, PlanResult, Status
from pliant.scene import load_scene
from pliant.spaces import Space

DEFAULT_SCENE = "triple-wall"
#: the component kinds :func:`check_component` has a contract for (a driver's without its robot or peer)
CHECKED_KINDS = ("robot", "cost", "planner", "simulator", "controller", "metric", "learner", "driver")


class ConformanceFailure(AssertionError):
    """A component broke its interface contract."""


def _require(condition: bool, who: str, rule: str) -> None:
    if not condition:
        raise ConformanceFailure(f"{who}: {rule}")


def _raises_pliant_error(fn, who: str, rule: str) -> None:
    try:
        fn()
    except PliantError:
        return
    except Exception as exc:  # the contract: bad input raises PliantError, nothing else
        raise ConformanceFailure(f"{who}: {rule} (raised {type(exc).__name__}: {exc})") from exc
    raise ConformanceFailure(f"{who}: {rule} (nothing was raised)")


def build_context(scene: str | None = None, registry: Registry | None = None,
                  options: dict[str, dict] | None = None, **components: str) -> Context:
    """A context for ``scene`` (default: the built-in test scene) with the named components created.

    ``components`` maps kinds to registered names, e.g. ``cost="voxel"``; a robot is added from the
    scene when not given.  ``options`` maps a kind to the options its component is created with (e.g.
    ``{"simulator": {"max_force": 50.0}}``).
    """
    options = options or {}
    reg = registry or default_registry()
    sc = load_scene(scene or DEFAULT_SCENE)
    ctx = Context(scene=sc, seed=0)
    robot = components.pop("robot", {"rigid": "rigid", "urdf": "pinocchio"}[sc.robot.kind])
    ctx.robot = reg.create("robot", robot, ctx)
    for kind in ("cost", "simulator", "controller"):
        if kind in components:
            setattr(ctx, kind, reg.create(kind, components.pop(kind), ctx, **options.get(kind, {})))
    return ctx


def check_space(space: Space, seed: int = 0, who: str = "space") -> list[str]:
    """Sampling, distance, interpolation and validity of a configuration space."""
    rng = np.random.default_rng(seed)
    q = space.sample(rng, 16)
    _require(q.shape == (16, space.dim) and q.dtype == np.float64, who, "sample(rng, n) returns (n, dim) float64")
    _require(bool(np.all(space.is_valid(q))), who, "samples are valid")
    d = space.distance(q[:8], q[8:])
    _require(d.shape == (8,) and np.all(d >= 0), who, "batched distance is (n,) and non-negative")
    _require(np.allclose(d, space.distance(q[8:], q[:8])), who, "distance is symmetric")
    _require(np.allclose(space.distance(q, q), 0.0, atol=1e-9), who, "distance to itself is zero")
    single = np.array([space.distance(a, b) for a, b in zip(q[:8], q[8:])])
    _require(np.allclose(d, single), who, "batched distance equals single calls")
    mid = space.interpolate(q[:8], q[8:], 0.5)
    _require(np.allclose(space.distance(q[:8], mid), d / 2, atol=1e-7), who, "the midpoint is half way")
    _require(np.allclose(space.distance(space.interpolate(q[:8], q[8:], 0.0), q[:8]), 0, atol=1e-9), who,
             "interpolate(a, b, 0) is a")
    _require(np.allclose(space.distance(space.interpolate(q[:8], q[8:], 1.0), q[8:]), 0, atol=1e-7), who,
             "interpolate(a, b, 1) is b")
    _require(np.allclose(space.sample(np.random.default_rng(seed), 16), q), who, "sampling is deterministic per seed")
    _raises_pliant_error(lambda: space.check(np.zeros(space.dim + 1)), who, "check() rejects a wrong length")
    _raises_pliant_error(lambda: space.check(np.full(space.dim, np.nan)), who, "check() rejects NaN")
    return ["sample", "distance", "interpolate", "determinism", "bad input"]


def check_robot(robot: RobotModel, seed: int = 0, who: str = "robot") -> list[str]:
    """Body points, materials and point Jacobians (against finite differences) of a robot model."""
    rules = check_space(robot.space, seed, f"{who}.space")
    rng = np.random.default_rng(seed)
    q = robot.space.sample(rng, 4)
    mats = robot.point_materials()
    m = len(mats)
    _require(mats.shape == (m, 2) and m > 0, who, "point_materials() is (m, 2) with m > 0")
    pts = robot.body_points(q)
    _require(pts.shape == (4, m, 3) and pts.dtype == np.float64, who, "body_points is (n, m, 3) float64")
    _require(np.allclose(robot.body_points(q[1]), pts[1:2]), who, "a single configuration equals its batch row")
    kept = pts.copy()
    again = robot.body_points(q[::-1])
    _require(not np.shares_memory(again, pts) and np.array_equal(pts, kept), who,
             "body_points returns a new array each call (a later call leaves an earlier result alone)")
    jac = robot.point_jacobians(q[:1])
    t = robot.space.tangent_dim
    _require(jac.shape == (1, m, 3, t), who, "point_jacobians is (n, m, 3, tangent_dim)")
    eps = 1e-6
    for k in range(t):
        e = np.zeros(t)
        e[k] = eps
        fd = (robot.body_points(robot.space.retract(q[:1], e)) - robot.body_points(robot.space.retract(q[:1], -e)))
        _require(np.allclose(fd / (2 * eps), jac[..., k], atol=1e-5), who,
                 f"Jacobian column {k} matches central finite differences")
    _raises_pliant_error(lambda: robot.body_points(np.zeros(robot.space.dim + 1)), who,
                         "a configuration of the wrong length raises PliantError")
    return [*rules, "body points", "a new array per call", "jacobians", "bad input"]


def check_cost(cost: CostModel, space: Space, seed: int = 0, who: str = "cost", configurations=None) -> list[str]:
    """Shapes, batch-equals-single, determinism, breakdown and gradient shapes of a cost model."""
    rng = np.random.default_rng(seed)
    q = space.sample(rng, 8) if configurations is None else np.asarray(configurations, dtype=np.float64)
    c = cost.cost(q)
    _require(c.shape == (len(q),) and c.dtype == np.float64, who, "cost is (n,) float64")
    single = np.array([cost.cost(x[None])[0] for x in q])
    _require(np.allclose(c, single, equal_nan=True), who, "batched cost equals single calls")
    _require(np.allclose(c, cost.cost(q), equal_nan=True), who, "cost is deterministic")
    _require(bool(np.all(np.isnan(c) | (c >= 0))), who, "costs are non-negative or NaN")
    b = cost.breakdown(q)
    _require(b.shape == (len(q), len(cost.feature_names())), who, "breakdown is (n, len(feature_names()))")
    finite = np.isfinite(c)
    _require(np.allclose(b[finite].sum(axis=1), c[finite]), who, "breakdown rows sum to the cost")
    if cost.has_gradient:
        g = cost.gradient(q)
        _require(g.shape == (len(q), space.tangent_dim), who, "gradient is (n, tangent_dim)")
    _raises_pliant_error(lambda: cost.cost(np.zeros((2, space.dim + 1))), who,
                         "configurations of the wrong width raise PliantError")
    return ["cost shape", "batch equals single", "determinism", "breakdown", "bad input"]


def check_planner(planner: Planner, problem: PlanningProblem, seed: int = 0, who: str = "planner") -> list[str]:
    """A planner returns a PlanResult (never None), valid solved paths, and is deterministic per seed."""
    result = planner.plan(problem, np.random.default_rng(seed))
    _require(isinstance(result, PlanResult), who, "plan() returns a PlanResult")
    _require(isinstance(result.status, Status), who, "the result has a Status")
    if result.status.success:
        path = result.path.configurations
        _require(path.ndim == 2 and path.shape[1] == problem.space.dim, who, "the path is (k, d)")
        _require(np.allclose(problem.space.distance(path[0], problem.start), 0, atol=1e-6), who,
                 "a solved path starts at the start")
        _require(bool(np.all(problem.is_valid(path))), who, "every configuration of a solved path is valid")
        if result.policy is None:
            _require(problem.path_is_valid(path), who, "every motion of a solved path is valid (at voxel resolution)")
        if result.status is Status.SOLVED:
            end_gap = float(problem.space.distance(path[-1], problem.goal))
            _require(bool(problem.in_goal(path[-1:])[0]) or end_gap <= max(problem.goal_tolerance, 1e-6), who,
                     "a solved path ends at the goal")
    again = planner.plan(problem, np.random.default_rng(seed))
    _require(again.status == result.status, who, "the same seed gives the same status")
    if result.path is not None:
        _require(again.path is not None and np.allclose(again.path.configurations, result.path.configurations),
                 who, "the same seed gives the same path")
    bad = PlanningProblem(space=problem.space, start=np.zeros(problem.space.dim + 1), goal=problem.goal,
                          cost=problem.cost, robot=problem.robot, scene=problem.scene)
    _raises_pliant_error(lambda: planner.plan(bad, np.random.default_rng(seed)), who,
                         "a start of the wrong length raises PliantError")
    return ["returns PlanResult", "valid path", "determinism", "bad input"]


def check_simulator(simulator: Simulator, space: Space, start: np.ndarray, seed: int = 0,
                    who: str = "simulator") -> list[str]:
    """Batch simulation shapes, determinism under a seed, and the stepping API."""
    rng = np.random.default_rng(seed)
    starts = np.repeat(np.asarray(start, dtype=np.float64)[None], 4, axis=0)
    targets = space.sample(rng, 4)
    out = simulator.simulate(starts, targets, np.random.default_rng(seed), 0.5)
    _require(out.final.shape == starts.shape, who, "simulate() final is (n, d)")
    for name in ("in_contact", "stuck", "reached"):
        _require(getattr(out, name).shape == (4,), who, f"simulate() {name} is (n,)")
    again = simulator.simulate(starts, targets, np.random.default_rng(seed), 0.5)
    _require(np.allclose(out.final, again.final), who, "the same seed gives the same particles")
    simulator.reset(starts[0])
    _require(np.allclose(simulator.configuration(), starts[0]), who, "reset() places the robot")
    q = simulator.step(np.zeros(space.tangent_dim), 0.1, np.random.default_rng(seed))
    _require(q.shape == (space.dim,), who, "step() returns (d,)")
    return ["simulate", "determinism", "stepping"]


def check_driver(driver: Driver, who: str = "driver", seconds: float = 0.5) -> list[str]:
    """The transport contract of a driver connected to a robot (or its peer) that is running and enabled.

    Checks: unique joint names; a limits file that covers them; ``open`` gives ``JointState`` messages with
    increasing stamps and a growing counter, covering the joints; ``robot_status`` is a ``RobotStatus``;
    ``shutdown`` twice is harmless; and through the core's stream, ``state()`` is ``(d,)`` and ``move_to`` the
    current position returns there.  Moves the robot by nothing more than holding it.
    """
    names = tuple(driver.joint_names())
    _require(len(names) > 0 and len(set(names)) == len(names), who, "joint_names() are unique and not empty")
    _require(driver.limits.names == names, who, "the limits file covers every joint, in order")
    driver.open()
    try:
        deadline = time.monotonic() + driver.options.connect_timeout
        while driver.latest_state() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        first = driver.latest_state()
        _require(isinstance(first, JointState), who, "latest_state() returns a JointState after open()")
        _require(set(names) <= set(first.names), who, "the joint states name every commanded joint")
        time.sleep(seconds)
        last = driver.latest_state()
        _require(last.stamp > first.stamp and last.sequence > first.sequence, who,
                 "joint states keep arriving with increasing stamps and counter")
        _require(isinstance(driver.robot_status(), RobotStatus), who, "robot_status() returns a RobotStatus")
    finally:
        driver.shutdown()
    driver.shutdown()
    with driver:
        q = driver.state()
        _require(q.shape == (len(names),), who, "state() is (d,)")
        _require(np.allclose(driver.move_to(q), q, atol=driver.options.reach_tolerance), who,
                 "move_to(current) arrives")
        _raises_pliant_error(lambda: driver.stream(np.full(len(names), np.nan)), who,
                             "a non-finite command is refused with PliantError")
    _raises_pliant_error(lambda: driver.state(), who, "after the with-block the driver is closed")
    return ["joint names", "limits", "joint states", "status", "shutdown twice", "stream", "non-finite",
            "closed on exit"]


def check_metric(metric: PathMetric, problem: PlanningProblem, path: Path, seed: int = 0,
                 who: str = "metric") -> list[str]:
    """A metric's ``evaluate``: named finite float scores (NaN only where documented is not allowed here: a
    straight path between valid endpoints must score), the same scores for the same seed, and a path of the wrong
    dimension raises PliantError."""
    scores = metric.evaluate(path, problem, np.random.default_rng(seed))
    _require(isinstance(scores, dict) and len(scores) > 0, who, "evaluate() returns a non-empty dict")
    _require(all(isinstance(k, str) for k in scores), who, "the scores are named by strings")
    values = list(scores.values())
    _require(all(isinstance(v, (float, int, np.floating, np.integer)) and not isinstance(v, bool) for v in values),
             who, "every score is a number")
    again = metric.evaluate(path, problem, np.random.default_rng(seed))
    _require(again.keys() == scores.keys() and all(np.isclose(again[k], scores[k], equal_nan=True) for k in scores),
             who, "the same seed gives the same scores")
    wrong = Path(np.zeros((2, problem.space.dim + 1)))
    _raises_pliant_error(lambda: metric.evaluate(wrong, problem, np.random.default_rng(seed)), who,
                         "a path of the wrong dimension raises PliantError")
    return ["named scores", "determinism", "bad input"]


def check_learner(learner: Learner, data, seed: int = 0, who: str = "learner") -> list[str]:
    """A learner's ``fit``: a dict of named parameters from ``data`` (the class's ``example_data``), the same
    parameters for the same seed, and empty data raises PliantError."""
    fitted = learner.fit(data, np.random.default_rng(seed))
    _require(isinstance(fitted, dict) and len(fitted) > 0, who, "fit() returns a non-empty dict of parameters")
    again = learner.fit(data, np.random.default_rng(seed))
    _require(again.keys() == fitted.keys(), who, "the same data and seed give the same parameters")
    for key in fitted:
        a, b = np.asarray(fitted[key]), np.asarray(again[key])
        same = a.shape == b.shape and (np.allclose(a, b, equal_nan=True) if a.dtype.kind in "biuf" else
                                       bool(np.all(a == b)))
        _require(same, who, f"the same data and seed give the same parameter {key!r}")
    _raises_pliant_error(lambda: learner.fit(type(data)() if isinstance(data, (list, dict, tuple)) else [],
                                             np.random.default_rng(seed)), who, "empty data raises PliantError")
    return ["parameters", "determinism", "empty data"]


def check_component(kind: str, name: str, scene: str | None = None, seed: int = 0,
                    registry: Registry | None = None, **components: str) -> list[str]:
    """Create ``kind``/``name`` in a context for ``scene`` and run the checks of its kind.

    The scene defaults to the component class's ``example_scene`` attribute, else the built-in test
    scene.  ``components`` names the other components it needs (``cost="voxel"``); the class's
    ``example_components``, ``example_options`` and a planner's ``example_budget`` (the request's budget, e.g.
    ``{"max_iterations": 1500}`` for an anytime planner, so the check is quick and deterministic) are used too, and
    ``example_component_options`` (kind -> options of the other components, e.g. the simulator settings a planner's
    pipelines use).
    """
    reg = registry or default_registry()
    cls = reg.entry(kind, name).load()
    scene = scene or getattr(cls, "example_scene", None)
    components = {**getattr(cls, "example_components", {}), **components}
    component_options = getattr(cls, "example_component_options", {})
    who = f"{kind} '{name}'"
    if kind == "robot":
        ctx = build_context(scene, reg, component_options, robot=name, **components)
        return check_robot(ctx.robot, seed, who)
    ctx = build_context(scene, reg, component_options, **components)
    component = reg.create(kind, name, ctx, **getattr(cls, "example_options", {}))
    _require(isinstance(component, Component), who, "is a Component")
    if kind == "cost":
        samples = ctx.space.sample(np.random.default_rng(seed), 8)
        return check_cost(component, ctx.space, seed, who, samples)
    if kind == "planner":
        ctx.extras["planner"] = component
        # the class's example_budget: the request's budget ([planning]), e.g. a small iteration budget
        problem = PlanningProblem.from_context(ctx, budget=getattr(cls, "example_budget", None))
        return check_planner(component, problem, seed, who)
    if kind == "simulator":
        return check_simulator(component, ctx.space, ctx.scene.start, seed, who)
    if kind == "controller":
        _require(isinstance(component, Controller), who, "is a Controller")
        v = component.command(ctx.scene.start, ctx.scene.goal, 0.1)
        _require(np.shape(v) == (ctx.space.tangent_dim,), who, "command() returns (tangent_dim,)")
        return ["command"]
    if kind == "metric":
        problem = PlanningProblem.from_context(ctx)
        path = Path(np.array([problem.start, problem.goal], dtype=np.float64))
        return check_metric(component, problem, path, seed, who)
    if kind == "learner":
        data = getattr(cls, "example_data", None)
        _require(data is not None, who, "the learner class declares example_data for the kit")
        return check_learner(component, data() if callable(data) else data, seed, who)
    if kind == "driver":
        # a driver needs its robot (or peer) running: check_driver(driver) does that; here what needs none
        names = tuple(component.joint_names())
        _require(len(names) > 0 and component.limits.names == names, who, "its limits file covers its joints")
        _raises_pliant_error(lambda: component.state(), who, "state() before connect() raises PliantError")
        return ["joints", "limits", "not connected"]
    return ["created"]
