"""Configuration spaces: metric axioms, interpolation, steering, validity and errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pliant.errors import DimensionError
from pliant.geometry.rotations import quat_angle, quat_from_axis_angle
from pliant.spaces import CompoundSpace, RealVectorSpace, SE2Space, SE3Space, space_from_dict
from pliant.testing import check_space

SPACES = {
    "rn": RealVectorSpace([-1.0, 0.0, 2.0], [1.0, 3.0, 5.0], weights=[1.0, 2.0, 0.5]),
    "se2": SE2Space([0.0, 0.0], [10.0, 10.0], rotation_weight=0.5),
    "se3": SE3Space([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], translation_weight=10.0),
    "compound": CompoundSpace([RealVectorSpace([0.0], [1.0]), SE2Space([0, 0], [1, 1])], weights=[2.0, 1.0]),
}


@pytest.mark.parametrize("name", SPACES)
def test_conformance(name):
    assert check_space(SPACES[name])


@pytest.mark.parametrize("name", SPACES)
@given(seed=st.integers(0, 2**32 - 1))
def test_metric_axioms(name, seed):
    space = SPACES[name]
    a, b, c = space.sample(np.random.default_rng(seed), 3)
    assert space.distance(a, a) == pytest.approx(0.0, abs=1e-7)
    assert space.distance(a, b) == pytest.approx(space.distance(b, a))
    assert space.distance(a, c) <= space.distance(a, b) + space.distance(b, c) + 1e-9


@pytest.mark.parametrize("name", SPACES)
@given(seed=st.integers(0, 2**32 - 1), t=st.floats(0.0, 1.0))
def test_interpolation_splits_the_distance(name, seed, t):
    space = SPACES[name]
    a, b = space.sample(np.random.default_rng(seed), 2)
    m = space.interpolate(a, b, t)
    d = space.distance(a, b)
    assert space.distance(a, m) == pytest.approx(t * d, abs=1e-6)
    assert space.distance(m, b) == pytest.approx((1 - t) * d, abs=1e-6)
    assert space.is_valid(m)


@pytest.mark.parametrize("name", SPACES)
def test_steer_and_discretize(name):
    space = SPACES[name]
    a, b = space.sample(np.random.default_rng(5), 2)
    step = 0.1 * float(space.distance(a, b))
    s = space.steer(a, b, step)
    assert space.distance(a, s) == pytest.approx(step, rel=1e-6)
    assert np.allclose(space.distance(space.steer(a, b, 1e9), b), 0, atol=1e-7)
    path = space.discretize(a, b, step)
    gaps = space.distance(path[:-1], path[1:])
    assert np.all(gaps <= step + 1e-9) and len(path) >= 11
    assert space.path_length(path) == pytest.approx(float(space.distance(a, b)), rel=1e-6)


def test_rn_weighted_distance_by_hand():
    space = SPACES["rn"]
    assert space.distance([0, 0, 2], [1, 1, 4]) == pytest.approx(np.sqrt(1 + 4 + 1))


def test_se2_wraps_angles():
    space = SE2Space([0, 0], [1, 1])
    a = np.array([0.5, 0.5, np.pi - 0.1])
    b = np.array([0.5, 0.5, -np.pi + 0.1])
    assert space.distance(a, b) == pytest.approx(0.2)
    mid = space.interpolate(a, b, 0.5)
    assert abs(abs(mid[2]) - np.pi) < 1e-9


def test_se3_samples_are_unit_quaternions_in_bounds():
    q = SPACES["se3"].sample(np.random.default_rng(0), 500)
    assert np.allclose(np.linalg.norm(q[:, 3:], axis=1), 1.0)
    assert np.all(SPACES["se3"].is_valid(q))


def test_se3_retract_applies_a_world_rotation():
    space = SE3Space([0, 0, 0], [1, 1, 1])
    q = np.array([0.5, 0.5, 0.5, 0, 0, 0, 1.0])
    moved = space.retract(q, [0.1, 0, 0, 0, 0, np.pi / 2])
    assert np.allclose(moved[:3], [0.6, 0.5, 0.5])
    assert quat_angle(moved[3:], quat_from_axis_angle(np.array([0, 0, 1.0]), np.pi / 2)) == pytest.approx(0, abs=1e-9)


def test_batches_equal_single_calls():
    space = SPACES["se3"]
    a = space.sample(np.random.default_rng(1), 6)
    b = space.sample(np.random.default_rng(2), 6)
    assert np.allclose(space.distance(a, b), [space.distance(x, y) for x, y in zip(a, b)])
    assert np.allclose(space.interpolate(a, b, 0.3), [space.interpolate(x, y, 0.3) for x, y in zip(a, b)])


@pytest.mark.parametrize(("value", "message"), [
    ([0.5, 0.5], "7 coordinates"),
    ([0.5, 0.5, 0.5, 0, 0, 0, np.nan], "finite"),
    ([0.5, 0.5, 0.5, 0, 0, 0, 2.0], "unit norm"),
    ([1.5, 0.5, 0.5, 0, 0, 0, 1.0], "bounds"),
    ("abc", "numbers"),
])
def test_check_rejects_bad_configurations(value, message):
    with pytest.raises(DimensionError, match=message) as info:
        SPACES["se3"].check(value, field="start", source="s.toml")
    assert str(info.value).startswith("s.toml:start:")


def test_bad_space_construction():
    with pytest.raises(DimensionError, match="lower"):
        RealVectorSpace([1.0], [0.0])
    with pytest.raises(DimensionError, match="weights"):
        RealVectorSpace([0.0], [1.0], weights=[-1.0])
    with pytest.raises(DimensionError, match="kind"):
        space_from_dict({"kind": "so7"})


@pytest.mark.parametrize("name", SPACES)
def test_round_trip_through_dict(name):
    space = SPACES[name]
    again = space_from_dict(space.to_dict())
    a, b = space.sample(np.random.default_rng(0), 2)
    assert again.distance(a, b) == pytest.approx(space.distance(a, b))


def test_mean_and_variance_on_known_sets():
    rn = RealVectorSpace([0, 0], [10, 10])
    pts = np.array([[1.0, 2.0], [3.0, 6.0]])
    assert np.allclose(rn.mean(pts), [2.0, 4.0]) and np.allclose(rn.variance(pts), [1.0, 4.0])
    se2 = SE2Space([0, 0], [10, 10])
    wrapped = np.array([[1.0, 1.0, np.pi - 0.1], [1.0, 3.0, -np.pi + 0.1]])   # angles either side of +-pi
    m = se2.mean(wrapped)
    assert np.allclose(m[:2], [1.0, 2.0]) and abs(abs(m[2]) - np.pi) < 1e-9
    assert np.allclose(se2.variance(wrapped), [0.0, 1.0, 0.01])
    se3 = SE3Space([0, 0, 0], [1, 1, 1])
    half = np.sin(0.1)
    quats = np.array([[0.5, 0.5, 0.5, 0, 0, half, np.cos(0.1)], [0.5, 0.5, 0.5, 0, 0, -half, np.cos(0.1)]])
    assert np.allclose(se3.mean(quats), [0.5, 0.5, 0.5, 0, 0, 0, 1.0])
    assert np.allclose(se3.variance(quats), [0, 0, 0, 0, 0, 0.04])
    assert np.allclose(se3.mean(quats[:1]), quats[0]) and np.allclose(se3.variance(quats[:1]), 0.0)


@pytest.mark.parametrize("space", [RealVectorSpace([0, 0], [10, 10]), SE2Space([0, 0], [10, 10]),
                                   SE3Space([0, 0, 0], [10, 10, 10])], ids=lambda s: s.kind)
def test_steer_and_interpolate_keep_the_shape_of_one_configuration(space):
    a, b = space.sample(np.random.default_rng(0), 2)
    for t in (0.3, np.asarray(0.3), np.float64(0.3)):
        assert space.interpolate(a, b, t).shape == (space.dim,)
    assert space.steer(a, b, 1e-3).shape == (space.dim,)
    assert space.steer(a[None], b[None], 1e-3).shape == (1, space.dim)


@pytest.mark.parametrize("k", [1, 2, 3, 7, 50])
@pytest.mark.parametrize("nudge", [-1e-12, 0.0, 1e-12])
def test_an_edge_within_rounding_of_k_steps_is_cut_into_k_pieces(k, nudge):
    from pliant.spaces import RealVectorSpace

    space = RealVectorSpace([0.0, 0.0], [100.0, 100.0])
    step = 0.1
    b = np.array([k * step + nudge, 0.0])
    pieces = space.discretize(np.zeros(2), b, step)
    assert len(pieces) == k + 1
    assert np.allclose(np.diff(pieces[:, 0]), b[0] / k)
    longer = space.discretize(np.zeros(2), np.array([k * step * (1 + 1e-6), 0.0]), step)
    assert len(longer) == k + 2                       # beyond rounding: one more piece


def _se2_distance_numpy(space, a, b):
    """SE(2)'s distance as numpy computed it before the compiled kernel (the reference, bit for bit)."""
    from pliant.geometry.rotations import wrap_angle

    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    dxy = a[..., :2] - b[..., :2]
    dth = wrap_angle(a[..., 2] - b[..., 2])
    return np.sqrt(space.translation_weight ** 2 * np.sum(dxy * dxy, axis=-1) + (space.rotation_weight * dth) ** 2)


@given(st.integers(0, 2**32 - 1), st.sampled_from([0.1, 1.0, 3.7]), st.sampled_from([0.05, 1.0, 2.5]))
def test_se2_distance_compiled_equals_the_numpy_formulation_bit_for_bit(seed, tw, rw):
    space = SE2Space([-5, -5], [5, 5], translation_weight=tw, rotation_weight=rw)
    rng = np.random.default_rng(seed)
    many = rng.uniform(-5, 5, (17, 3)) * [1, 1, 4]           # angles also outside [-pi, pi)
    many[3, 2] = np.pi                                        # the wrap's edges
    many[4, 2] = -np.pi
    one = rng.uniform(-5, 5, 3)
    for a, b in [(many, one), (one, many), (many, many[::-1]), (one, one + 0.1), (many[:1], one),
                 (one, many[:1]), (many, many[2:3])]:
        ours, reference = space.distance(a, b), _se2_distance_numpy(space, a, b)
        assert np.shape(ours) == np.shape(reference)
        assert np.asarray(ours).tobytes() == np.asarray(reference).tobytes()
    batch = rng.uniform(-5, 5, (2, 4, 3))                    # other shapes: numpy, as before
    np.testing.assert_array_equal(space.distance(batch, one), _se2_distance_numpy(space, batch, one))
