"""Quaternion and rotation helpers."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pliant.geometry.rotations import (
    matrix_to_quat,
    quat_angle,
    quat_multiply,
    quat_slerp,
    quat_to_matrix,
    random_quaternions,
    rotation_z,
)


@given(st.integers(0, 2**32 - 1))
def test_matrix_round_trip(seed):
    q = random_quaternions(np.random.default_rng(seed), 8)
    m = quat_to_matrix(q)
    assert np.allclose(m @ np.swapaxes(m, 1, 2), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(m), 1.0)
    back = matrix_to_quat(m)
    assert np.allclose(quat_angle(back, q), 0.0, atol=1e-6)


def test_product_composes_rotations():
    rng = np.random.default_rng(0)
    a, b = random_quaternions(rng, 2)
    assert np.allclose(quat_to_matrix(quat_multiply(a, b)), quat_to_matrix(a) @ quat_to_matrix(b))


def test_rotation_z_matches_quaternion():
    theta = 0.7
    q = np.array([0, 0, np.sin(theta / 2), np.cos(theta / 2)])
    assert np.allclose(rotation_z(theta), quat_to_matrix(q))


def test_slerp_endpoints_and_unit_norm():
    rng = np.random.default_rng(1)
    a, b = random_quaternions(rng, 2)
    t = np.linspace(0, 1, 11)
    path = quat_slerp(a, b, t)
    assert np.allclose(np.linalg.norm(path, axis=1), 1.0)
    assert quat_angle(path[0], a) == pytest.approx(0, abs=1e-7)
    assert quat_angle(path[-1], b) == pytest.approx(0, abs=1e-7)
    steps = quat_angle(path[:-1], path[1:])
    assert np.allclose(steps, steps[0], atol=1e-7)


def test_random_quaternions_are_uniform():
    q = random_quaternions(np.random.default_rng(2), 200_000)
    second_moment = q.T @ q / len(q)
    assert np.allclose(second_moment, np.eye(4) / 4, atol=5e-3)
