"""Tasks, the simulated expert and the sample paths on the real hollow-cube scene (thesis 4.4.1)."""

import numpy as np
import pliant
import pytest
from pliant.errors import ConfigError, PlanningError
from pliant_piirl.expert import ExpertOptions, SimulatedExpert, funnel_frame
from pliant_piirl.features import DeformationFeatures, true_sensitivities, unit_sensitivity_scene
from pliant_piirl.sampling import PathSampler, SampleOptions, smooth_covariance
from pliant_piirl.tasks import TaskSpace, rotation_onto

TIP = np.array([0.0, 0.0, -0.06])
CENTRE = np.full(3, 0.202)


@pytest.fixture(scope="module")
def cube():
    scene = pliant.load_scene("hollow-cube")
    return scene, TaskSpace(scene), DeformationFeatures(scene)


def test_every_face_is_adjacent_to_the_four_faces_it_meets(cube):
    _, tasks, _ = cube
    opposite = {"L1": "L2", "L2": "L1", "M1": "M2", "M2": "M1", "H1": "H2", "H2": "H1"}
    adjacency = tasks.adjacency()
    for name, neighbours in adjacency.items():
        assert neighbours == set(opposite) - {name, opposite[name]}


def test_the_distance_fields_are_built_once_per_grid_and_equal_fresh_transforms(cube, tmp_path, monkeypatch):
    from pliant import cache
    from scipy import ndimage

    scene, tasks, _ = cube
    grid = tasks.grid
    for k in range(len(tasks.names)):               # against the transforms themselves
        np.testing.assert_array_equal(tasks._each[k], ndimage.distance_transform_edt(grid.object_id != k) *
                                      grid.resolution)
    np.testing.assert_array_equal(tasks.clearance_field, ndimage.distance_transform_edt(~grid.occupied) *
                                  grid.resolution)
    monkeypatch.setenv("PLIANT_CACHE_DIR", str(tmp_path / "cache"))
    cache.forget()
    first = TaskSpace(scene)
    before = dict(cache.counts)
    second = TaskSpace(scene)
    assert cache.counts["built"] == before["built"] and cache.counts["memo"] > before["memo"]   # nothing rebuilt
    for a, b in zip(first._each + [first.clearance_field], second._each + [second.clearance_field]):
        np.testing.assert_array_equal(a, b)
    cache.forget()


def test_edge_points_are_equidistant_and_inside_is_the_hollow(cube):
    _, tasks, _ = cube
    points = tasks.edge_points("L1", "M1")
    assert len(points) > 0
    # L1 is the +x face, M1 the +y face: their edge runs along z at x = y = 0.202 + ~0.075
    assert np.allclose(points[:, 0] - CENTRE[0], points[:, 1] - CENTRE[1], atol=0.005)
    assert np.all(np.abs(points[:, 2] - CENTRE[2]) < 0.062)
    assert tasks.inside(CENTRE) and not tasks.inside(CENTRE + [0.15, 0.0, 0.0])
    with pytest.raises(PlanningError, match="not adjacent"):
        tasks.generate_task("L1", "L2", np.random.default_rng(0), TIP, rotation_onto)
    with pytest.raises(ConfigError, match="no object"):
        tasks.edge_points("L1", "Q9")


@pytest.mark.parametrize("pair", [("L1", "M1"), ("M2", "H2"), ("H1", "L2")])
def test_a_generated_task_is_inside_clear_and_its_funnel_holds_start_and_target(cube, pair):
    _, tasks, features = cube
    task = tasks.generate_task(*pair, np.random.default_rng(4), TIP, rotation_onto)
    o = tasks.options
    assert tasks.inside(task.target) and tasks.clearance(task.target) >= o.clearance
    assert o.depth_range[0] - 1e-9 <= np.linalg.norm(task.target - task.edge) <= o.depth_range[1] + 1e-9
    assert task.allows(task.target[None])[0]
    start_points = features.robot.body_points(task.start[None])[0]
    assert task.allows(start_points).all()
    assert features.of_path(np.array([task.start, task.start])).sum() == 0          # the probe starts free
    rot, pos, _ = features.robot.rigid_placement(task.start[None])
    assert np.linalg.norm(rot[0] @ TIP + pos[0] - task.edge) == pytest.approx(o.start_distance)


def test_features_count_robot_points_per_object_and_the_learner_never_sees_sensitivities(cube):
    scene, _, features = cube
    assert all(o.material.sensitivity == 1.0 for o in unit_sensitivity_scene(scene).objects)
    assert true_sensitivities(scene) == {"L1": 0.2, "L2": 0.2, "M1": 0.4, "M2": 0.4, "H1": 0.8, "H2": 0.8}
    # the probe lying inside the +x face (L1) along y: every body point in L1 whose lattice cell lies in it
    inside = np.r_[0.276, 0.202, 0.202, rotation_onto([0.0, 1.0, 0.0])]
    v = features.of_path(np.array([inside, inside]))
    assert v[features.names.index("L1")] > 0 and v.sum() == v[features.names.index("L1")]
    # two identical waypoints are measured as two configurations: twice one state
    one = features.cost.breakdown(inside[None])[0]
    assert np.allclose(v, 2 * one)


@pytest.fixture(scope="module")
def demonstration(cube):
    scene, tasks, features = cube
    expert = SimulatedExpert(features, true_sensitivities(scene), TIP, ExpertOptions(grid=11, refine=1, noise=0.0))
    task = tasks.generate_task("L1", "M1", np.random.default_rng(1), TIP, rotation_onto)
    return expert, task, expert.demonstrate(task, np.random.default_rng(0))


def test_the_expert_shows_its_optimum_which_prefers_the_less_sensitive_face(cube, demonstration):
    scene, _, features = cube
    expert, task, shown = demonstration
    weights = features.sensitivity_vector(true_sensitivities(scene))
    cost = features.of_path(shown.path) @ weights
    frame = funnel_frame(task)
    for tilt in ([0.0, 0.0], [0.3, 0.0], [-0.3, 0.0], [0.1, 0.05]):
        other = expert.path(task, tilt, frame)
        if expert.valid(task, [other])[0]:
            assert cost <= features.of_path(other) @ weights + 1e-9
    v = dict(zip(features.names, features.of_path(shown.path)))
    assert v["L1"] > v["M1"]
    rot, pos, _ = features.robot.rigid_placement(shown.path[-1:])
    assert np.allclose(rot[0] @ TIP + pos[0], task.target)                          # the tip touches the target
    assert np.array_equal(shown.path[0], task.start) and expert.valid(task, [shown.path])[0]


def test_smooth_noise_is_clamped_at_the_start_and_largest_at_the_end():
    cov = smooth_covariance(10)
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) >= -1e-12)
    assert cov[0, 0] == 0 and cov.diagonal().max() == pytest.approx(1.0)
    assert np.all(np.diff(cov.diagonal()) >= 0)
    both = smooth_covariance(9, clamp_end=True)                # a goal configuration: clamped at both ends
    assert np.allclose(both, both.T) and np.all(np.linalg.eigvalsh(both) >= -1e-12)
    assert both[0, 0] == both[-1, -1] == 0 and both.diagonal().max() == pytest.approx(1.0)
    assert np.allclose(both.diagonal(), both.diagonal()[::-1])  # symmetric about the middle


def test_samples_do_the_same_task_and_the_local_optimiser_only_improves(cube, demonstration):
    _, _, features = cube
    _, task, shown = demonstration
    sampler = PathSampler(features, TIP, SampleOptions(samples=20, rounds=2))
    samples = sampler.draw(shown, np.random.default_rng(2))
    assert len(samples) == 20
    for s in samples:
        assert np.array_equal(s[0], shown.path[0]) and len(s) == sampler.options.waypoints
        rot, pos, _ = features.robot.rigid_placement(s[-1:])
        assert np.allclose(rot[0] @ TIP + pos[0], task.target, atol=1e-9)
        assert task.allows(features.robot.body_points(features.states(s))).all()
    assert not all(np.allclose(samples[0], s) for s in samples[1:])
    better, replaced = sampler.improve(shown, np.random.default_rng(3))
    assert np.all(features.of_path(better.path) <= features.of_path(shown.path) + 1e-9)
    assert (replaced == 0) == (better is shown)


@pytest.mark.parametrize("scene_name", ["hollow-cube", "planar-objects"])
def test_the_outline_meets_every_half_space_exactly_when_all_body_points_do(scene_name):
    features = DeformationFeatures(pliant.load_scene(scene_name))
    q = features.space.sample(np.random.default_rng(0), 40)
    outline, points = features.outline(q), features.robot.body_points(q)
    assert outline.shape[1] <= points.shape[1]
    for n in np.random.default_rng(1).normal(size=(30, 3)):
        n /= np.linalg.norm(n)
        assert np.allclose((outline @ n).max(axis=1), (points @ n).max(axis=1))    # the same support function


def _costliest_sample(cube, demonstration, samples: int):
    """The demonstration's task and the costliest (true sensitivities) of ``samples`` wide samples around it:
    ``features, task, shown, weights, poor``."""
    scene, _, features = cube
    _, task, shown = demonstration
    weights = features.sensitivity_vector(true_sensitivities(scene))
    wide = PathSampler(features, TIP, SampleOptions(samples=samples, translation=0.012, rotation=0.2))
    drawn = wide.draw(shown, np.random.default_rng(5))
    return features, task, shown, weights, drawn[int(np.argmax(features.of_paths(drawn) @ weights))]


def _assert_keeps_the_task(path, task, features) -> None:
    """The path's tip ends on the task's target and no configuration breaks the task's collision planes."""
    rot, pos, _ = features.robot.rigid_placement(path[-1:])
    assert np.allclose(rot[0] @ TIP + pos[0], task.target, atol=1e-9)
    assert task.allows(features.robot.body_points(features.states(path))).all()


def test_refining_a_poor_path_lowers_its_cost_keeps_the_task_and_respects_the_check(cube, demonstration):
    from pliant_piirl.verification import refine

    features, task, shown, weights, poor = _costliest_sample(cube, demonstration, 40)
    poor_cost = float(features.of_path(poor) @ weights)
    assert poor_cost > float(features.of_path(shown.path) @ weights)
    better = refine(poor, task, features, weights, TIP, np.random.default_rng(6), rounds=4, samples=40)
    assert float(features.of_path(better) @ weights) < poor_cost
    assert np.array_equal(better[0], poor[0])
    _assert_keeps_the_task(better, task, features)
    refused = refine(poor, task, features, weights, TIP, np.random.default_rng(6), rounds=2, samples=20,
                     check=lambda path: False)
    assert refused is poor or np.array_equal(refused, poor)


def test_pivots_turn_the_tail_rigidly_about_the_target_and_keep_start_and_tip(cube, demonstration):
    from pliant_piirl.verification import pivot_paths
    from scipy.spatial.transform import Rotation

    _, _, features = cube
    _, task, shown = demonstration
    base = PathSampler(features, TIP, SampleOptions(waypoints=8)).resample(shown.path)
    turned = pivot_paths(base, task.target, np.random.default_rng(0), 30, 0.1)
    assert turned.shape == (30, 8, 7)
    assert np.all(turned[:, 0] == base[0])
    rot, pos, _ = features.robot.rigid_placement(turned[:, -1])
    assert np.allclose(np.einsum("nij,j->ni", rot, TIP) + pos, task.target, atol=1e-9)      # the tip stays on it
    for path in turned:          # every waypoint turned about the target by a growing share of one rotation
        turns = [Rotation.from_quat(q) * Rotation.from_quat(b).inv() for q, b in zip(path[:, 3:], base[:, 3:])]
        last = turns[-1].as_rotvec()
        shares = [t.as_rotvec() @ last / (last @ last) for t in turns]
        assert np.allclose([t.as_rotvec() for t in turns], np.outer(shares, last), atol=1e-9)
        assert shares[0] == 0 and np.all(np.diff(shares) >= -1e-9) and shares[-1] == pytest.approx(1.0)
        for q, b, t in zip(path, base, turns):
            assert np.allclose(q[:3] - task.target, t.apply(b[:3] - task.target), atol=1e-12)
    assert not np.allclose(turned[0], turned[1])
    assert np.array_equal(turned, pivot_paths(base, task.target, np.random.default_rng(0), 30, 0.1))     # seeded


def test_candidates_made_elsewhere_are_kept_as_the_sampler_keeps_its_own(cube, demonstration):
    _, _, features = cube
    _, task, shown = demonstration
    sampler = PathSampler(features, TIP, SampleOptions(samples=10))
    drawn, feats = sampler.draw_with_features(shown, np.random.default_rng(3))
    outside = drawn[0].copy()
    outside[1:, :3] += 0.5                                                       # far outside the funnel
    kept, kept_feats = sampler.valid_with_features(drawn + [outside], task)
    assert len(kept) == len(drawn) and np.allclose(kept_feats, feats)
    assert sampler.valid_with_features([outside], task)[0] == []


def test_refining_with_pivots_and_step_adaptation_is_seeded_and_keeps_the_task(cube, demonstration):
    from pliant_piirl.verification import refine

    features, task, _, weights, poor = _costliest_sample(cube, demonstration, 20)
    options = {"rounds": 4, "samples": 20, "pivots": 20, "translation": 0.02, "rotation": 0.3, "shrink": 0.8,
               "grow": 1.2}
    better = refine(poor, task, features, weights, TIP, np.random.default_rng(6), **options)
    assert float(features.of_path(better) @ weights) < float(features.of_path(poor) @ weights)
    assert np.array_equal(better, refine(poor, task, features, weights, TIP, np.random.default_rng(6), **options))
    _assert_keeps_the_task(better, task, features)
