"""The core voxel grid: materials, padding, signed distance, box decomposition."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from pliant import Scene, load_scene
from pliant.geometry.voxelgrid import VoxelGrid


def _grid(occupancy: np.ndarray) -> VoxelGrid:
    """A grid of 0.5 m voxels at the origin whose occupied voxels belong to one object."""
    return VoxelGrid(np.zeros(3), 0.5, np.where(occupancy, 0.5, 1.0), np.where(occupancy, 1.0, 0.0),
                     np.where(occupancy, 0, -1).astype(np.int32), ["o"])


@given(st.integers(0, 2**32 - 1))
def test_boxes_cover_the_occupied_voxels_exactly_once(seed):
    rng = np.random.default_rng(seed)
    occ = rng.random(tuple(rng.integers(1, 7, 3))) < rng.uniform(0.1, 0.9)
    grid = _grid(occ)
    covered = np.zeros(occ.shape, dtype=int)
    for lo, hi in grid.boxes():
        i0, i1 = np.round(lo / 0.5).astype(int), np.round(hi / 0.5).astype(int)
        covered[i0[0]:i1[0], i0[1]:i1[1], i0[2]:i1[2]] += 1
    assert np.array_equal(covered, occ.astype(int))


def test_bundled_scenes_decompose_into_few_boxes():
    assert len(VoxelGrid.from_scene(load_scene("se3-peg-in-hole")).boxes()) == 5
    assert len(VoxelGrid.from_scene(load_scene("se2-maze")).boxes()) <= 20


def test_signed_distance_of_a_box():
    data = {"name": "b", "start": [0.1, 0.1, 0.1], "goal": [0.1, 0.1, 0.1],
            "bounds": {"lower": [0, 0, 0], "upper": [2, 2, 2], "resolution": 0.1},
            "objects": [{"name": "box", "cells": [[5, 15], [5, 15], [5, 15]], "deformability": 0.0,
                         "sensitivity": 1.0}],
            "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "sphere", "radius": 0.01}]}}
    grid = VoxelGrid.from_scene(Scene.from_dict(data))
    assert grid.sdf_at(np.array([[1.0, 1.0, 1.0]]))[0] < -0.4          # deep inside
    assert abs(grid.sdf_at(np.array([[0.25, 1.05, 1.05]]))[0] - 0.25) < 0.06   # 0.25 m from the face at x = 0.5
    grad = grid.sdf_gradient_at(np.array([[0.3, 1.05, 1.05]]))[0]
    assert grad[0] < -0.9 and abs(grad[1]) < 1e-9                     # pointing away from the box: -x


def test_padding_grows_by_the_distance():
    scene = load_scene("cube-wall")
    plain, padded = VoxelGrid.from_scene(scene), VoxelGrid.from_scene(scene, padding=0.04)
    assert padded.occupied.sum() > plain.occupied.sum()
    assert np.all(padded.deformability[padded.occupied] == 0.0)


def test_static_only_leaves_out_movable_objects_and_keeps_the_ids():
    base = {"name": "t", "start": [0.05, 0.05, 0.05], "goal": [0.35, 0.35, 0.35],
            "bounds": {"lower": [0, 0, 0], "upper": [0.4, 0.4, 0.4], "resolution": 0.1},
            "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "sphere", "radius": 0.01}]},
            "objects": [{"name": "wall", "shape": "box", "size": [0.1, 0.4, 0.4], "position": [0.05, 0.2, 0.2],
                         "deformability": 0.0, "sensitivity": 1.0},
                        {"name": "crate", "shape": "box", "size": [0.1, 0.1, 0.1], "position": [0.25, 0.25, 0.25],
                         "deformability": 0.0, "sensitivity": 1.0, "mass": 1.0}]}
    scene = Scene.from_dict(base)
    full = VoxelGrid.from_scene(scene)
    walls = VoxelGrid.from_scene(scene, static_only=True)
    assert full.object_names == walls.object_names == ["wall", "crate"]
    assert (full.object_id == 1).sum() == 1 and (walls.object_id == 1).sum() == 0
    assert np.array_equal(full.object_id == 0, walls.object_id == 0) and (walls.object_id == 0).sum() == 16
    assert np.array_equal(walls.occupied, full.occupied & (full.object_id != 1))
