"""The pybullet backend: rest on a box, compliant contact with bounded force, agreement, swapping."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import Pipeline, load_scene, registry
from pliant.errors import SimulationError
from pliant.interfaces import Context
from pliant.testing import check_component


def pose(x, y, z):
    return np.array([x, y, z, 0.0, 0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def peg():
    ctx = Context(scene=load_scene("se3-peg-in-hole"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    return ctx


def test_a_body_dropped_on_a_box_comes_to_rest_on_it(peg):
    sim = registry.create("simulator", "pybullet", peg, gravity=9.81, max_force=0.0)
    sim.reset(pose(7, 7, 4.5))
    rng = np.random.default_rng(0)
    for _ in range(40):
        q = sim.step(np.zeros(6), 0.1, rng)
    assert q[2] == pytest.approx(3.5, abs=0.02) and sim.in_contact()
    assert np.allclose(q[:2], [7, 7], atol=0.01)


def test_commanded_into_the_block_it_stops_with_bounded_force(peg):
    sim = registry.create("simulator", "pybullet", peg, max_force=100.0)
    sim.reset(pose(7, 7, 3.6))
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = sim.step(np.array([0, 0, -1.0, 0, 0, 0]), 0.1, rng)
        force = np.linalg.norm(sim.pb.getConstraintState(sim._hold)[:3])
        assert force <= 100.0 * 1.01
    assert sim.in_contact() and q[2] == pytest.approx(3.5, abs=0.02)


def test_free_motion_and_the_hole_agree_with_the_kinematic_simulator(peg):
    pb = registry.create("simulator", "pybullet", peg, kp=1.0, angular_velocity_limit=0.25)
    kin = registry.create("simulator", "kinematic", peg, kp=1.0, angular_velocity_limit=0.25)
    for start, target, duration in ((pose(8, 8, 8), pose(7, 7.5, 6), 6.0), (pose(5, 5, 3.6), pose(5, 5, 0.625), 6.0)):
        a = pb.simulate(start[None], target, np.random.default_rng(0), duration)
        b = kin.simulate(start[None], target, np.random.default_rng(0), duration)
        assert a.reached[0] and b.reached[0]
        assert np.allclose(a.final[0, :3], b.final[0, :3], atol=0.02)


def test_same_seed_same_trajectory(peg):
    sim = registry.create("simulator", "pybullet", peg, noise="bounded", noise_linear=0.125, noise_angular=0.03)
    starts = np.repeat(pose(6, 6, 3.6)[None], 2, axis=0)
    a = sim.simulate(starts, pose(5, 5, 2), np.random.default_rng(3), 1.0)
    b = sim.simulate(starts, pose(5, 5, 2), np.random.default_rng(3), 1.0)
    assert np.array_equal(a.final, b.final)


def test_urdf_robots_are_refused_with_the_reason():
    ctx = Context(scene=load_scene("iiwa-shelf"))
    ctx.robot = registry.create("robot", "pinocchio", ctx)
    with pytest.raises(SimulationError, match="rigid"):
        registry.create("simulator", "pybullet", ctx)


def test_conformance():
    assert check_component("simulator", "pybullet", scene="se3-peg-in-hole")


@pytest.mark.parametrize("simulator", ["kinematic", "pybullet"])
def test_swapping_the_simulator_by_name_in_se3(simulator, tmp_path):
    record = Pipeline.from_file("peg-slide", overrides=[f"simulator={simulator}", "simulator.noise=none",
                                                        f'output="{tmp_path}"']).run()
    assert record.execution.success and record.execution.configurations[-1, 2] == pytest.approx(0.625, abs=0.1)
