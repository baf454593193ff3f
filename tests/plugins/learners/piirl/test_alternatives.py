"""The straight-insertion alternatives a fit compares each demonstration with: the lattice, the funnel check and the
features against the expert's own path-by-path reading; the tilts' round trip; none outside SE(3)."""

import functools

import numpy as np
import pliant
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant_piirl.alternatives import AROUND, straight_alternatives
from pliant_piirl.demonstration import Demonstration, DemonstrationTask
from pliant_piirl.expert import ExpertOptions, SimulatedExpert, funnel_frame, straight_insertion, tilt_of
from pliant_piirl.features import DeformationFeatures, true_sensitivities
from pliant_piirl.sampling import PathSampler, SampleOptions
from pliant_piirl.tasks import TaskSpace, rotation_onto

TIP = np.array([0.0, 0.0, -0.06])


@pytest.fixture(scope="module")
def cube():
    scene = pliant.load_scene("hollow-cube")
    features = DeformationFeatures(scene)
    tasks = TaskSpace(scene)
    rng = np.random.default_rng(5)
    expert = SimulatedExpert(features, true_sensitivities(scene), TIP, ExpertOptions(grid=7, refine=1))
    shown = [expert.demonstrate(tasks.generate_task(a, b, rng, TIP, rotation_onto), rng)
             for a, b in (("L1", "M1"), ("M2", "H1"), ("H2", "L2"))]
    return scene, features, PathSampler(features, TIP, SampleOptions(samples=5)), expert, shown


def test_the_alternatives_are_the_lattices_valid_insertions_read_path_by_path(cube):
    _, features, sampler, expert, shown = cube
    o = ExpertOptions()
    for demonstration in shown:
        task = demonstration.task
        frame = funnel_frame(task)
        got = straight_alternatives(sampler, demonstration, 7)
        # the lattices by hand: 7 x 3 over the openings, 5 x 3 one coarse step (0.2 rad, 0.15 rad) around the
        # demonstration's own direction, its centre left out
        rotation = sampler.robot.rigid_placement(demonstration.path[-1:])[0][0]
        np.testing.assert_allclose(rotation[:, 2], _axis_of(demonstration.path[-1]), atol=1e-12)
        own = tilt_of(rotation[:, 2], frame)
        across, along = np.linspace(-0.6, 0.6, 7), np.linspace(-0.15, 0.15, 3)
        tilts = [(a, b) for a in across for b in along]
        # (the direction and the steps with the module's own arithmetic: a feature counts voxels, and a tilt
        # 1e-17 rad off can move a state onto another voxel)
        step_a, step_b = across[1] - across[0], along[1] - along[0]
        tilts += [(np.clip(own[0] + da, -0.6, 0.6), np.clip(own[1] + db, -0.15, 0.15))
                  for da in np.linspace(-step_a, step_a, 5) for db in np.linspace(-step_b, step_b, 3) if da or db]
        assert len(tilts) == 7 * 3 + AROUND[0] * AROUND[1] - 1
        paths = [straight_insertion(task, t, frame, TIP, o.insertion) for t in tilts]
        valid = [p for p in paths if expert.valid(task, [p])[0]]
        want = np.array([features.of_path(p) for p in valid])
        want = want[np.all(np.isfinite(want), axis=1)]
        assert 0 < len(got) == len(want)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)


def _axis_of(configuration):
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(configuration[3:]).apply([0.0, 0.0, 1.0])


@functools.cache
def _one_task():
    """A hollow-cube task (made once: hypothesis calls the test below 50 times)."""
    return TaskSpace(pliant.load_scene("hollow-cube")).generate_task("L1", "M1", np.random.default_rng(0), TIP,
                                                                       rotation_onto)


@settings(max_examples=50, deadline=None)
@given(st.floats(-0.6, 0.6), st.floats(-0.15, 0.15))
def test_a_straight_insertions_tilts_come_back_from_its_direction(alpha, beta):
    task = _one_task()
    frame = funnel_frame(task)
    path = straight_insertion(task, (alpha, beta), frame, TIP, 0.07)
    d = (path[1, :3] - path[2, :3]) / 0.07
    np.testing.assert_allclose(d, _axis_of(path[-1]), atol=1e-12)           # the body z axis is the direction
    np.testing.assert_allclose(tilt_of(d, frame), [alpha, beta], atol=1e-9)
    # the tip ends on the target
    np.testing.assert_allclose(path[-1, :3] + _rotate(path[-1, 3:], TIP), task.target, atol=1e-12)


def _rotate(q, v):
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q).apply(v)


def test_a_grid_of_zero_or_a_planar_robot_gives_no_alternatives(cube):
    _, features, sampler, _, shown = cube
    assert straight_alternatives(sampler, shown[0], 0).shape == (0, len(features.names))
    planar = pliant.load_scene("planar-objects")
    flat = DeformationFeatures(planar)
    task = DemonstrationTask(planar.start, np.r_[planar.goal[:2], 0.0], goal=planar.goal)
    demonstration = Demonstration(task, np.array([planar.start, planar.goal]))
    got = straight_alternatives(PathSampler(flat, (0.0, 0.0, 0.0)), demonstration, 7)
    assert got.shape == (0, len(flat.names))
