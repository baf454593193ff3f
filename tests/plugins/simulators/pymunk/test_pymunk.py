"""The pymunk backend: planar scenes only, free-space agreement with the kinematic simulator, contact."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import Pipeline, load_scene, registry
from pliant.errors import SimulationError
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import Context
from pliant.testing import check_component
from pliant_kinematic.contact import ContactModel


@pytest.fixture(scope="module")
def maze():
    ctx = Context(scene=load_scene("se2-maze"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


def test_free_motion_agrees_with_the_kinematic_simulator(maze):
    pm = registry.create("simulator", "pymunk", maze)
    kin = registry.create("simulator", "kinematic", maze)
    start, target = np.array([[4.0, 4.0, 0.0]]), np.array([4.6, 5.0, 0.2])
    a = pm.simulate(start, target, np.random.default_rng(0), 6.0, record=True)
    b = kin.simulate(start, target, np.random.default_rng(0), 6.0, record=True)
    assert a.reached[0] and b.reached[0] and not a.in_contact[0]
    assert np.abs(a.trajectories - b.trajectories).max() < 0.06       # the compliant pull lags a little


def test_commanded_into_a_wall_it_stops_at_contact_with_bounded_force(maze):
    pm = registry.create("simulator", "pymunk", maze, max_force=500.0)
    pm.reset(np.array([8.0, 8.0, 0.0]))
    grid = ContactModel(VoxelGrid.from_scene(maze.scene))
    rng = np.random.default_rng(0)
    for _ in range(30):
        q = pm.step(np.array([0.0, 1.0, 0.0]), 0.1, rng)
        assert pm.servo_force <= 500.0 * (1 + 1e-9)
    assert pm.in_contact()
    # at rest against the wall, the wall holds exactly the servo's saturated force
    pushes = []
    pm.body.each_arbiter(lambda arbiter: pushes.append(arbiter.total_impulse))
    wall_force = sum(pushes, start=pushes[0] * 0) / (0.1 / pm.substeps)
    assert pm.servo_force == pytest.approx(500.0)
    assert abs(wall_force.y) == pytest.approx(500.0, rel=0.05)
    points = maze.robot.body_points(q)
    # the L's top arm ends 1.5 above the reference: it rests against the top wall (y = 9.5) without entering it
    assert q[1] + 1.5 == pytest.approx(9.5 - 0.125 / 2, abs=0.1)
    assert grid.colliding(points).sum() <= 0.1 * points.shape[1]


def test_pressed_on_a_ledge_and_commanded_along_it_the_block_slides_as_in_the_kinematic_model(maze):
    """se2-maze's goal pocket: the L rests on the ledge of the bottom corridor's dead end (its x-arm's left
    end on the wall below y = 1 left of x = 0.5) and is driven by the contact controller toward the goal,
    mostly down into the ledge.  The servo's force follows the velocity error, so the block slides right
    until it drops into the pocket, as in the frictionless planning model (pymunk's capped pivot joint spent
    its whole force pushing down and the block never moved, frictionless too)."""
    from pliant.execution.loop import Recorder, drive

    pipeline = Pipeline.from_file("maze-policy", overrides=["planner.progress=false"])   # friction 0.1, noise
    context = pipeline.build()
    start, target = np.array([0.645, 1.25, 0.0]), np.array([0.75, 0.75, 0.0])
    for seed in range(3):
        finals = []
        for simulator in (pipeline.execution_world(context), context.simulator):
            simulator.reset(start)
            recorder = Recorder(simulator)
            outcome = drive(simulator, context.controller, target, np.random.default_rng(seed), recorder,
                            time_limit=30.0)
            assert outcome == "reached"
            finals.append(recorder.states[-1])
        assert finals[0][1] < 0.85 and finals[1][1] < 0.85       # both dropped below the ledge (y = 1.25 on it)
        assert np.abs(finals[0][:2] - finals[1][:2]).max() < 0.1


def test_the_scene_bounds_are_walls_where_free_space_reaches_them(maze):
    """se2-maze's top corridor spans the full width: driven right along it, the block stops at x = 10 (the
    bounds, a wall for the voxel cost and the kinematic simulator too) instead of leaving the scene."""
    pm = registry.create("simulator", "pymunk", maze)
    kin = registry.create("simulator", "kinematic", maze)
    start, target = np.array([[8.5, 7.75, 0.0]]), np.array([11.0, 7.75, 0.0])
    a = pm.simulate(start, target, np.random.default_rng(0), 8.0)
    b = kin.simulate(start, target, np.random.default_rng(0), 8.0)
    assert a.in_contact[0] and b.in_contact[0]
    # the x-arm ends 1.5 right of the reference: both stop with it at the boundary
    assert a.final[0, 0] + 1.5 == pytest.approx(10.0, abs=0.08)
    assert abs(a.final[0, 0] - b.final[0, 0]) < 0.08


def test_same_seed_same_trajectory(maze):
    pm = registry.create("simulator", "pymunk", maze, noise="bounded", noise_linear=0.125, noise_angular=0.0156)
    starts = np.array([[4.0, 4.0, 0.0], [5.0, 4.0, 0.0]])
    a = pm.simulate(starts, np.array([4.6, 5.0, 0.2]), np.random.default_rng(5), 3.0)
    b = pm.simulate(starts, np.array([4.6, 5.0, 0.2]), np.random.default_rng(5), 3.0)
    assert np.array_equal(a.final, b.final)
    c = pm.simulate(starts, np.array([4.6, 5.0, 0.2]), np.random.default_rng(6), 3.0)
    assert not np.array_equal(a.final, c.final)


def test_a_3d_scene_is_refused_with_the_reason():
    ctx = Context(scene=load_scene("se3-peg-in-hole"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    with pytest.raises(SimulationError, match="planar"):
        registry.create("simulator", "pymunk", ctx)


def test_conformance():
    assert check_component("simulator", "pymunk", scene="se2-maze")


@pytest.mark.parametrize("simulator", ["kinematic", "pymunk"])
def test_swapping_the_simulator_by_name(simulator, tmp_path):
    record = Pipeline.from_file("maze-slide", overrides=[f"simulator={simulator}", f'output="{tmp_path}"']).run()
    assert record.execution is not None and record.execution.success
    assert (tmp_path / "path.png").is_file()


def test_the_l_block_is_one_polygon_split_along_a_diagonal_without_ghost_corners(maze):
    from pliant_pymunk.world import rectilinear_outline

    outline = rectilinear_outline(maze.scene)
    assert outline == [(-0.25, -0.25), (1.5, -0.25), (1.5, 0.25), (0.25, 0.25), (0.25, 1.5), (-0.25, 1.5)]
    pm = registry.create("simulator", "pymunk", maze)
    pieces = [s for s in pm.world.shapes if s.body is pm.body]
    assert len(pieces) == 2
    assert sum(s.area for s in pieces) == pytest.approx(2 * 1.75 * 0.5 - 0.25)     # the overlap counted once
    vertices = {tuple(np.round(v, 9)) for s in pieces for v in s.get_vertices()}
    assert vertices <= set(outline)                                                  # no vertex inside a face


def test_a_face_slides_past_a_wall_corner_where_two_boxes_would_catch(maze):
    """Turned by -1.2 rad, the L enters the right passage from the top corridor with its face against the
    wall's corner (7, 7).  As two overlapping boxes, the x-arm's corner on that face caught on the wall's top;
    as one polygon it slides down, as the kinematic simulator predicts (friction 0.1, the maze pipelines')."""
    pm = registry.create("simulator", "pymunk", maze, friction=0.1)
    kin = registry.create("simulator", "kinematic", maze)
    start, target = np.array([[7.13, 7.328, -1.166]]), np.array([6.008, 5.564, -1.458])
    a = pm.simulate(start, target, np.random.default_rng(0), 6.0)
    b = kin.simulate(start, target, np.random.default_rng(0), 6.0)
    assert a.final[0, 1] < 6.2 and b.final[0, 1] < 6.2
    assert np.abs(a.final[0, :2] - b.final[0, :2]).max() < 0.3
