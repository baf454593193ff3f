"""Towing a soft cube in pybullet (thesis 3.3.4): deformation in free space, through holes, bad input."""

from __future__ import annotations

import copy

import numpy as np
import pliant
import pytest
from pliant.errors import ConfigError, DimensionError, PliantError, SimulationError
from pliant.scene import Scene
from pliant_pybullet.towing import Tower, TowingOptions, check_path, soft_cube_from_scene, tow

CUBE_VOLUME = 0.2 ** 3


def _line(x, z, y0, y1, step=0.02, quaternion=(0.0, 0.0, 0.0, 1.0)):
    ys = np.arange(y0, y1 + 1e-9, step)
    return np.column_stack([np.full_like(ys, x), ys, np.full_like(ys, z), np.tile(quaternion, (len(ys), 1))])


@pytest.fixture(scope="module")
def scene():
    return pliant.load_scene("cube-wall")


@pytest.fixture(scope="module")
def through_holes(scene):
    # the same towing through the larger (0.18 m) and the smaller (0.16 m) hole, centred on each
    fast = {"speed": 0.2, "max_settle_steps": 30}
    big = tow(scene, _line(0.70, 0.50, 0.37, 0.61, step=0.04), fast)
    small = tow(scene, _line(0.29, 0.49, 0.37, 0.61, step=0.04), fast)
    return big, small


def test_the_cube_wall_robot_is_a_soft_box_around_a_rigid_core(scene):
    cube = soft_cube_from_scene(scene)
    assert np.allclose(cube.size, 0.2) and np.allclose(cube.center, 0.01)
    assert np.allclose(cube.core_upper - cube.core_lower, 0.06)


def test_towing_through_free_space_deforms_almost_nothing(scene):
    r = tow(scene, _line(0.5, 0.5, 0.2, 0.3), {"max_settle_steps": 30})
    assert len(r.deformation) == 6 and r.tracked
    assert r.total == pytest.approx(r.deformation.sum())
    # what remains is the sloshing of a very soft body stopped at each state: well under 1% of its volume
    assert np.all(r.deformation < 1e-2 * CUBE_VOLUME)
    assert np.all(r.contacts == 0)


def test_towing_through_a_hole_smaller_than_the_cube_deforms_it(through_holes):
    big, small = through_holes
    for r in (big, small):
        assert np.all(r.deformation >= 0) and np.all(np.isfinite(r.deformation))
        assert r.deformation.max() > 0.05 * CUBE_VOLUME      # squeezed by 0.02 m / 0.04 m across
        assert r.contacts.max() > 0
        assert r.core_error.max() < 0.02                      # the cube followed its core
    assert small.total > big.total
    assert small.deformation.max() > big.deformation.max()


def test_deformation_starts_when_the_cube_reaches_the_wall(through_holes):
    big, _ = through_holes
    # the cube's front (core y + 0.11 m) reaches the wall's face (y = 0.475) at core y = 0.365
    assert big.deformation[0] < 1e-2 * CUBE_VOLUME
    assert big.deformation.max() > 100 * big.deformation[0]


def test_bad_input_is_refused(scene):
    with pytest.raises(DimensionError, match=r"path.*\(k, 7\)"):
        check_path(np.zeros((3, 3)))
    bad = _line(0.5, 0.5, 0.2, 0.3)
    bad[2, 3:] = [0.0, 0.0, 0.0, 2.0]
    with pytest.raises(DimensionError, match=r"path\[2\].*unit"):
        check_path(bad)
    bad[2, 3:] = [0.0, 0.0, 0.0, 1.0]
    bad[1, 0] = np.nan
    with pytest.raises(PliantError, match=r"path\[1\]"):
        tow(scene, bad)
    with pytest.raises(ConfigError, match="cells"):
        Tower(scene, {"cells": (1, 4, 4)})
    with pytest.raises(ConfigError, match="speed"):
        Tower(scene, {"speed": -1.0})
    with pytest.raises(ConfigError, match="max_settle_steps"):
        TowingOptions(min_settle_steps=10, max_settle_steps=5).validate()


def test_a_robot_without_a_rigid_core_cannot_be_towed(scene):
    raw = copy.deepcopy(scene.raw)
    raw.pop("pipeline", None)
    raw["robot"]["parts"] = raw["robot"]["parts"][:1]
    with pytest.raises(SimulationError, match="rigid part"):
        soft_cube_from_scene(Scene.from_dict(raw, source="no-core"))


def test_assessing_one_configuration_in_the_hole_settles_with_positive_deformation(scene):
    with Tower(scene, {"max_settle_steps": 200}) as tower:
        free = tower.assess([0.5, 0.25, 0.5, 0.0, 0.0, 0.0, 1.0])
        pressed = tower.assess([0.70, 0.50, 0.50, 0.0, 0.0, 0.0, 1.0])
    assert free["settled"] and free["deformation"] < 1e-6 and free["contacts"] == 0
    assert pressed["contacts"] > 0 and pressed["deformation"] > 1e-2 * CUBE_VOLUME
    assert 1 <= pressed["steps"] <= 200
