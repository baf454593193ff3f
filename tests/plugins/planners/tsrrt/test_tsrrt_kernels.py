"""The compiled kernels of TS-RRT (IN_COLLISION, the validity of single-object steps, the task cost) answer exactly
what the batched numpy code answers, on random batches crowded enough that many arrangements are near a collision."""

from __future__ import annotations

import numpy as np
import pytest
from pliant_tsrrt.cost import TaskCost
from pliant_tsrrt.geometry import BOX, CIRCLE, CollisionChecker, Footprints
from pliant_tsrrt.pushing import PushSettings
from pliant_tsrrt.search import ObjectSpace

TABLE = (0.0, 0.0, 1.0, 0.8)
BOUNDS = (-0.2, -0.2, 1.2, 1.0)
MODEL = [[0.045, 0, 0], [-0.045, 0, 0], [0, 0.045, 0], [0, -0.045, 0], [0.001, 0.002, 0.2], [0.001, -0.002, -0.2]]
OBJECTS = Footprints([BOX, BOX, CIRCLE, BOX], [[0.12, 0.08], [0.05, 0.05], [0.05, 0.05], [0.09, 0.015]])
OBSTACLES = (Footprints([BOX, CIRCLE], [[0.1, 0.02], [0.04, 0.04]]), np.array([[0.5, 0.4, 0.3], [0.2, 0.6, 0.0]]))


def _space(k, obstacles, margin):
    fp = OBJECTS.subset(np.arange(k))
    checker = CollisionChecker(fp, obstacles[0], obstacles[1], TABLE, margin)
    relations = np.array([[1, 0, 0.2, 0.0], [0, -1, 0.3, 0.25]]) if k > 1 else np.zeros((0, 4))
    cost = TaskCost(fp, TABLE, (1.0, 0.7, 1.3, 0.5), relations[: max(0, k - 1)], 0.1)
    return ObjectSpace(fp, np.array([MODEL] * k, dtype=float), checker, cost, PushSettings(), BOUNDS)


def _crowded(space, rng, n):
    states = np.stack([space.random_config(rng) for _ in range(n)])
    states[: n // 2, :, :2] = np.array([0.5, 0.4]) + rng.normal(0.0, 0.15, (n // 2, space.k, 2))
    return states


@pytest.mark.parametrize("k", [1, 2, 3, 4])
@pytest.mark.parametrize("with_obstacles", [False, True])
@pytest.mark.parametrize("margin", [0.0, 0.01, -0.001])
def test_kernels_agree_with_numpy(k, with_obstacles, margin):
    none = (Footprints(np.zeros(0, dtype=int), np.zeros((0, 2))), np.zeros((0, 3)))
    space = _space(k, OBSTACLES if with_obstacles else none, margin)
    rng = np.random.default_rng(k * 10 + with_obstacles)
    states = _crowded(space, rng, 4000)
    hit = space.checker.in_collision(states)
    assert np.array_equal(hit, space.checker.in_collision_numpy(states))
    assert 0 < hit.sum() < len(hit)
    assert np.allclose(space.cost.cost(states), space.cost.cost_numpy(states), rtol=0, atol=1e-12)
    actions = rng.integers(0, 6 * k, len(states))
    after = np.stack([space.step(s, a) for s, a in zip(states, actions)])
    ok = space.valid_steps(states, after, actions)
    assert np.array_equal(ok, space.valid_steps_numpy(states, after, actions))
    assert 0 < ok.sum() < len(ok)


def test_rollout_kernel_composes_the_models_in_turn():
    space = _space(3, (Footprints(np.zeros(0, dtype=int), np.zeros((0, 2))), np.zeros((0, 3))), 0.0)
    rng = np.random.default_rng(3)
    s0 = space.random_config(rng)
    actions = [int(a) for a in rng.integers(0, 18, 40)]
    states, _ = space.rollout(s0, actions)
    expected = [s0]
    for a in actions:
        expected.append(space.step(expected[-1], a))
    assert np.allclose(states, np.array(expected), rtol=0, atol=1e-12)
    assert np.all((states[..., 2] >= -np.pi) & (states[..., 2] < np.pi))


def test_beam_expand_moves_every_pose_by_every_primitive():
    from pliant_tsrrt.kernels import beam_expand
    from pliant_tsrrt.models import compose

    rng = np.random.default_rng(4)
    poses = np.column_stack([rng.uniform(0, 1, 50), rng.uniform(0, 0.8, 50), rng.uniform(-np.pi, np.pi, 50)])
    means = np.array(MODEL, dtype=float)
    target = np.array([0.5, 0.4, 0.3])
    to, err, key, bins = beam_expand(poses, means, target, 0.144, np.pi, np.radians(0.25))
    expected = compose(np.repeat(poses, 6, axis=0), np.tile(means, (50, 1)))
    assert np.allclose(to, expected, rtol=0, atol=1e-12)
    d = (to[:, 2] - target[2] + np.pi / 2) % np.pi - np.pi / 2
    assert np.allclose(err, np.sqrt(np.sum((to[:, :2] - target[:2]) ** 2, axis=1) + (0.144 * d) ** 2), atol=1e-12)
    assert len(np.unique(key)) == len(key)                  # 300 distinct poses, 300 keys
    assert np.all((bins >= 0) & (bins <= round(np.pi / np.radians(0.25))))


def test_a_space_with_fractions_of_a_stroke_moves_and_checks_them_as_the_numpy_code_does():
    # the six primitives followed by the same at half their stroke: actions 12 o + p; a half stroke moves half as far,
    # and is checked with its primitive's whole sweep (which contains it), in the kernel as in numpy
    k = 3
    space = _space(k, OBSTACLES, 0.0)
    halves = ObjectSpace(space.fp, np.array([MODEL + [[0.5 * v for v in m] for m in MODEL]] * k, dtype=float),
                         space.checker, space.cost, PushSettings(), BOUNDS, strokes=(1.0, 0.5))
    assert halves.n_prims == 12 and halves.decode(12 * 2 + 6 + 3) == (2, 3, 0.5)
    rng = np.random.default_rng(12)
    s = space.random_config(rng)
    outcomes = halves.outcomes(s)
    assert outcomes.shape == (12 * k, k, 3)
    for o in range(k):
        for p in range(6):
            assert np.allclose(outcomes[12 * o + p], space.step(s, 6 * o + p), rtol=0, atol=1e-15)
            half = outcomes[12 * o + 6 + p]
            assert np.allclose(half[o, :2] - s[o, :2], 0.5 * (outcomes[12 * o + p][o, :2] - s[o, :2]), atol=1e-12)
    states = _crowded(halves, rng, 3000)
    actions = rng.integers(0, 12 * k, len(states))
    after = np.stack([halves.step(x, a) for x, a in zip(states, actions)])
    ok = halves.valid_steps(states, after, actions)
    assert np.array_equal(ok, halves.valid_steps_numpy(states, after, actions))
    assert 0 < ok.sum() < len(ok)
    # the beam step moves a pose by all twelve
    from pliant_tsrrt.kernels import beam_expand

    to, *_ = beam_expand(s[:1].copy(), halves.means[0].copy(), s[0].copy(), 0.1, np.pi, 0.01)
    assert len(to) == 12


def test_means_that_are_not_six_primitives_per_stroke_are_refused():
    space = _space(2, OBSTACLES, 0.0)
    with pytest.raises(ValueError, match="means must be"):
        ObjectSpace(space.fp, np.zeros((2, 7, 3)), space.checker, space.cost, PushSettings(), BOUNDS)
    with pytest.raises(ValueError, match="6 x 1 strokes"):       # twelve primitives need two strokes declared
        ObjectSpace(space.fp, np.zeros((2, 12, 3)), space.checker, space.cost, PushSettings(), BOUNDS)
