"""The kinematic simulator: free motion, sliding contact, edges, noise bounds, determinism, batches."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from pliant import Scene, load_scene, registry
from pliant.errors import DimensionError
from pliant.execution.noise import ActuationNoise, truncated_normal
from pliant.interfaces import Context
from pliant.testing import check_component
from pliant_kinematic.contact import ContactModel


@functools.cache
def peg(**options):
    ctx = Context(scene=load_scene("se3-peg-in-hole"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.simulator = registry.create("simulator", "kinematic", ctx, kp=1.0, angular_velocity_limit=0.25,
                                    **dict(options))
    return ctx


def pose(x, y, z):
    return np.array([x, y, z, 0.0, 0.0, 0.0, 1.0])


BLOCK_TOP = 3.0
HALF_HEIGHT = 0.5


def test_free_motion_converges_to_the_target():
    sim = peg().simulator
    out = sim.simulate(pose(8, 8, 8)[None], pose(7, 7.5, 6), np.random.default_rng(0), 6.0)
    assert out.reached[0] and not out.in_contact[0] and not out.stuck[0]
    assert np.allclose(out.final[0, :3], [7, 7.5, 6], atol=0.01)


def test_velocity_limit_bounds_each_step():
    sim = peg().simulator
    out = sim.simulate(pose(8, 8, 8)[None], pose(1, 1, 8), np.random.default_rng(0), 1.0, record=True)
    steps = np.linalg.norm(np.diff(out.trajectories[0, :, :3], axis=0), axis=1)
    assert np.all(steps <= 1.0 * 0.1 + 1e-9)       # 1 m/s at 10 Hz


def test_sliding_along_the_block_never_penetrates():
    ctx = peg()
    out = ctx.simulator.simulate(pose(7.5, 7.5, 3.6)[None], pose(6.5, 6.5, 2.0), np.random.default_rng(0), 2.0,
                                 record=True)
    traj = out.trajectories[0]
    assert out.in_contact[0]
    # the bottom face rests on the top of the block (within a clearance), and the peg slid toward the target
    bottom = traj[:, 2] - HALF_HEIGHT
    assert np.all(bottom >= BLOCK_TOP - 1e-9)
    assert traj[-1, 2] - HALF_HEIGHT < BLOCK_TOP + 0.02 * ctx.scene.resolution + 1e-6
    assert traj[-1, 0] < 7.0
    pts = ctx.robot.body_points(traj)
    assert not ContactModel(ctx.simulator.grid).colliding(pts).any()


def test_a_peg_pushed_into_a_wall_stops_at_contact():
    out = peg().simulator.simulate(pose(7, 7, 4)[None], pose(7, 7, 1), np.random.default_rng(0), 3.0)
    assert out.in_contact[0] and out.stuck[0] and not out.reached[0]
    assert out.final[0, 2] == pytest.approx(BLOCK_TOP + HALF_HEIGHT, abs=0.02 * 0.0625 + 1e-9)
    assert np.allclose(out.final[0, :2], [7, 7], atol=1e-9)     # straight down: no sideways slip


def test_the_peg_drops_into_the_hole_when_above_it():
    out = peg().simulator.simulate(pose(5, 5, 3.6)[None], pose(5, 5, 0.625), np.random.default_rng(0), 5.0)
    assert out.reached[0] and out.final[0, 2] == pytest.approx(0.625, abs=0.05)


def test_normal_at_an_edge_follows_the_direction_of_motion():
    grid = peg().simulator.grid
    contact = ContactModel(grid)
    # a point just inside the block's top edge at the hole's rim (x = 4.6875 .. voxel boundary)
    res = grid.resolution
    corner = np.array([4.6875 - 0.2 * res, 5.0, BLOCK_TOP - 0.2 * res])   # in the rim voxel at the hole's edge
    assert contact.colliding(corner[None, None])[0, 0]
    down = contact.penetration(corner[None], np.array([[0.0, 0.0, -1.0]]))[0][0]
    sideways = contact.penetration(corner[None], np.array([[-1.0, 0.0, 0.0]]))[0][0]
    assert np.allclose(down, [0, 0, 1]) and np.allclose(sideways, [1, 0, 0])


def test_same_seed_same_particles_and_batch_equals_one_by_one():
    ctx = peg(noise="bounded", noise_linear=0.125, noise_angular=0.03125)
    starts = np.repeat(pose(6, 6, 3.6)[None], 6, axis=0)
    a = ctx.simulator.simulate(starts, pose(5, 5, 2), np.random.default_rng(7), 1.0)
    b = ctx.simulator.simulate(starts, pose(5, 5, 2), np.random.default_rng(7), 1.0)
    assert np.array_equal(a.final, b.final)
    assert len(np.unique(a.final.round(9), axis=0)) > 1        # the noise does spread the particles
    quiet = peg()
    batch = quiet.simulator.simulate(np.vstack([pose(6, 6, 3.6), pose(8, 8, 8), pose(5, 5, 3.6)]), pose(5, 5, 2),
                                     np.random.default_rng(0), 1.0)
    for k, start in enumerate([pose(6, 6, 3.6), pose(8, 8, 8), pose(5, 5, 3.6)]):
        one = quiet.simulator.simulate(start[None], pose(5, 5, 2), np.random.default_rng(0), 1.0)
        assert np.allclose(one.final[0], batch.final[k], atol=1e-9)


def test_noise_stays_inside_its_bounds():
    rng = np.random.default_rng(0)
    limit = np.array([0.125, 0.125, 0.125, 0.03125, 0.03125, 0.03125])
    draws = truncated_normal(rng, np.broadcast_to(limit, (20000, 6)))
    assert np.all(np.abs(draws) <= limit) and np.allclose(draws.mean(axis=0), 0, atol=3e-3)
    assert np.allclose(draws.std(axis=0) / limit, 0.44, atol=0.02)   # sigma = limit / 2, truncated at 2 sigma
    eq614 = ActuationNoise("floor", np.full(2, 0.25), velocity_limit=np.array([1.0, 2.0]))
    assert np.allclose(eq614.limits(np.array([[1.0, 0.0]])), [[0.25, 0.125]])
    prop = ActuationNoise("proportional", np.full(2, 0.1))
    assert np.all(np.abs(prop.sample(rng, np.array([[0.5, 0.0]]) * np.ones((100, 1)))) <= [0.05, 0.0])


def test_qp_solver_also_resolves_contact():
    ctx = peg(solver="qp")
    out = ctx.simulator.simulate(pose(7.5, 7.5, 3.6)[None], pose(6.5, 6.5, 2.0), np.random.default_rng(0), 1.0)
    assert out.in_contact[0] and out.final[0, 2] - HALF_HEIGHT >= BLOCK_TOP - 1e-9


def test_planar_maze_motion_stays_in_the_corridor(scene_context):
    ctx = scene_context("se2-maze")
    sim = registry.create("simulator", "kinematic", ctx)
    start = np.array([7.75, 7.75, 0.0])
    out = sim.simulate(start[None], np.array([7.75, 0.75, 0.0]), np.random.default_rng(0), 20.0, record=True)
    pts = ctx.robot.body_points(out.trajectories[0])
    assert not ContactModel(sim.grid).colliding(pts).any()
    assert out.final[0, 1] < 2.0


def test_stepping_api_and_bad_input():
    sim = peg().simulator
    sim.reset(pose(8, 8, 8))
    q = sim.step(np.array([1.0, 0, 0, 0, 0, 0]), 0.1, np.random.default_rng(0))
    assert q[0] == pytest.approx(8.1)
    with pytest.raises(DimensionError):
        sim.step(np.zeros(3), 0.1, np.random.default_rng(0))
    with pytest.raises(DimensionError):
        sim.simulate(np.zeros((2, 3)), pose(1, 1, 1), np.random.default_rng(0), 1.0)
    with pytest.raises(DimensionError):
        sim.simulate(pose(8, 8, 8)[None], pose(np.nan, 1, 1), np.random.default_rng(0), 1.0)


def test_conformance():
    assert check_component("simulator", "kinematic", scene="se2-maze")


def test_scene_objects_of_any_shape_block_motion():
    data = {"name": "ball", "start": [0.5, 0.5, 0.5], "goal": [0.5, 0.5, 0.5],
            "bounds": {"lower": [0, 0, 0], "upper": [1, 1, 1], "resolution": 0.05},
            "objects": [{"name": "ball", "shape": "sphere", "radius": 0.2, "position": [0.5, 0.5, 0.5],
                         "deformability": 0.0, "sensitivity": 1.0}],
            "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "box", "size": [0.1, 0.1, 0.1]}]}}
    ctx = Context(scene=Scene.from_dict(data))
    ctx.robot = registry.create("robot", "rigid", ctx)
    sim = registry.create("simulator", "kinematic", ctx, kp=1.0)
    out = sim.simulate(np.array([[0.5, 0.5, 0.9]]), np.array([0.5, 0.5, 0.5]), np.random.default_rng(0), 2.0)
    assert out.in_contact[0] and out.final[0, 2] > 0.5 + 0.2


@pytest.mark.parametrize("solver", ["effort", "least-squares"])    # the default, and the thesis's eq. 8.5
@pytest.mark.parametrize("scene", ["se3-peg-in-hole", "se2-maze"])
def test_fused_kernel_equals_the_generic_path(scene, solver):
    ctx = Context(scene=load_scene(scene))
    ctx.robot = registry.create("robot", "rigid", ctx)
    options = {"noise": "bounded", "noise_linear": 0.125, "noise_angular": 0.03, "solver": solver}
    fused = registry.create("simulator", "kinematic", ctx, **options)
    generic = registry.create("simulator", "kinematic", ctx, fused_kernel=False, **options)
    if scene == "se2-maze":
        starts, target = np.repeat([[7.75, 7.75, 0.0]], 8, axis=0), np.array([9.0, 0.75, 0.5])
    else:
        starts, target = np.repeat(pose(6, 6, 3.55)[None], 8, axis=0), pose(5, 5, 2)
    a = fused.simulate(starts, target, np.random.default_rng(3), 2.0)
    b = generic.simulate(starts, target, np.random.default_rng(3), 2.0)
    assert a.in_contact.any()
    assert np.allclose(a.final, b.final, atol=1e-9)
    assert np.array_equal(a.in_contact, b.in_contact)


def test_an_arm_pushed_into_a_board_stops_in_contact_within_its_limits():
    ctx = Context(scene=load_scene("iiwa-shelf"))
    ctx.robot = registry.create("robot", "pinocchio", ctx)
    sim = registry.create("simulator", "kinematic", ctx)
    start = np.array([[0.0, 0.3, 0.0, -1.2, 0.0, 0.6, 0.0]])
    out = sim.simulate(start, np.array([0.0, 1.7, 0.0, -0.3, 0.0, 0.6, 0.0]), np.random.default_rng(0), 4.0,
                       record=True)
    assert out.in_contact[0] and not out.reached[0]
    assert np.all(out.trajectories >= ctx.robot.space.lower - 1e-12)
    assert np.all(out.trajectories <= ctx.robot.space.upper + 1e-12)
    # the voxel model keeps penetration within a voxel of the board
    assert ctx.robot.environment_distance(out.final)[0] > -ctx.scene.resolution
    free = sim.simulate(start, np.array([0.0, 1.2, 0.0, 0.3, 0.0, 1.2, 0.0]), np.random.default_rng(0), 4.0)
    assert free.reached[0] and not free.in_contact[0]


def test_an_arm_at_rest_stays_put_for_one_look_at_its_points_per_step(monkeypatch):
    """A robot peer's arm holds still for most of a test: a noiseless step at zero velocity is one microstep,
    and a free microstep places the body points once (not again for the point of departure and the final check; the
    next step's travel bound starts from them)."""
    ctx = Context(scene=load_scene("iiwa-shelf"))
    ctx.robot = registry.create("robot", "pinocchio", ctx)
    sim = registry.create("simulator", "kinematic", ctx)
    start = np.array([0.0, 0.3, 0.0, -1.2, 0.0, 0.6, 0.0])
    sim.reset(start)
    rng = np.random.default_rng(0)
    assert sim.microsteps(start[None], np.zeros((1, 7)), 0.002) == 1
    calls = []
    placed = ctx.robot.body_points
    monkeypatch.setattr(ctx.robot, "body_points", lambda q, indices=None: calls.append(len(q)) or placed(q, indices))
    for _ in range(3):
        assert np.array_equal(sim.step(np.zeros(7), 0.002, rng), start) and not sim.in_contact()
    assert calls == [1, 1, 1]
    # moving, the travel bound places the points after the step (those before are the last free microstep's), then
    # each free microstep places them once
    micro = sim.microsteps(start[None], np.full((1, 7), 0.1), 0.002)
    calls.clear()
    moved = sim.step(np.full(7, 0.1), 0.002, rng)
    assert np.allclose(moved, start + 0.0002) and calls == [1] + [1] * micro
    sim.reset(start)                                # another configuration than the last placed: placed again
    calls.clear()
    sim.step(np.full(7, 0.1), 0.002, rng)
    assert calls == [1, 1] + [1] * micro


def test_self_collision_momentum_model_keeps_an_arm_out_of_itself():
    ctx = Context(scene=load_scene("iiwa-shelf"))
    ctx.robot = registry.create("robot", "pinocchio", ctx)
    folded = np.array([2.9, 2.0, 0.0, -2.0, 0.0, 2.0, 0.0])           # folds the forearm into the upper arm
    assert ctx.robot.self_collision(folded[None])[0]
    start = np.array([[2.9, 0.0, 0.0, -0.5, 0.0, 0.5, 0.0]])
    modelled = registry.create("simulator", "kinematic", ctx).simulate(start, folded, np.random.default_rng(0), 5.0,
                                                                       record=True)
    ignored = registry.create("simulator", "kinematic", ctx, self_collision=False).simulate(
        start, folded, np.random.default_rng(0), 5.0, record=True)
    assert ignored.reached[0] and ctx.robot.self_collision(ignored.trajectories[0]).any()
    assert modelled.in_contact[0] and not modelled.reached[0]
    assert not ctx.robot.self_collision(modelled.trajectories[0]).any()


def test_self_contacts_with_non_finite_geometry_are_left_out():
    """coal sometimes reports a colliding link pair of Baxter's arm with NaN witness points and normal; one
    such row turned the damped least squares into NaN joints.  The simulator drops it and resolves the
    others: the folded iiwa still ends out of collision, with finite joints."""
    ctx = Context(scene=load_scene("iiwa-shelf"))
    ctx.robot = registry.create("robot", "pinocchio", ctx)
    real = ctx.robot.self_contacts

    def with_a_broken_row(q):
        c = real(q)
        if c is None or len(c) == 0:
            return c
        fields = {name: np.concatenate([value, np.full_like(value[:1], np.nan)]) for name, value in vars(c).items()}
        return type(c)(**fields)

    ctx.robot.self_contacts = with_a_broken_row
    sim = registry.create("simulator", "kinematic", ctx)
    folded = np.array([2.9, 2.0, 0.0, -2.0, 0.0, 2.0, 0.0])
    assert len(sim._self_contacts(folded)) == len(real(folded)) > 0
    out = sim.simulate(np.array([[2.9, 0.0, 0.0, -0.5, 0.0, 0.5, 0.0]]), folded, np.random.default_rng(0), 5.0,
                       record=True)
    assert np.isfinite(out.trajectories).all()
    assert not ctx.robot.self_collision(out.trajectories[0]).any()


def test_self_contacts_of_a_rigid_body_are_none(scene_context):
    assert scene_context("se2-maze").robot.self_contacts(np.array([7.75, 7.75, 0.0])) is None


def test_forward_and_back_batches():
    sim = peg().simulator
    starts = np.vstack([pose(8, 8, 8), pose(7, 8, 6), pose(6.5, 6.5, 3.6)])
    forward = sim.simulate(starts, pose(7, 7, 6), np.random.default_rng(0), 4.0)
    back = sim.simulate(forward.final, starts, np.random.default_rng(0), 4.0)
    assert forward.reached.all() and back.reached.all()
    assert np.allclose(back.final[:, :3], starts[:, :3], atol=0.07)


# --- the effort-limited contact correction (se2-maze: contact must not spin the L-block) -----------------

MAZE_CONTROL = {"kp": 0.5, "velocity_limit": 1.0, "angular_velocity_limit": 0.125}
#: (start, target) pairs where eq. 8.5's least squares turned the L-block against its command at a corner
MAZE_CORNERS = [(np.array([7.75, 7.75, 0.0]), np.array([6.68, 6.19, -0.65])),
                (np.array([3.56, 7.21, 1.32]), np.array([3.32, 5.35, 2.0]))]


@functools.cache
def maze():
    ctx = Context(scene=load_scene("se2-maze"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


def heading_error(q, target):
    return np.abs((target[2] - q[..., 2] + np.pi) % (2 * np.pi) - np.pi)


@pytest.mark.parametrize("fused", [True, False])
@pytest.mark.parametrize("case", range(len(MAZE_CORNERS)))
def test_contact_at_a_corner_does_not_turn_the_body_against_its_command(case, fused):
    start, target = MAZE_CORNERS[case]
    sim = registry.create("simulator", "kinematic", maze(), fused_kernel=fused, **MAZE_CONTROL)
    out = sim.simulate(start[None], target, np.random.default_rng(0), 8.0, record=True)
    traj = out.trajectories[0]
    assert out.in_contact[0]
    # the heading never gets farther from the commanded one than it started (+ 0.02 rad of contact slack) ...
    assert np.all(heading_error(traj, target) <= heading_error(start, target) + 0.02)
    # ... turns at no more than the speed limit, and reaches the commanded heading, as pymunk does
    turn = np.abs((np.diff(traj[:, 2]) + np.pi) % (2 * np.pi) - np.pi)
    assert np.all(turn <= 0.125 * 0.1 + 0.01)
    assert heading_error(out.final[0], target) < 0.02
    # (the second start overlaps the wall corner by two points: the first step pushes them out)
    assert not ContactModel(sim.grid).colliding(maze().robot.body_points(traj[1:])).any()


@pytest.mark.parametrize("case", range(len(MAZE_CORNERS)))
def test_the_thesis_least_squares_does_not_reach_the_commanded_heading_at_a_corner(case):
    """The behaviour the effort solver replaces (eq. 8.5's least squares, kept as an option): fitting every
    point's push-out vector holds the body's faces flush with the wall (or, with tracing alone, turned it
    against its command), so it ends far from the heading the effort solver reaches within 0.02 rad."""
    start, target = MAZE_CORNERS[case]
    old = registry.create("simulator", "kinematic", maze(), solver="least-squares", **MAZE_CONTROL)
    before = old.simulate(start[None], target, np.random.default_rng(0), 8.0)
    assert heading_error(before.final[0], target) > 0.4


@pytest.mark.parametrize("fused", [True, False])
def test_a_robot_face_slides_past_the_end_of_a_wall(fused):
    """The L-block's left face against the end of the wall between the right and middle passages: the
    points of its face passing the wall's corner must push it along x (the face's normal), not up (the
    wall's top face, which tracing alone picks for a point that crossed both planes within the clearance)
    and jam it there."""
    sim = registry.create("simulator", "kinematic", maze(), fused_kernel=fused, **MAZE_CONTROL)
    start = np.array([7.2512, 6.876, 0.0])            # the face flush against the wall's end (x = 7.0)
    out = sim.simulate(start[None], np.array([6.336, 6.336, 0.0]), np.random.default_rng(0), 5.0)
    # it slides down along the wall to the target's height, never through it
    assert out.final[0, 0] > 7.0 + 0.25 - 1e-3
    assert abs(out.final[0, 1] - 6.336) < 0.05
    faces = maze().robot.surface_faces()
    assert faces.shape == (len(maze().robot.surface_indices()), 6)
    # every point of a one-layer plate lies on both z faces; at most two in-plane faces meet at a corner
    assert faces[:, 4:].all() and faces[:, :4].sum(axis=1).max() == 2


def test_surface_faces_of_the_l_block_are_its_face_normals():
    robot = maze().robot
    local = robot.rigid_placement(np.zeros((1, 3)))[2][robot.surface_indices()]
    faces = robot.surface_faces()
    # the leftmost points of the L (x = -0.25) are on its -x face, the lowest (y = -0.25) on its -y face
    assert np.all(faces[np.isclose(local[:, 0], local[:, 0].min()), 0])
    assert np.all(faces[np.isclose(local[:, 1], local[:, 1].min()), 2])
    assert not faces[~np.isclose(local[:, 0], local[:, 0].min()), 0].any()


def test_the_corner_case_ends_near_the_dynamic_simulator():
    """Both slide the L down the passage from the corner; the frictionless kinematic model is compared with
    pymunk frictionless and at the maze pipelines' friction 0.1 (at pymunk's default 0.5 the pressed block
    slides 0.14 m less in the 8 s: friction the kinematic model does not have)."""
    start, target = MAZE_CORNERS[0]
    pytest.importorskip("pymunk")
    kinematic = registry.create("simulator", "kinematic", maze(), **MAZE_CONTROL)
    a = kinematic.simulate(start[None], target, np.random.default_rng(0), 8.0).final[0]
    for friction in (0.0, 0.1):
        dynamic = registry.create("simulator", "pymunk", maze(), friction=friction, **MAZE_CONTROL)
        b = dynamic.simulate(start[None], target, np.random.default_rng(0), 8.0).final[0]
        assert maze().robot.space.distance(a, b) < 0.05     # it slid down the passage as pymunk does


def test_effort_correction_pushes_a_short_lever_out_without_turning():
    from pliant_kinematic.rigid_kernel import effort_correction

    groups, weights = np.array([0, 0, 1]), np.array([1.0, 0.9])
    out = np.empty(3)
    # one contact at lever 0.5 < 0.9 m, normal +x, 1 cm deep: exactly a translation (a quadratic metric, the
    # ellipsoidal limit surface, would turn it by 2.4e-3 rad)
    effort_correction(np.array([[1.0, 0.0, -0.5]]), np.array([0.01]), 1, groups, weights, 1e-6, out)
    assert np.allclose(out, [0.01, 0.0, 0.0], atol=1e-12)
    # a lever of 2 m > 0.9 m: a pure rotation is cheaper (0.9 * 0.005 < 0.01)
    effort_correction(np.array([[1.0, 0.0, 2.0]]), np.array([0.01]), 1, groups, weights, 1e-6, out)
    assert np.allclose(out, [0.0, 0.0, 0.005], atol=1e-6)
    # a flat face pushed evenly at many points: exactly a translation (the active set has no GS-order bias)
    levers = np.linspace(-0.5, 0.5, 9)
    rows = np.array([[0.0, 1.0, x] for x in levers])
    effort_correction(rows, np.full(9, 0.01), 9, groups, weights, 1e-6, out)
    assert np.allclose(out, [0.0, 0.01, 0.0], atol=1e-9)
    # a tilted face (depth 0 to 1 cm) with levers under 0.9 m: translated by the deepest depth, not snapped flush
    depth = 0.005 + 0.01 * levers
    effort_correction(rows, depth, 9, groups, weights, 1e-6, out)
    assert np.all(rows @ out >= depth - 1e-6) and np.allclose(out, [0.0, 0.01, 0.0], atol=1e-12)
    # the thesis's least squares instead turns it flush (the fit explains the depths by a rotation of 0.01 rad)
    assert np.allclose(np.linalg.lstsq(rows, depth, rcond=None)[0][1:], [0.005, 0.01])


@pytest.mark.parametrize("fused", [True, False])
def test_a_tilted_robot_face_slides_over_a_wall_corner_into_the_corridor(fused):
    """The L-block turned by -1.1 rad leaving the right passage: the wall's corner pokes its (tilted) face,
    and the contact normal is the face's, so it slides up past the corner into the top corridor (as pymunk
    does) instead of being pushed straight back along the wall's axis and jamming below it."""
    sim = registry.create("simulator", "kinematic", maze(), fused_kernel=fused, **MAZE_CONTROL)
    out = sim.simulate(np.array([[7.349, 6.472, -0.971]]), np.array([5.489, 7.193, -1.119]),
                       np.random.default_rng(0), 8.0)
    assert out.final[0, 1] > 7.5 and out.in_contact[0]
    assert not ContactModel(sim.grid).colliding(maze().robot.body_points(out.final)).any()


def test_control_law_predicts_a_free_step_and_its_noise():
    """Simulator.control_law(): its noise-free step is simulate's in free space; step_noise matches its spread."""
    ctx = Context(scene=load_scene("se3-peg-in-hole"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    quiet = registry.create("simulator", "kinematic", ctx, kp=0.5, angular_velocity_limit=0.25)
    q = np.array([pose(3.0, 4.0, 6.2), pose(4.0, 3.0, 6.5)])          # well above the block
    target = pose(3.5, 3.5, 6.0)
    law = quiet.control_law()
    assert law.dt == pytest.approx(0.1) and law.kp == 0.5
    simulated = quiet.simulate(q, target, np.random.default_rng(0), 0.1).final
    assert np.allclose(law.step(q, target), simulated, atol=1e-9)
    noisy = registry.create("simulator", "kinematic", ctx, kp=0.5, noise="bounded", noise_linear=0.2,
                            noise_angular=0.05)
    law = noisy.control_law()
    rng = np.random.default_rng(1)
    starts = np.repeat(q[:1], 400, axis=0)
    velocity = law.velocity(starts, target)
    predicted = law.step_noise(rng, starts, velocity)
    moved = noisy.space.difference(noisy.simulate(starts, target, rng, 0.1).final, starts) - velocity * law.dt
    assert np.all(np.abs(predicted) <= law.noise_bounds(velocity) + 1e-12)
    # the same spread (the simulator averages one draw per microstep; so does step_noise)
    assert np.std(predicted[:, 0]) == pytest.approx(np.std(moved[:, 0]), rel=0.25)
