"""Approximate reachable volumes (thesis 6.4.1, eq. 6.1-6.8): hand-computed bounds and coverage (Theorem 2)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import ConfigError
from pliant.execution.actuation import ControlLaw
from pliant.execution.noise import ActuationNoise
from pliant.spaces import RealVectorSpace
from pliant_reachability.assess import sample_counts
from pliant_reachability.volumes import reachable_volumes, tangent_weights
from reachability_helpers import GOAL, START, metric, passage


def law_2d(kp=0.5, bound=0.0, limit=100.0, dt=0.1):
    space = RealVectorSpace([-10, -10], [10, 10])
    noise = ActuationNoise("bounded", np.array([bound, bound])) if bound else ActuationNoise()
    return ControlLaw(space, kp, 0.0, dt, np.zeros(2, dtype=bool), limit, limit, None, noise)


def test_a_proportional_controller_shrinks_the_box_geometrically():
    law = law_2d(kp=0.5)
    volumes = reachable_volumes(law, np.array([1.0, 0.0]), np.zeros(2), 0.1, np.ones(2))
    # eq. 6.7-6.8 without noise: each bound moves half-way to the target every step
    assert volumes.lower[0] == pytest.approx([0.9, -0.1])
    assert volumes.upper[0] == pytest.approx([1.1, 0.1])
    assert volumes.lower[1] == pytest.approx([0.45, -0.05])
    assert volumes.upper[3] == pytest.approx([1.1 / 8, 0.1 / 8])
    # ends with the first box within 0.1 of the target: 1.1 * 0.5^k * sqrt(1 + (1/11)^2) <= 0.1 -> k = 4
    assert len(volumes) == 5 and volumes.converged


def test_noise_widens_each_bound_by_its_largest_displacement():
    law = law_2d(kp=0.5, bound=0.2)              # 0.2 m/s over 0.1 s: 0.02 per step
    volumes = reachable_volumes(law, np.array([1.0, 0.0]), np.zeros(2), 0.1, np.ones(2))
    assert volumes.lower[1] == pytest.approx([0.45 - 0.02, -0.05 - 0.02])
    assert volumes.upper[1] == pytest.approx([0.55 + 0.02, 0.05 + 0.02])


def test_the_velocity_cap_limits_the_advance():
    law = law_2d(kp=1.0, limit=1.0)              # at most 0.1 per step
    volumes = reachable_volumes(law, np.array([1.0, 0.0]), np.zeros(2), 0.05, np.ones(2))
    # the box's points all move by at most 0.1 per step toward the target
    assert volumes.upper[1][0] == pytest.approx(1.05 - 0.1 * 1.05 / np.hypot(1.05, 0.05), abs=1e-9)
    assert 10 <= len(volumes) <= 12


@settings(max_examples=25, deadline=None)
@given(kp=st.floats(0.2, 1.0), bound=st.floats(0.0, 0.5), epsilon=st.floats(0.05, 0.3), seed=st.integers(0, 10**6))
def test_obstacle_free_executions_stay_in_the_volumes(kp, bound, epsilon, seed):
    """Theorem 2: the volumes cover every noisy execution of the controller, step by step."""
    law = law_2d(kp=kp, bound=bound, limit=2.0)
    volumes = reachable_volumes(law, np.array([1.0, -0.5]), np.zeros(2), epsilon, np.ones(2))
    rng = np.random.default_rng(seed)
    x = volumes.sample(0, rng, 200)
    for t in range(1, len(volumes)):
        velocity = law.velocity(x, np.zeros(2))
        x = x + (velocity + law.noise.sample(rng, velocity)) * law.dt
        assert volumes.contains(t, x).all(), t


def test_se2_volumes_are_in_target_coordinates_and_end_near_it():
    m = metric(passage(), epsilon_reached=0.125)
    volumes = m.volumes(START, GOAL)
    # RV_0 is the epsilon box around the start: 0.125 / 10 m in x and y, 0.125 rad
    assert volumes.lower[0] == pytest.approx([-0.0125, -0.3 - 0.0125, -0.125])
    assert volumes.converged
    assert volumes.distance_to_target(volumes.upper[-1][None])[0] <= 0.125 + 1e-12
    assert np.allclose(volumes.configurations(volumes.coordinates(START[None])), START[None])


def test_weights_and_bad_epsilon():
    law = passage().simulator.control_law()
    assert tangent_weights(law, 10.0, 1.0) == pytest.approx([10.0, 10.0, 1.0])
    with pytest.raises(ConfigError, match="epsilon_reached"):
        reachable_volumes(law, START, GOAL, 0.0, np.ones(3))


def test_sample_counts_floor_thin_sides_at_the_spacing():
    law = law_2d()
    volumes = reachable_volumes(law, np.array([1.0, 0.0]), np.zeros(2), 0.1, np.ones(2))
    counts = sample_counts(volumes, 100.0, 10**6)       # spacing 0.1
    # RV_0 is 0.2 x 0.2: 4 samples; RV_3 is 0.025 x 0.025, both sides floored at 0.1: one sample
    assert counts[0] == 4 and counts[3] == 1
    assert sample_counts(volumes, 1e6, 50).max() == 50
