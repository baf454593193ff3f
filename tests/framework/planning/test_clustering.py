"""Particle clustering of thesis 5.3.3 (PC, WCR, AC, distance pass) and the match of Algorithm 4, on se2-maze."""

from __future__ import annotations

import dataclasses
import functools
from types import SimpleNamespace

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.errors import ConfigError, DimensionError, PliantError
from pliant.interfaces import Context
from pliant.planning.clustering import (
    CLUSTERING_METHODS,
    ClusteringContext,
    _cut,
    ac_distances,
    actuation_centres,
    cluster_particles,
    complete_link,
    default_distance_threshold,
    matches,
    wcr_distances,
)
from scipy.cluster.hierarchy import fcluster, linkage

# se2-maze: passages x in [3.5, 6.5] (middle) and [7.0, 9.5] (right), a 0.5 m wall between them; the
# L-block's arms reach 1.5 m (+ 0.25 half thickness) along +x and +y from its frame origin.
MIDDLE = (4.2, 5.0, 0.0)
RIGHT = (7.5, 5.0, 0.0)


@functools.cache
def maze() -> ClusteringContext:
    ctx = Context(scene=load_scene("se2-maze"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.simulator = registry.create("simulator", "kinematic", ctx)
    return ClusteringContext.from_context(ctx, duration=5.0)


def cloud(centre, n, seed, spread=0.2, turn=0.05):
    rng = np.random.default_rng(seed)
    q = np.tile(np.asarray(centre, dtype=np.float64), (n, 1))
    q[:, :2] += rng.uniform(-spread, spread, (n, 2))
    q[:, 2] += rng.uniform(-turn, turn, n)
    return q


def partition(labels):
    return {frozenset(np.flatnonzero(labels == k).tolist()) for k in np.unique(labels)}


def test_context_from_pipeline_context():
    cc = maze()
    assert len(cc.regions) == 5 and cc.goal_tolerance == pytest.approx(0.4375)
    assert cc.grid.occupied.any() and cc.simulator is not None
    assert default_distance_threshold(cc) == pytest.approx(8 * 0.125)
    assert default_distance_threshold(dataclasses.replace(cc, grid=None)) == pytest.approx(8 * 0.4375)
    assert set(CLUSTERING_METHODS) == {"pc", "wcr", "ac", "distance"}


@pytest.mark.parametrize("method", ["wcr", "ac", "distance"])
def test_straddling_a_wall_splits_and_free_space_does_not(method):
    cc = maze()
    middle, right = cloud(MIDDLE, 12, 1), cloud(RIGHT, 12, 2)
    labels = cluster_particles(np.concatenate([middle, right]), method, cc)
    assert partition(labels) == {frozenset(range(12)), frozenset(range(12, 24))}
    assert np.array_equal(cluster_particles(cloud(MIDDLE, 24, 3), method, cc), np.zeros(24))


def test_particle_connectivity_splits_across_the_wall():
    cc = maze()
    middle, right = cloud(MIDDLE, 5, 1), cloud(RIGHT, 5, 2)
    labels = cluster_particles(np.concatenate([middle, right]), "pc", cc, rng=np.random.default_rng(0))
    assert partition(labels) == {frozenset(range(5)), frozenset(range(5, 10))}
    assert np.array_equal(cluster_particles(cloud(MIDDLE, 6, 3), "pc", cc), np.zeros(6))


@pytest.mark.parametrize("method", ["wcr", "ac", "pc"])
def test_second_pass_splits_far_groups_in_one_region(method):
    cc = maze()
    n = 4 if method == "pc" else 10
    low, high = cloud((4.2, 3.5, 0.0), n, 4, spread=0.1), cloud((4.2, 6.0, 0.0), n, 5, spread=0.1)
    both = np.concatenate([low, high])
    # the spatial feature alone sees one group: both are inside the middle passage, joined by free space
    if method == "wcr":
        assert wcr_distances(both, cc).max() == 0.0
    if method == "ac":
        assert ac_distances(both, cc).max() == 0.0
    labels = cluster_particles(both, method, cc)
    assert partition(labels) == {frozenset(range(n)), frozenset(range(n, 2 * n))}
    # with a threshold wider than the gap the groups stay together
    assert np.array_equal(cluster_particles(both, method, cc, distance_threshold=5.0), np.zeros(2 * n))


def test_wcr_distance_is_the_fraction_of_points_without_a_shared_region():
    cc = maze()
    q = np.array([MIDDLE, RIGHT, (4.2, 7.5, 0.0), (7.5, 7.5, 0.0), (7.5, 6.0, 0.0)])
    d = wcr_distances(q, cc)
    assert d[0, 1] == 1.0                  # different passages: nothing shared
    assert d[2, 3] == 0.0                  # different passages, but both wholly in the top corridor
    assert d[0, 2] == 0.0                  # both wholly in the middle passage
    assert 0.0 < d[4, 2] < 1.0             # only the tip of the vertical arm at (7.5, 6.0) is in the corridor
    assert np.allclose(d, d.T) and np.all(np.diag(d) == 0.0)
    # a configuration half inside the wall: its points outside every region share nothing, even with a copy
    wall = np.array([(5.6, 5.0, 0.0), (5.6, 5.0, 0.0)])
    points = cc.robot.body_points(wall[:1])[0]
    outside = np.mean(~np.any([r.contains(points) for r in cc.regions], axis=0))
    assert outside > 0.0
    assert wcr_distances(wall, cc)[0, 1] == pytest.approx(outside)


def test_ac_checks_the_straight_segment_between_centres():
    cc = maze()
    q = np.array([MIDDLE, RIGHT, (4.2, 8.0, 0.0), (7.5, 8.0, 0.0)])
    d = ac_distances(q, cc)
    assert d[0, 1] == 1.0                  # through the wall
    assert d[2, 3] == 0.0                  # along the top corridor
    assert d[0, 2] == 0.0
    assert np.array_equal(actuation_centres(q, cc)[:, 0], np.column_stack([q[:, :2], np.zeros(4)]))


def test_labels_are_first_appearance_and_deterministic():
    cc = maze()
    rng = np.random.default_rng(7)
    q = np.concatenate([cloud(MIDDLE, 8, 1), cloud(RIGHT, 8, 2), cloud((4.2, 3.0, 0.0), 8, 3)])
    q = q[rng.permutation(len(q))]
    for method in ("wcr", "ac", "distance"):
        labels = cluster_particles(q, method, cc)
        assert labels.dtype.kind == "i" and labels.shape == (24,)
        k = labels.max() + 1
        assert k == 3 and set(labels.tolist()) == set(range(k))
        assert np.array_equal(np.unique(labels, return_index=True)[1], np.sort(np.unique(labels, return_index=True)[1]))
        assert labels[0] == 0
        assert np.array_equal(labels, cluster_particles(q, method, cc))
    assert np.array_equal(cluster_particles(q[:1], "wcr", cc), [0])


def _brute_complete_link(d, threshold):
    """The textbook O(n^3) agglomeration: merge the two clusters of smallest maximum distance while within."""
    clusters = [[i] for i in range(len(d))]
    while len(clusters) > 1:
        best = None
        for a in range(len(clusters)):
            for b in range(a + 1, len(clusters)):
                link = max(d[i, j] for i in clusters[a] for j in clusters[b])
                if best is None or link < best[0]:
                    best = (link, a, b)
        if best[0] > threshold:
            break
        _, a, b = best
        clusters[a] = clusters[a] + clusters.pop(b)
    return {frozenset(c) for c in clusters}


def test_complete_link_does_not_chain():
    cc = maze()
    # consecutive gaps 0.5, 0.6, 0.55 are all within 1.0 (single link would make one cluster), but no
    # cluster of complete link may have a diameter above 1.0
    y = np.array([1.5, 2.0, 2.6, 3.15])
    q = np.column_stack([np.full(4, 4.2), y, np.zeros(4)])
    labels = cluster_particles(q, "distance", cc, distance_threshold=1.0)
    assert partition(labels) == {frozenset({0, 1}), frozenset({2, 3})}


def test_complete_link_matches_brute_force_and_fcluster():
    cc = maze()
    rng = np.random.default_rng(11)
    for trial in range(25):
        n = int(rng.integers(2, 9))
        q = np.column_stack([rng.uniform(3.5, 6.5, n), rng.uniform(0.5, 9.5, n), np.zeros(n)])
        threshold = float(rng.uniform(0.5, 4.0))
        labels = cluster_particles(q, "distance", cc, distance_threshold=threshold)
        d = np.linalg.norm(q[:, None, :2] - q[None, :, :2], axis=-1)
        assert partition(labels) == _brute_complete_link(d, threshold), trial
        if n > 2:
            tree = linkage(d[np.triu_indices(n, 1)], method="complete")
            assert partition(_cut(tree, n, threshold)) == partition(fcluster(tree, threshold, criterion="distance"))
    # groups are never merged, whatever their distances
    d = np.zeros((4, 4))
    assert partition(complete_link(d, 0.5, groups=np.array([0, 1, 0, 1]))) == {frozenset({0, 2}), frozenset({1, 3})}


@pytest.mark.parametrize("method", ["wcr", "ac", "distance", "pc"])
def test_matches_inside_the_cloud_and_not_across_the_wall(method):
    cc = maze()
    belief = cloud(MIDDLE, 6 if method == "pc" else 24, 1)
    assert matches(belief, np.array([4.25, 5.05, 0.01]), method, cc, rng=np.random.default_rng(0))
    assert not matches(belief, np.array(RIGHT), method, cc, rng=np.random.default_rng(0))
    assert not matches(belief, np.array([4.2, 8.5, 0.0]), method, cc, rng=np.random.default_rng(0))


def test_an_observation_the_simulator_cannot_start_from_matches_no_belief():
    # an executed robot (pybullet has no walls at the scene's bounds, and lets contacts sink) can be observed where
    # the planning simulator refuses a start: PC's connectivity test cannot run from there, so it matches nothing
    cc = maze()
    belief = cloud((4.6, 5.0, 0.0), 6, 1, spread=0.1, turn=0.02)
    inside_wall = np.array([5.1, 5.0, 0.0])                 # the arm's tip 0.1 m into the wall at x = 6.5
    assert cc.simulator.start_penetration(inside_wall[None])[0] > cc.simulator.start_tolerance
    assert np.max(cc.space.distance(belief, inside_wall[None])) < default_distance_threshold(cc)  # distance passes
    assert not matches(belief, inside_wall, "pc", cc, rng=np.random.default_rng(0))
    assert matches(belief, np.array([4.7, 5.0, 0.0]), "pc", cc, rng=np.random.default_rng(0))


def test_matches_is_the_single_cluster_test_of_algorithm_4():
    cc = maze()
    belief = cloud(MIDDLE, 12, 1)
    for q in np.concatenate([cloud(MIDDLE, 10, 9, spread=1.0, turn=0.5), cloud(RIGHT, 3, 8)]):
        for method in ("wcr", "ac", "distance"):
            single = cluster_particles(np.concatenate([belief, q[None]]), method, cc).max() == 0
            assert matches(belief, q, method, cc) == single, (method, q)


def test_articulated_centres_use_joint_frames_or_the_body_centroid():
    cc = maze()
    frames = {"a": np.array([1.0, 2.0, 0.0]), "b": np.array([3.0, 4.0, 0.0])}

    class Arm:
        def rigid_placement(self, q):
            return None

        def urdf_description(self):
            return SimpleNamespace(joint_names=("a", "b"))

        def frame_position(self, q, name):
            return frames[name] + q[:, :1]

        def body_points(self, q):
            return np.zeros((len(q), 2, 3)) + q[:, None, :1]

    arm = dataclasses.replace(cc, robot=Arm())
    q = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    centres = actuation_centres(q, arm)
    assert centres.shape == (2, 2, 3)
    assert np.allclose(centres[1, 1], [4.0, 5.0, 1.0])

    class Blob(Arm):
        def urdf_description(self):
            return None

    assert np.allclose(actuation_centres(q, dataclasses.replace(cc, robot=Blob()))[:, 0, 0], [0.0, 1.0])


def test_bad_input_names_the_field_and_value():
    cc = maze()
    q = cloud(MIDDLE, 4, 1)
    cases = [
        (lambda: cluster_particles(q, "kmeans", cc), ConfigError, "method", "kmeans"),
        (lambda: cluster_particles(q[:, :2], "wcr", cc), DimensionError, "particles", "[4, 2]"),
        (lambda: cluster_particles(np.zeros((0, 3)), "wcr", cc), DimensionError, "particles", "[0, 3]"),
        (lambda: cluster_particles(np.where(np.eye(4, 3) > 0, np.nan, q), "ac", cc), DimensionError, "particles",
         "nan"),
        (lambda: cluster_particles(q, "wcr", dataclasses.replace(cc, regions=[])), ConfigError, "regions", "[]"),
        (lambda: cluster_particles(q, "ac", dataclasses.replace(cc, grid=None)), ConfigError, "grid", "None"),
        (lambda: cluster_particles(q, "pc", dataclasses.replace(cc, simulator=None)), ConfigError, "simulator",
         "None"),
        (lambda: cluster_particles(q, "wcr", cc, wcr_threshold=1.5), ConfigError, "wcr_threshold", "1.5"),
        (lambda: cluster_particles(q, "distance", cc, distance_threshold=-1.0), ConfigError, "distance_threshold",
         "-1.0"),
        (lambda: matches(q, q[:2], "wcr", cc), DimensionError, "q", "[2, 3]"),
        (lambda: matches(q, [1.0, 2.0], "wcr", cc), DimensionError, "q", "[1, 2]"),
        (lambda: dataclasses.replace(cc, goal_tolerance=0.0), ConfigError, "goal_tolerance", "0.0"),
        (lambda: dataclasses.replace(cc, duration=float("nan")), ConfigError, "duration", "nan"),
    ]
    for call, kind, field, value in cases:
        with pytest.raises(kind) as info:
            call()
        assert isinstance(info.value, PliantError)
        assert info.value.field == field and value in str(info.value), str(info.value)


def test_ac_connected_pairs_configurations_one_to_one():
    from pliant.planning.clustering import ac_connected

    cc = maze()
    # the middle and right passages are 0.5 m of wall apart; within one passage the segment is free
    a = np.array([MIDDLE, MIDDLE, RIGHT])
    b = np.array([RIGHT, (4.5, 5.0, 0.0), RIGHT])
    assert ac_connected(a, b, cc).tolist() == [False, True, True]
    assert ac_connected(a[:0], b[:0], cc).shape == (0,)
