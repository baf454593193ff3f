"""The core's checks in front of plan / reset / step / command (pliant.contracts): every plugin, built-in or
third-party, answers bad arguments with one PliantError naming the argument."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import registry
from pliant.contracts import WRAPPED, check_duration, check_rng, check_vector
from pliant.errors import DimensionError, PlanningError, SimulationError
from pliant.interfaces import Controller, Planner, PlanningProblem, Simulator
from pliant.results import PlanResult, Status


@pytest.fixture
def maze(scene_context):
    context = scene_context("se2-maze")
    simulator = registry.create("simulator", "kinematic", context)
    controller = registry.create("controller", "contact", context)
    return context, simulator, controller


def test_a_planner_refuses_a_seed_where_a_generator_goes(maze):
    context = maze[0]
    planner = registry.create("planner", "straight", context)
    with pytest.raises(PlanningError, match=r"rng: must be a numpy\.random\.Generator") as info:
        planner.plan(PlanningProblem.from_context(context), 42)
    assert info.value.value == 42
    with pytest.raises(PlanningError, match=r"problem: must be a pliant\.interfaces\.PlanningProblem"):
        planner.plan(context, np.random.default_rng(0))


@pytest.mark.parametrize("dt", [0.0, -0.1, float("nan"), float("inf"), "soon", None])
def test_a_simulator_step_needs_a_finite_positive_dt(maze, dt):
    context, simulator, _ = maze
    simulator.reset(context.scene.start)
    with pytest.raises(SimulationError, match="dt: must be a"):
        simulator.step(np.zeros(3), dt, np.random.default_rng(0))


@pytest.mark.parametrize("velocity", [[np.nan, 0, 0], [0, 0], [[0, 0, 0]], "fast"])
def test_a_simulator_step_needs_a_finite_velocity_per_tangent_direction(maze, velocity):
    context, simulator, _ = maze
    simulator.reset(context.scene.start)
    with pytest.raises(DimensionError, match="velocity"):
        simulator.step(velocity, 0.1, np.random.default_rng(0))


def test_a_simulator_reset_outside_the_workspace_is_refused(maze):
    context, simulator, _ = maze
    with pytest.raises(DimensionError, match=r"reset: .*outside"):
        simulator.reset(np.asarray(context.scene.start) + [100.0, 0.0, 0.0])


def test_a_kinematic_reset_inside_a_wall_is_refused_and_free_space_is_not(maze):
    context, simulator, _ = maze
    scene = context.scene
    grid = simulator.grid
    occupied = np.argwhere(grid.occupied)
    assert len(occupied)
    inside = None
    for index in occupied[len(occupied) // 2::7]:
        centre = scene.lower + (index + 0.5) * scene.resolution
        q = np.array([centre[0], centre[1], 0.0])
        if context.space.is_valid(q):
            inside = q
            break
    assert inside is not None
    with pytest.raises(SimulationError, match=r"reset: places the robot .* inside "):
        simulator.reset(inside)
    simulator.reset(scene.start)                      # the scene's start is free
    assert np.allclose(simulator.configuration(), scene.start)


@pytest.mark.parametrize("name", ["pymunk", "pybullet"])
def test_dynamic_simulators_refuse_a_reset_inside_a_wall(scene_context, name):
    context = scene_context("se2-maze")
    simulator = registry.create("simulator", name, context)
    from pliant.geometry.voxelgrid import VoxelGrid

    grid = VoxelGrid.from_scene(context.scene)
    occupied = np.argwhere(grid.occupied)
    scene = context.scene
    # a voxel deep inside a wall: all its neighbours within one voxel occupied
    for index in occupied:
        lo, hi = np.maximum(index[:2] - 1, 0), index[:2] + 2
        block = grid.occupied[lo[0]:hi[0], lo[1]:hi[1]]
        if block.shape[:2] == (3, 3) and block.all():
            centre = scene.lower + (index + 0.5) * scene.resolution
            break
    else:
        raise AssertionError("se2-maze has no wall three voxels thick")
    with pytest.raises(SimulationError, match=r"reset: places the robot .* inside"):
        simulator.reset(np.array([centre[0], centre[1], 0.0]))
    simulator.reset(scene.start)


@pytest.mark.parametrize(("q", "target", "field"), [([np.nan, 1, 0], [1, 1, 0], "q"), ([1, 1, 0], [1, np.inf, 0],
                                                                                       "target"),
                                                    ([1, 1], [1, 1, 0], "q")])
def test_a_controller_answers_nan_with_an_error_not_a_nan_command(maze, q, target, field):
    controller = maze[2]
    with pytest.raises(DimensionError, match=f"{field}: must be"):
        controller.command(np.array(q, dtype=float), np.array(target, dtype=float), 0.1)
    with pytest.raises(SimulationError, match="dt: must be"):
        controller.command(np.array([1.0, 1.0, 0.0]), np.array([1.5, 1.0, 0.0]), 0.0)


def test_a_third_party_component_gets_the_checks_without_writing_them():
    class MyPlanner(Planner):
        def plan(self, problem, rng, termination=None):
            return PlanResult(status=Status.INFEASIBLE)

    class MySimulator(Simulator):
        def simulate(self, starts, targets, rng, duration, record=False):
            raise NotImplementedError

        def reset(self, q):
            self.q = q

        def step(self, velocity, dt, rng):
            return velocity * dt

        def configuration(self):
            return self.q

    class MyController(Controller):
        def command(self, q, target, dt):
            return target - q

    for method in (MyPlanner.plan, MySimulator.reset, MySimulator.step, MyController.command):
        assert getattr(method, WRAPPED)
    with pytest.raises(PlanningError, match="rng"):
        MyPlanner().plan(PlanningProblem.__new__(PlanningProblem), None)
    with pytest.raises(SimulationError, match="dt"):
        MySimulator().step(np.zeros(2), -1.0, None)
    with pytest.raises(DimensionError, match="q: must be finite"):
        MyController().command(np.array([np.nan, 0.0]), np.zeros(2), 0.1)
    assert np.allclose(MyController().command(np.zeros(2), np.ones(2), 0.1), 1.0)

    class Derived(MyController):            # an inherited, already wrapped method is not wrapped twice
        pass

    assert Derived.command is MyController.command


@settings(max_examples=200)
@given(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5), st.text(max_size=3),
                 st.none()))
def test_check_duration_accepts_exactly_the_finite_positive_numbers(value):
    try:
        ok = float(value) > 0 and np.isfinite(float(value))
    except (TypeError, ValueError):
        ok = False
    if ok:
        assert check_duration(value) == float(value)
    else:
        with pytest.raises(SimulationError):
            check_duration(value)


@settings(max_examples=200)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=5))
def test_check_vector_accepts_exactly_finite_vectors_of_the_size(values):
    if len(values) == 3 and all(np.isfinite(values)):
        assert check_vector(values, 3, field="v").tolist() == values
    else:
        with pytest.raises(DimensionError, match="v: "):
            check_vector(values, 3, field="v")


def test_check_rng():
    rng = np.random.default_rng(1)
    assert check_rng(rng) is rng
    for bad in (1, None, np.random.RandomState(0)):
        with pytest.raises(PlanningError):
            check_rng(bad)
