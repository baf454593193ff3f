"""Hostile scene files: every one loads into a valid Scene or raises a PliantError naming the field -- never a
traceback, never unbounded memory or time, never garbage accepted (issue: hardening).

File-level cases the dictionary corpus of test_bad_input.py cannot reach: meshes (huge, overflowing, FIFOs), voxel
arrays (strings, NaN, objects, compressed bombs), TOML nested past the recursion limit, grids too large to
allocate; plus hypothesis over the voxel-array loader."""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant import load_scene
from pliant.errors import PliantError, SceneError
from pliant.geometry.shapes import MAX_MESH_TRIANGLES, VoxelArray
from pliant.scene import MAX_GRID_CELLS

BASE = """name = "hostile"
start = [0.1, 0.1, 0.1]
goal = [0.9, 0.9, 0.1]
[bounds]
lower = [0.0, 0.0, 0.0]
upper = [1.0, 1.0, 0.2]
resolution = {resolution}
[robot]
kind = "rigid"
name = "box"
space = "r3"
parts = [{{ shape = "box", size = [0.05, 0.05, 0.05] }}]
"""


def _scene(tmp_path, objects: str = "", resolution: str = "0.05") -> str:
    path = tmp_path / "scene.toml"
    path.write_text(BASE.format(resolution=resolution) + objects)
    return str(path)


def _object(**fields) -> str:
    lines = ["[[objects]]", 'name = "o"', "deformability = 0.5", "sensitivity = 1.0"]
    lines += [f"{k} = {v}" for k, v in fields.items()]
    return "\n".join(lines) + "\n"


def _cube_obj(path, triangles: int = 12):
    verts = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    faces = ("f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\n"
             "f 4 5 8\n")
    extra = "".join(f"f 1 2 {3 + k % 6}\n" for k in range(triangles - 12))
    path.write_text(verts + faces + extra)


def _raises(path: str, field: str, says: str):
    with pytest.raises(SceneError, match=says) as info:
        load_scene(path)
    assert f":{field}" in str(info.value), str(info.value)


def test_a_grid_too_large_to_allocate_is_refused_before_allocating(tmp_path):
    _raises(_scene(tmp_path, resolution="1e-9"), "bounds.resolution", "more than the limit of")
    _raises(_scene(tmp_path, resolution="1e-5"), "bounds.resolution", "PLIANT_MAX_GRID_CELLS")
    assert MAX_GRID_CELLS >= 150 * 150 * 200            # the largest bundled scene (se3-peg-tight) fits


def test_the_grid_limit_can_be_raised_and_lowered_by_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("PLIANT_MAX_GRID_CELLS", "100")
    _raises(_scene(tmp_path), "bounds.resolution", "limit of 100")
    monkeypatch.setenv("PLIANT_MAX_GRID_CELLS", "lots")
    with pytest.raises(PliantError, match="PLIANT_MAX_GRID_CELLS: must be an integer"):
        load_scene(_scene(tmp_path))


def test_an_object_wholly_outside_the_bounds_is_an_error_and_one_partly_outside_is_not(tmp_path):
    _raises(_scene(tmp_path, _object(shape='"box"', size="[0.1, 0.1, 0.1]", position="[5, 5, 5]")),
            "objects[0].position", "wholly outside")
    scene = load_scene(_scene(tmp_path, _object(shape='"box"', size="[0.4, 0.4, 0.4]", position="[1.0, 1.0, 0.1]")))
    assert scene.objects[0].name == "o"


def test_meshes_too_large_overflowing_or_not_regular_files_are_refused(tmp_path):
    _cube_obj(tmp_path / "cube.obj")
    ok = load_scene(_scene(tmp_path, _object(shape='"mesh"', file='"cube.obj"', scale="0.2",
                                             position="[0.4, 0.4, 0.0]")))
    assert ok.objects[0].part.shape.triangles.shape == (12, 3, 3)
    for scale in ("1e300", "1e7"):
        _raises(_scene(tmp_path, _object(shape='"mesh"', file='"cube.obj"', scale=scale, position="[0.4, 0.4, 0]")),
                "objects[0].scale", "mesh vertices")
    _cube_obj(tmp_path / "big.obj", MAX_MESH_TRIANGLES + 1)
    _raises(_scene(tmp_path, _object(shape='"mesh"', file='"big.obj"', position="[0.4, 0.4, 0]")),
            "objects[0].file", "triangles, more than the limit")
    os.mkfifo(tmp_path / "fifo.obj")
    _raises(_scene(tmp_path, _object(shape='"mesh"', file='"fifo.obj"', position="[0.4, 0.4, 0]")),
            "objects[0].file", "not a regular file")
    (tmp_path / "dir.stl").mkdir()
    _raises(_scene(tmp_path, _object(shape='"mesh"', file='"dir.stl"', position="[0.4, 0.4, 0]")),
            "objects[0].file", "a directory")
    (tmp_path / "junk.stl").write_bytes(b"\x00" * 200)
    _raises(_scene(tmp_path, _object(shape='"mesh"', file='"junk.stl"', position="[0.4, 0.4, 0]")),
            "objects[0].file", "cannot read mesh file")


def test_the_winding_number_of_a_large_mesh_uses_bounded_memory(tmp_path):
    _cube_obj(tmp_path / "cube.obj", 5000)
    scene = load_scene(_scene(tmp_path, _object(shape='"mesh"', file='"cube.obj"', scale="0.2",
                                                position="[0.4, 0.4, 0.0]")))
    mesh = scene.objects[0].part.shape
    import tracemalloc

    points = np.random.default_rng(0).uniform(-0.1, 0.3, (3000, 3))
    tracemalloc.start()
    mesh.winding_number(points)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 200 * 2**20, peak            # 3000 x 5000 x 9 floats at once would be 1 GB


@pytest.mark.parametrize(("arrays", "says"), [
    ({"occupancy": np.array([[["a", "b"]]])}, "booleans or 0 / 1"),
    ({"occupancy": np.full((2, 2, 2), np.nan)}, "each be 0 or 1"),
    ({"occupancy": np.full((2, 2, 2), 2.0)}, "each be 0 or 1"),
    ({"occupancy": np.ones((2, 2))}, "3-D array"),
    ({"occupancy": np.ones((0, 2, 2))}, "3-D array"),
    ({"voxels": np.ones((2, 2, 2))}, "no 'occupancy'"),
    ({"occupancy": np.ones((2, 2, 2), bool), "sensitivity": np.array([[["x"] * 2] * 2] * 2)}, "must hold numbers"),
    ({"occupancy": np.ones((2, 2, 2), bool), "deformability": np.full((2, 2, 2), 3.0)}, r"\[0.0, 1.0\]"),
    ({"occupancy": np.ones((2, 2, 2), bool), "deformability": np.ones((3, 2, 2))}, "shape of 'occupancy'"),
])
def test_voxel_arrays_of_garbage_are_errors_not_occupancy(tmp_path, arrays, says):
    np.savez(tmp_path / "v.npz", **arrays)
    _raises(_scene(tmp_path, _object(shape='"voxels"', file='"v.npz"', position="[0.4, 0.4, 0]")),
            "objects[0].file", says)


def test_voxel_files_that_are_not_npz_or_hold_objects_or_bombs_are_refused(tmp_path, monkeypatch):
    np.savez(tmp_path / "obj.npz", occupancy=np.array([{"a": 1}, None], dtype=object))
    _raises(_scene(tmp_path, _object(shape='"voxels"', file='"obj.npz"')), "objects[0].file", "cannot read voxel")
    (tmp_path / "text.npz").write_text("not a zip")
    _raises(_scene(tmp_path, _object(shape='"voxels"', file='"text.npz"')), "objects[0].file", "cannot read voxel")
    # a compressed array far larger than its file: refused from the header, before decompressing
    np.savez_compressed(tmp_path / "bomb.npz", occupancy=np.zeros((400, 400, 400), bool))
    assert (tmp_path / "bomb.npz").stat().st_size < 2**20
    monkeypatch.setenv("PLIANT_MAX_GRID_CELLS", str(10**6))
    _raises(_scene(tmp_path, _object(shape='"voxels"', file='"bomb.npz"')), "objects[0].file",
            "64,000,000 entries")


def test_toml_nested_past_the_recursion_limit_is_an_error(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 50000 + "]" * 50000 + "\n")
    with pytest.raises(SceneError, match="nested too deeply"):
        load_scene(str(path))


def test_a_scene_path_that_is_a_fifo_or_a_directory_is_an_error(tmp_path):
    os.mkfifo(tmp_path / "fifo.toml")
    for target in (tmp_path / "fifo.toml", tmp_path):
        with pytest.raises(PliantError):
            load_scene(str(target))


ARRAYS = st.one_of(
    st.builds(lambda shape, value: np.full(shape, value), st.tuples(*[st.integers(1, 3)] * 3),
              st.one_of(st.booleans(), st.integers(-2, 3), st.floats(allow_nan=True, allow_infinity=True),
                        st.text(max_size=2))),
    st.builds(lambda shape: np.zeros(shape), st.lists(st.integers(0, 3), min_size=0, max_size=4).map(tuple)))


@settings(max_examples=200, deadline=None)
@given(ARRAYS, st.one_of(st.none(), ARRAYS))
def test_the_voxel_loader_accepts_exactly_3d_zero_one_occupancy(tmp_path_factory, occupancy, sensitivity):
    path = tmp_path_factory.mktemp("npz") / "v.npz"
    arrays = {"occupancy": occupancy} if sensitivity is None else {"occupancy": occupancy, "sensitivity": sensitivity}
    np.savez(path, **arrays)
    try:
        loaded = VoxelArray.load(path, 0.05, source="s.toml", field_name="objects[0].file")
    except SceneError as exc:
        assert str(exc).startswith("s.toml:objects[0].file:"), str(exc)
        return
    assert occupancy.ndim == 3 and occupancy.size and loaded.occupancy.dtype == np.bool_
    assert occupancy.dtype.kind in "biuf" and np.all((occupancy == 0) | (occupancy == 1))
