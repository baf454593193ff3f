"""The rigid-body robot: body points counted by hand, analytic Jacobians against finite differences."""

from __future__ import annotations

import numpy as np
import pytest
from pliant.errors import DimensionError
from pliant.testing import check_robot


def test_triple_wall_puck_has_the_benchmark_cells(scene_context):
    robot = scene_context("triple-wall").robot
    # rows in x: x=1 y in [3,8) (5), x=2 [2,9) (7), x=3..7 [1,9) (8 each), x=8 [2,9) (7); 3 layers
    assert robot.point_count() == (5 + 7 + 5 * 8 + 7) * 3
    offsets = np.round(robot.local_points / 0.008).astype(int) + np.array([5, 5, 1])
    assert set(map(tuple, offsets[offsets[:, 0] == 1][:, 1:])) == {(y, z) for y in range(3, 8) for z in range(3)}
    assert np.all(robot.point_materials() == [0.0, 1.0])


def test_cube_wall_cube_has_1000_points_and_a_rigid_core(scene_context):
    robot = scene_context("cube-wall").robot
    mats = robot.point_materials()
    assert len(mats) == 1000
    assert np.sum(mats[:, 0] == 0.0) == 27 and np.sum(mats[:, 0] == 0.5) == 973


@pytest.mark.parametrize("scene", ["triple-wall", "se2-maze", "cube-wall"])
def test_conformance_and_jacobians(scene, scene_context):
    assert check_robot(scene_context(scene).robot)


def test_se2_rotation_moves_points_about_the_reference(scene_context):
    robot = scene_context("se2-maze").robot
    q0 = np.array([5.0, 5.0, 0.0])
    q90 = np.array([5.0, 5.0, np.pi / 2])
    p0 = robot.body_points(q0)[0] - [5.0, 5.0, 0.0]
    p90 = robot.body_points(q90)[0] - [5.0, 5.0, 0.0]
    assert np.allclose(p90[:, 0], -p0[:, 1]) and np.allclose(p90[:, 1], p0[:, 0])


def test_wrong_configuration_length(scene_context):
    with pytest.raises(DimensionError, match="7"):
        scene_context("cube-wall").robot.body_points(np.zeros(3))
