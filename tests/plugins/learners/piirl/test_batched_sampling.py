"""The batched sample paths and features equal the one-path-at-a-time reference (same seed, same numbers)."""

import inspect
import itertools

import numpy as np
import pliant
import pytest
from pliant_piirl.demonstration import Demonstration, DemonstrationTask
from pliant_piirl.expert import ExpertOptions, SimulatedExpert
from pliant_piirl.features import DeformationFeatures, true_sensitivities
from pliant_piirl.sampling import FUNNEL_TOLERANCE, PathSampler, SampleOptions, _funnel_codes
from pliant_piirl.tasks import TaskSpace, rotation_onto

TIP = np.array([0.0, 0.0, -0.06])


# --- the slow references: one path, one segment, one sample at a time ------------------------------------------

def reference_states(features, path):
    """The states of one path, segment by segment."""
    path = np.atleast_2d(np.asarray(path, dtype=np.float64))
    pieces = [path[:1]]
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(float(features.space.distance(a, b)) / features.step)))
        t = np.arange(1, n + 1, dtype=np.float64)[:, None] / n
        pieces.append(features.space.interpolate(np.broadcast_to(a, (n, len(a))), np.broadcast_to(b, (n, len(b))), t))
    return np.concatenate(pieces)


def reference_features(features, paths):
    """The features of each path, read path by path."""
    return np.array([features.cost.breakdown(reference_states(features, p)).sum(axis=0) for p in paths])


def reference_draw(sampler, demonstration, rng, n=None):
    """Candidates drawn in the same batches, each retracted, put on the target and checked on its own."""
    features, space = sampler.features, sampler.space
    n = sampler.options.samples if n is None else n
    base = sampler.resample(demonstration.path)
    task = demonstration.task
    out = []
    budget = n * (1 + sampler.options.redraws)
    while len(out) < n and budget > 0:
        batch = min(budget, 2 * (n - len(out)))
        budget -= batch
        chol = sampler._chol if task.goal is None else sampler._chol_clamped
        noise = np.einsum("ij,bjt->bit", chol, rng.normal(size=(batch, len(chol), len(sampler._scale))))
        for eps in noise * sampler._scale:
            sample = base.copy()
            sample[1:1 + len(chol)] = space.retract(base[1:1 + len(chol)], eps)
            if task.goal is None:
                rot, _, _ = sampler.robot.rigid_placement(sample[-1][None])
                sample[-1, :3] = task.target - rot[0] @ sampler.tip
            else:
                sample[-1] = task.goal
            if task.allows(features.outline(reference_states(features, sample))).all():
                out.append(sample)
                if len(out) == n:
                    break
    feats = reference_features(features, out) if out else np.zeros((0, len(features.names)))
    finite = np.all(np.isfinite(feats), axis=1)
    return [p for p, f in zip(out, finite) if f], feats[finite]


# --- fixtures ---------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def cube():
    scene = pliant.load_scene("hollow-cube")
    features = DeformationFeatures(scene)
    expert = SimulatedExpert(features, true_sensitivities(scene), TIP, ExpertOptions(grid=7, refine=1, noise=0.0))
    task = TaskSpace(scene).generate_task("L1", "M1", np.random.default_rng(1), TIP, rotation_onto)
    return features, expert.demonstrate(task, np.random.default_rng(0))


@pytest.fixture(scope="module")
def planar():
    scene = pliant.load_scene("planar-objects")
    features = DeformationFeatures(scene)
    task = DemonstrationTask(scene.start, np.r_[scene.goal[:2], 0.0], goal=scene.goal)
    turn = np.pi / 2
    path = np.array([scene.start, [0.1275, 0.2, turn], [0.1275, 0.4, turn], scene.goal])
    return features, Demonstration(task, path)


def _same(paths, others):
    return len(paths) == len(others) and all(np.array_equal(a, b) for a, b in zip(paths, others))


# --- states and features ----------------------------------------------------------------------------------------

def test_states_of_a_straight_segment_are_evenly_spaced_at_most_a_step_apart(cube):
    features, _ = cube
    q = np.r_[0.2, 0.1, 0.3, rotation_onto([0.0, 1.0, 0.0])]
    end = q.copy()
    end[0] += 0.009                                                 # 9 mm at most 2 mm apart: five pieces of 1.8
    assert features.step == pytest.approx(0.002)
    states, counts = features.path_states([np.array([q, end]), q[None]])
    assert counts.tolist() == [6, 1]
    assert np.allclose(states[:6, 0], 0.2 + 0.0018 * np.arange(6))
    assert np.allclose(states[:, 1:3], [0.1, 0.3]) and np.allclose(states[:, 3:], q[3:])
    assert np.array_equal(states[6], q)
    empty, none = features.path_states([])
    assert empty.shape == (0, 7) and none.shape == (0,)
    assert features.of_paths([]).shape == (0, len(features.names))


def test_batched_states_and_features_equal_the_path_by_path_reference(cube):
    features, shown = cube
    rng = np.random.default_rng(7)
    paths = [shown.path, shown.path[:1], shown.path[:2]]
    for k in (2, 3, 5, 12):                                         # paths of other lengths near the demonstration
        base = np.repeat(shown.path[-1:], k, axis=0)
        noise = rng.normal(scale=[0.01, 0.01, 0.01, 0.1, 0.1, 0.1], size=(k, 6))
        paths.append(features.space.retract(base, noise))
    states, counts = features.path_states(paths)
    reference = [reference_states(features, p) for p in paths]
    assert counts.tolist() == [len(r) for r in reference]
    assert np.array_equal(states, np.concatenate(reference))        # bit for bit, not just close
    for p, r in zip(paths, reference):
        assert np.array_equal(features.states(p), r)
    assert np.array_equal(features.of_paths(paths), reference_features(features, paths))
    same_length = np.array(paths[3:4] * 3)                          # an (n, k, d) array
    assert np.array_equal(features.path_states(same_length)[0], np.concatenate([reference[3]] * 3))


def test_a_path_leaving_the_grid_has_nan_features_and_leaves_the_others_alone(cube):
    features, shown = cube
    away = shown.path.copy()
    away[-1, :3] += 5.0                                             # far outside the voxel grid
    got = features.of_paths([shown.path, away, shown.path])
    assert np.all(np.isnan(got[1]))
    assert np.array_equal(got[0], features.of_path(shown.path)) and np.array_equal(got[2], got[0])


# --- the funnel check -------------------------------------------------------------------------------------------

def test_the_funnel_kernel_decides_beyond_doubt_and_leaves_the_boundary_undecided():
    hull = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    normals = np.array([[1.0, 0.0, 0.0]])
    limits = np.array([1.0])                                        # x <= 1: a unit cube at x = c reaches c + 0.5
    x = np.array([0.4, 0.6, 0.4, 0.4, 0.5, 0.7, 0.5])
    counts = np.array([2, 3, 2])                                    # [in, out], [in, in, on], [out, on]
    pos = np.column_stack([x, np.zeros(7), np.zeros(7)])
    rot = np.repeat(np.eye(3)[None], 7, axis=0)
    out = np.empty(3, dtype=np.int64)
    _funnel_codes(rot, pos, hull, normals, limits, 1e-12, counts, out)
    assert out.tolist() == [0, -1, 0]
    turned = np.repeat(np.array([[[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]]), 7, axis=0)
    _funnel_codes(turned, pos, hull, normals, limits, 1e-12, counts, out)  # a quarter turn about z: same cube
    assert out.tolist() == [0, -1, 0]


def test_the_funnel_tolerance_is_the_tasks():
    assert inspect.signature(DemonstrationTask.allows).parameters["tolerance"].default == FUNNEL_TOLERANCE


def test_the_batched_funnel_check_equals_the_exact_one_even_on_the_boundary(cube):
    features, shown = cube
    task = shown.task
    sampler = PathSampler(features, TIP)
    rng = np.random.default_rng(3)
    along = features.states(shown.path)
    base = along[rng.integers(0, len(along), 60)]
    states = features.space.retract(base, rng.normal(scale=[0.002] * 3 + [0.02] * 3, size=(60, 6)))
    # every sixth state exactly on a plane of the funnel (its outline's furthest vertex there, plus the tolerance)
    for i in range(0, 60, 6):
        normal, offset = task.planes[i // 6 % len(task.planes), :3], task.planes[i // 6 % len(task.planes), 3]
        states[i, :3] += normal * (offset + FUNNEL_TOLERANCE - (features.outline(states[i]) @ normal).max())
    exact = task.allows(features.outline(states)).all(axis=1)
    assert exact.any() and not exact.all()
    rot, pos, hull = features.outline_placement(states)
    codes = np.empty(60, dtype=np.int64)
    _funnel_codes(rot, pos, hull, np.ascontiguousarray(task.planes[:, :3]), task.planes[:, 3] + FUNNEL_TOLERANCE,
                  1e-12, np.ones(60, dtype=np.int64), codes)
    assert (codes == -1).sum() >= 5                                 # the kernel leaves the boundary undecided
    assert np.array_equal(codes[codes >= 0] == 1, exact[codes >= 0])
    for counts in (np.ones(60, dtype=np.int64), np.array([1] * 30 + [3] * 10)):
        starts = np.cumsum(counts) - counts
        expected = np.logical_and.reduceat(exact, starts)
        assert np.array_equal(sampler._paths_allowed(states, counts, task), expected)
        maybe = sampler._paths_allowed(states, counts, task, exact=False)
        assert np.all(maybe[expected])                              # the pre-check never rejects an allowed path


# --- whole draws ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("options", [SampleOptions(samples=15),
                                     SampleOptions(samples=10, redraws=1)])
def test_the_batched_draw_equals_the_sample_by_sample_reference(cube, options):
    features, shown = cube
    sampler = PathSampler(features, TIP, options)
    rng, reference_rng = np.random.default_rng(11), np.random.default_rng(11)
    paths, feats = sampler.draw_with_features(shown, rng)
    expected, expected_feats = reference_draw(sampler, shown, reference_rng)
    assert _same(paths, expected) and np.array_equal(feats, expected_feats)
    assert rng.bit_generator.state == reference_rng.bit_generator.state            # the same random stream
    assert len(paths) > 0 and np.array_equal(feats, features.of_paths(paths))
    assert _same(sampler.draw(shown, np.random.default_rng(11)), paths)


def test_few_redraws_run_out_before_n_paths(cube):
    features, shown = cube                                          # so the test above covers the budget's end too
    sampler = PathSampler(features, TIP, SampleOptions(samples=10, redraws=1))
    paths, feats = sampler.draw_with_features(shown, np.random.default_rng(11))
    assert 0 < len(paths) < 10 and feats.shape == (len(paths), len(features.names))


def test_samples_leaving_the_grid_are_dropped_as_the_reference_drops_them(cube):
    features, _ = cube
    grid = features.cost.grid
    top = grid.lower[2] + grid.resolution * grid.shape[2]
    down = rotation_onto([0.0, 0.0, -1.0])                          # the probe upright, its top 4 mm below the grid's
    start, end = np.r_[0.2, 0.2, top - 0.09, down], np.r_[0.2, 0.2, top - 0.064, down]
    rot, _, _ = features.robot.rigid_placement(end[None])
    demo = Demonstration(DemonstrationTask(start, end[:3] + rot[0] @ TIP), np.array([start, end]))   # no funnel
    sampler = PathSampler(features, TIP, SampleOptions(samples=20, rotation=0.2))
    paths, feats = sampler.draw_with_features(demo, np.random.default_rng(0))
    expected, expected_feats = reference_draw(sampler, demo, np.random.default_rng(0))
    assert 0 < len(paths) < 20 and np.all(np.isfinite(feats))      # some tilted past the grid's top: NaN, dropped
    assert _same(paths, expected) and np.array_equal(feats, expected_feats)


def test_the_batched_draw_of_a_goal_task_equals_the_reference(planar):
    features, demo = planar
    sampler = PathSampler(features, (0.0, 0.0, 0.0), SampleOptions(samples=10))
    rng, reference_rng = np.random.default_rng(0), np.random.default_rng(0)
    paths, feats = sampler.draw_with_features(demo, rng)
    expected, expected_feats = reference_draw(sampler, demo, reference_rng)
    assert len(paths) == 10 and _same(paths, expected) and np.array_equal(feats, expected_feats)
    assert rng.bit_generator.state == reference_rng.bit_generator.state
