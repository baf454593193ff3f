"""Scene loading: shapes, the bundled scenes' geometry, variants, meshes and voxel files."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pliant import load_scene
from pliant.errors import SceneError
from pliant.geometry.shapes import Box, Cylinder, Mesh, Sphere, VoxelArray
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.scene import Scene, available_scenes


def test_primitive_membership_by_hand():
    pts = np.array([[0.0, 0.0, 0.0], [0.49, 0.0, 0.0], [0.51, 0.0, 0.0], [0.3, 0.3, 0.3]])
    assert Box(np.array([1.0, 1.0, 1.0])).contains(pts).tolist() == [True, True, False, True]
    assert Sphere(0.5).contains(pts).tolist() == [True, True, False, False]   # |(0.3, 0.3, 0.3)| = 0.52
    cyl = Cylinder(0.5, 0.4)
    assert cyl.contains(pts).tolist() == [True, True, False, False]


CUBE_OBJ = """v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8
"""


def _cube_triangles():
    v = np.array([[float(x) for x in line.split()[1:]] for line in CUBE_OBJ.splitlines() if line.startswith("v")])
    f = [[int(x) - 1 for x in line.split()[1:]] for line in CUBE_OBJ.splitlines() if line.startswith("f")]
    return v[np.array(f)]


@pytest.mark.parametrize("fmt", ["obj", "stl-binary", "stl-ascii"])
def test_mesh_membership(tmp_path, fmt):
    tris = _cube_triangles()
    if fmt == "obj":
        path = tmp_path / "cube.obj"
        path.write_text(CUBE_OBJ)
    elif fmt == "stl-binary":
        path = tmp_path / "cube.stl"
        data = bytearray(80) + struct.pack("<I", len(tris))
        for t in tris:
            data += struct.pack("<12fH", 0, 0, 0, *t.reshape(-1), 0)
        path.write_bytes(bytes(data))
    else:
        path = tmp_path / "cube.stl"
        body = "".join("facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {a} {b} {c}\n" for a, b, c in t)
                       + "endloop\nendfacet\n" for t in tris)
        path.write_text(f"solid cube\n{body}endsolid cube\n")
    mesh = Mesh.load(path, scale=2.0)
    pts = np.array([[1.0, 1.0, 1.0], [0.1, 1.9, 0.5], [2.1, 1.0, 1.0], [-0.1, 0.5, 0.5]])
    assert mesh.contains(pts).tolist() == [True, True, False, False]


def test_unreadable_mesh_names_the_field(tmp_path):
    bad = tmp_path / "broken.stl"
    bad.write_bytes(b"\x00\x01garbage")
    with pytest.raises(SceneError, match=r"x\.toml:objects\[0\]\.file: cannot read mesh"):
        Scene.from_dict(_scene_with({"name": "m", "shape": "mesh", "file": "broken.stl", "deformability": 0,
                                     "sensitivity": 1}), source="x.toml", base_dir=tmp_path)


def test_voxel_array_file(tmp_path):
    occ = np.zeros((4, 4, 4), bool)
    occ[1:3, 1:3, 1:3] = True
    defo = np.where(occ, 0.25, 1.0)
    np.savez(tmp_path / "blob.npz", occupancy=occ, deformability=defo)
    arr = VoxelArray.load(tmp_path / "blob.npz", 0.1)
    assert arr.contains(np.array([[0.15, 0.15, 0.15], [0.05, 0.05, 0.05]])).tolist() == [True, False]
    scene = Scene.from_dict(_scene_with({"name": "blob", "shape": "voxels", "file": "blob.npz", "resolution": 0.1,
                                         "deformability": 0.5, "sensitivity": 2.0}), base_dir=tmp_path)
    grid = VoxelGrid.from_scene(scene)
    assert grid.occupied.sum() == 8
    assert np.all(grid.deformability[grid.occupied] == 0.25)     # per-voxel values from the file win
    assert np.all(grid.sensitivity[grid.occupied] == 2.0)        # absent in the file: the object's material


def _scene_with(obj: dict) -> dict:
    return {"name": "t", "start": [0.05, 0.05, 0.05], "goal": [0.35, 0.35, 0.35],
            "bounds": {"lower": [0, 0, 0], "upper": [0.4, 0.4, 0.4], "resolution": 0.1}, "objects": [obj],
            "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "sphere", "radius": 0.01}]}}


def test_every_bundled_scene_loads():
    names = available_scenes()
    assert {"triple-wall", "multi-cost", "cube-wall", "se2-maze", "se3-peg-in-hole"} <= set(names)
    for name in names:
        scene = load_scene(name)
        for variant in scene.variants:
            load_scene(name, variant=variant)


def test_triple_wall_geometry_cell_by_cell():
    grid = VoxelGrid.from_scene(load_scene("triple-wall"))
    occ = grid.occupied
    x, y, z = np.meshgrid(np.arange(30), np.arange(66), np.arange(30), indexing="ij")
    in_wall = {1: (y >= 12) & (y < 18), 2: (y >= 30) & (y < 36), 3: (y >= 48) & (y < 54)}
    open1 = (z < 12) | ((x >= 12) & (x < 18) & (z < 18)) | ((x >= 15) & (x < 18) & (z >= 27))
    open2 = (z >= 18) | ((x >= 12) & (x < 18) & (z >= 12))
    open3 = (z < 12) | ((x >= 12) & (x < 18) & (z < 18)) | ((x >= 12) & (x < 15) & (z >= 27))
    expected = (in_wall[1] & ~open1) | (in_wall[2] & ~open2) | (in_wall[3] & ~open3)
    assert np.array_equal(occ, expected)
    assert np.all(grid.deformability[occ] == 0.5) and np.all(grid.sensitivity[occ] == 0.5)
    assert np.all(grid.deformability[~occ] == 1.0) and np.all(grid.sensitivity[~occ] == 0.0)


def test_multi_cost_geometry_cell_by_cell():
    grid = VoxelGrid.from_scene(load_scene("multi-cost"))
    x, y, z = np.meshgrid(np.arange(30), np.arange(66), np.arange(12), indexing="ij")
    opening = (x >= 10) & (x < 20) & (z >= 5) & (z < 10)
    wall1 = (y >= 18) & (y < 24) & ~opening
    wall2 = (y >= 42) & (y < 48) & ~opening
    assert np.array_equal(grid.occupied, wall1 | wall2)
    low = (wall1 & (x < 15)) | (wall2 & (x >= 15))
    high = (wall1 & (x >= 15)) | (wall2 & (x < 15))
    assert np.all(grid.deformability[low] == 0.25) and np.all(grid.sensitivity[low] == 0.25)
    assert np.all(grid.deformability[high] == 0.5) and np.all(grid.sensitivity[high] == 0.5)


def test_variants_swap_materials():
    scene = load_scene("triple-wall:soft-robot-hard-walls")
    assert scene.variant == "soft-robot-hard-walls"
    assert scene.robot.material.deformability == 0.5
    assert all(o.material.deformability == 0.0 and o.material.sensitivity == 1.0 for o in scene.objects)
    assert all(p.material.deformability == 0.5 for p in scene.robot.parts)


def test_appending_variant_adds_the_block():
    scene = load_scene("se2-maze", variant="blocked")
    assert [o.name for o in scene.objects] == ["walls", "block"]
    assert scene.object("block").contains(np.array([[8.0, 5.0, 0.0]]))[0]


def test_unknown_variant_and_scene():
    with pytest.raises(SceneError, match="unknown variant"):
        load_scene("triple-wall", variant="squishy")
    with pytest.raises(SceneError, match="no bundled scene"):
        load_scene("no-such-scene")


def test_se2_maze_regions_and_free_space():
    scene = load_scene("se2-maze")
    assert len(scene.regions) == 5
    walls = scene.object("walls")
    free = np.array([[1.0, 5.0, 0.0], [5.0, 8.0, 0.0], [8.0, 2.0, 0.0], [0.75, 0.75, 0.0]])
    solid = np.array([[0.25, 5.0, 0.0], [3.25, 5.0, 0.0], [6.75, 5.0, 0.0], [5.0, 9.75, 0.0]])
    assert not walls.contains(free).any() and walls.contains(solid).all()


# --- movable objects: mass and friction -------------------------------------------------------

_BOX = {"name": "crate", "shape": "box", "size": [0.1, 0.1, 0.1], "position": [0.2, 0.2, 0.2],
        "deformability": 0.0, "sensitivity": 1.0}


def test_mass_and_friction_make_an_object_movable():
    static = Scene.from_dict(_scene_with(dict(_BOX))).object("crate")
    assert static.mass is None and static.friction is None and not static.movable
    movable = Scene.from_dict(_scene_with({**_BOX, "mass": 2, "friction": 0.3})).object("crate")
    assert movable.movable and movable.mass == 2.0 and movable.friction == 0.3
    assert isinstance(movable.mass, float)
    rough_wall = Scene.from_dict(_scene_with({**_BOX, "friction": 0.0})).object("crate")
    assert rough_wall.friction == 0.0 and not rough_wall.movable      # friction alone: still static


@pytest.mark.parametrize("key", ["mass", "friction"])
@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf"), True, "heavy", [1.0]])
def test_bad_mass_or_friction_names_file_field_and_value(key, value):
    with pytest.raises(SceneError) as err:
        Scene.from_dict(_scene_with({**_BOX, key: value}), source="s.toml")
    assert f"s.toml:objects[0].{key}" in str(err.value) and repr(value)[:4] in str(err.value)


def test_zero_mass_is_refused_but_zero_friction_is_not():
    with pytest.raises(SceneError, match=r"objects\[0\]\.mass: must be positive"):
        Scene.from_dict(_scene_with({**_BOX, "mass": 0.0}))
    assert Scene.from_dict(_scene_with({**_BOX, "mass": 1.0, "friction": 0})).object("crate").friction == 0.0


@given(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6), st.booleans(),
                 st.text(max_size=3), st.none()),
       st.sampled_from(["mass", "friction"]))
def test_any_mass_or_friction_loads_iff_it_is_in_range(value, key):
    ok_number = (not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
                 and (value > 0 if key == "mass" else value >= 0))
    data = _scene_with({**_BOX, key: value})
    if value is None:            # a dict (not TOML) may say None: the field is absent
        assert getattr(Scene.from_dict(data).object("crate"), key) is None
    elif ok_number:
        assert getattr(Scene.from_dict(data).object("crate"), key) == float(value)
    else:
        with pytest.raises(SceneError, match=rf"objects\[0\]\.{key}"):
            Scene.from_dict(data)
