"""The content-addressed preprocessing cache (pliant.cache) and its users: a cached build equals a fresh one exactly,
changed content misses, a damaged file is rebuilt, concurrent writers leave a whole file, the environment variables
work."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from pliant import cache, load_scene
from pliant.errors import ConfigError
from pliant.geometry.voxelgrid import VoxelGrid, _signed_distance
from pliant.scene import Scene

SCENES = ["triple-wall", "multi-cost", "se2-maze", "se2-push", "hollow-cube"]


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    """An empty cache directory of this test, an empty memo and zeroed counts."""
    path = tmp_path / "cache"
    monkeypatch.setenv("PLIANT_CACHE_DIR", str(path))
    monkeypatch.delenv("PLIANT_CACHE", raising=False)
    cache.forget()
    for key in cache.counts:
        cache.counts[key] = 0
    yield path
    cache.forget()


def _same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert a.keys() == b.keys()
    for name in a:
        assert a[name].dtype == b[name].dtype and a[name].shape == b[name].shape, name
        assert np.array_equal(a[name], b[name], equal_nan=True), name


def _grid_arrays(grid: VoxelGrid) -> dict[str, np.ndarray]:
    return {**grid.arrays(), "lower": np.asarray(grid.lower), "resolution": np.array(grid.resolution)}


@pytest.mark.parametrize("name", SCENES)
def test_a_cached_grid_and_distance_field_equal_a_fresh_build(cache_dir, name):
    scene = load_scene(name)
    for static_only in (False, True):
        fresh = VoxelGrid._build(scene, 0.0, static_only)
        built = VoxelGrid.from_scene(scene, static_only=static_only)      # built and written
        memo = VoxelGrid.from_scene(scene, static_only=static_only)       # this process's memo
        cache.forget()
        disk = VoxelGrid.from_scene(scene, static_only=static_only)       # read from the file
        for grid in (built, memo, disk):
            _same(_grid_arrays(fresh), _grid_arrays(grid))
            assert grid.object_names == fresh.object_names
    assert cache.counts["disk"] >= 1 and cache.counts["memo"] >= 1
    fresh = VoxelGrid._build(scene, 0.0, False)
    sdf = _signed_distance(fresh.occupied, fresh.resolution) if fresh.occupied.any() else None
    if sdf is not None:
        assert np.array_equal(VoxelGrid.from_scene(scene).sdf, sdf)
        cache.forget()
        assert np.array_equal(VoxelGrid.from_scene(scene).sdf, sdf)


def test_padding_and_per_voxel_materials_are_kept(cache_dir, tmp_path):
    occ = np.zeros((4, 4, 4), bool)
    occ[1:3, 1:3, 1:3] = True
    np.savez(tmp_path / "blob.npz", occupancy=occ, deformability=np.where(occ, 0.25, 1.0))
    scene = Scene.from_dict({
        "name": "t", "start": [0.05, 0.05, 0.05], "goal": [0.55, 0.55, 0.55],
        "bounds": {"lower": [0, 0, 0], "upper": [0.6, 0.6, 0.6], "resolution": 0.1},
        "objects": [{"name": "blob", "shape": "voxels", "file": "blob.npz", "resolution": 0.1,
                     "deformability": 0.5, "sensitivity": float("nan")},
                    {"name": "box", "shape": "box", "size": [0.2, 0.2, 0.2], "position": [0.45, 0.45, 0.45],
                     "deformability": 0.0, "sensitivity": 1.0, "mass": 1.0}],
        "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "sphere", "radius": 0.01}]}},
        base_dir=tmp_path)
    for padding, static_only in ((0.0, False), (0.1, False), (0.0, True), (0.15, True)):
        fresh = VoxelGrid._build(scene, padding, static_only)
        VoxelGrid.from_scene(scene, padding, static_only)
        cache.forget()
        _same(_grid_arrays(fresh), _grid_arrays(VoxelGrid.from_scene(scene, padding, static_only)))
    assert cache.counts["built"] == 4


@pytest.mark.parametrize("count", [3, 126, 127, 140])
def test_a_grid_read_back_has_its_objects_materials_whatever_the_ids_type(cache_dir, count):
    """Up to 126 objects the cache keeps the ids as int8 and the materials are looked up by the ids' bytes; from 127
    on as int16, looked up by id + 1: both give the fresh build's arrays."""
    rng = np.random.default_rng(count)
    objects = [{"name": f"b{k}", "shape": "box", "size": [0.08, 0.08, 0.08],
                "position": [0.05 + 0.1 * (k % 12), 0.05 + 0.1 * (k // 12 % 12), 0.05 + 0.1 * (k // 144)],
                "deformability": float(rng.uniform(0.0, 1.0)), "sensitivity": float(rng.uniform(0.0, 5.0))}
               for k in range(count)]
    scene = Scene.from_dict({
        "name": "many", "start": [1.25, 1.25, 0.25], "goal": [1.25, 1.15, 0.25],
        "bounds": {"lower": [0, 0, 0], "upper": [1.3, 1.3, 0.3], "resolution": 0.05}, "objects": objects,
        "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "sphere", "radius": 0.01}]}})
    fresh = VoxelGrid._build(scene, 0.0, False)
    VoxelGrid.from_scene(scene)
    cache.forget()                                          # the next one is read from disk
    read = VoxelGrid.from_scene(scene)
    _same(_grid_arrays(fresh), _grid_arrays(read))
    assert set(np.unique(read.object_id)) == {-1, *range(count)}


def _moved(scene: Scene, index: int, offset) -> Scene:
    obj = scene.objects[index]
    pose = dataclasses.replace(obj.part.pose, position=obj.part.pose.position + np.asarray(offset))
    part = dataclasses.replace(obj.part, pose=pose)
    objects = list(scene.objects)
    objects[index] = dataclasses.replace(obj, part=part)
    return dataclasses.replace(scene, objects=objects)


def test_changed_content_misses(cache_dir):
    scene = load_scene("triple-wall")
    VoxelGrid.from_scene(scene)
    assert cache.counts["built"] == 1
    VoxelGrid.from_scene(load_scene("triple-wall"))       # loaded again: same content, a hit
    assert cache.counts["built"] == 1
    moved = _moved(scene, 0, [0.001, 0.0, 0.0])            # one object moved 1 mm
    VoxelGrid.from_scene(moved)
    assert cache.counts["built"] == 2
    assert np.array_equal(VoxelGrid.from_scene(moved).object_id, VoxelGrid._build(moved, 0.0, False).object_id)
    coarser = load_scene("triple-wall")
    coarser = dataclasses.replace(coarser, resolution=2 * coarser.resolution)   # resolution changed
    VoxelGrid.from_scene(coarser)
    assert cache.counts["built"] == 3
    VoxelGrid.from_scene(scene, padding=scene.resolution)  # another padding
    assert cache.counts["built"] == 4
    assert len(list((cache_dir / "voxelgrid").glob("*.npz"))) == 4


def test_keys_follow_content_not_identity():
    a, b = np.arange(6.0), np.arange(6.0)
    assert cache.fingerprint(a, {"x": 1, "y": [1.0, "s"]}) == cache.fingerprint(b, {"y": [1.0, "s"], "x": 1})
    distinct = [1, 1.0, "1", True, None, np.array([1]), np.array([1.0]), np.array([[1.0]]), (1,), [1.0, 2.0],
                [2.0, 1.0]]
    assert len({cache.fingerprint(v) for v in distinct}) == len(distinct)
    assert cache.fingerprint(0.0) == cache.fingerprint(-0.0)
    scene = load_scene("triple-wall")
    assert cache.fingerprint(scene.objects) == cache.fingerprint(load_scene("triple-wall").objects)
    assert cache.fingerprint(scene.objects) != cache.fingerprint(_moved(scene, 1, [0, 0, 1e-3]).objects)
    with pytest.raises(TypeError, match="cannot fingerprint"):
        cache.fingerprint(object())


def _build_counter():
    calls = []

    def build():
        calls.append(1)
        return {"a": np.arange(10.0), "b": np.eye(3, dtype=np.int8)}
    return build, calls


@pytest.mark.parametrize("damage", ["garbage", "truncated", "empty", "other key", "missing array"])
def test_a_damaged_or_mismatched_file_is_rebuilt(cache_dir, damage):
    build, calls = _build_counter()
    first = cache.cached_arrays("test", "v1", "inputs", build)
    (path,) = (cache_dir / "test").glob("*.npz")
    data = path.read_bytes()
    if damage == "garbage":
        path.write_bytes(b"not a zip file at all" * 10)
    elif damage == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "other key":
        np.savez(path, __pliant_cache_key__=np.array("0" * 64), a=np.zeros(3))
    else:
        np.savez(path, __pliant_cache_key__=np.array(path.stem), __pliant_cache_names__=np.array(["a", "b"]),
                 a=np.arange(10.0))                                  # the key, one of its two arrays
    cache.forget()
    again = cache.cached_arrays("test", "v1", "inputs", build)
    assert len(calls) == 2
    _same(first, again)
    cache.forget()
    _same(first, cache.cached_arrays("test", "v1", "inputs", build))   # the rebuilt file is whole
    assert len(calls) == 2


def test_results_are_copies_and_versions_separate(cache_dir):
    build, calls = _build_counter()
    a = cache.cached_arrays("test", "v1", 1, build)
    a["a"][:] = -1                                        # the caller's copy
    assert np.array_equal(cache.cached_arrays("test", "v1", 1, build)["a"], np.arange(10.0))
    cache.cached_arrays("test", "v2", 1, build)          # another algorithm version: built again
    assert len(calls) == 2
    with pytest.raises(TypeError, match="Python objects"):
        cache.cached_arrays("test", "v1", 2, lambda: {"x": np.array([object()])})
    from pliant.errors import ConfigError
    with pytest.raises(ConfigError):
        cache.cached_arrays("../escape", "v1", 1, build)


def test_the_environment_variables(tmp_path, monkeypatch):
    build, calls = _build_counter()
    monkeypatch.setenv("PLIANT_CACHE_DIR", str(tmp_path / "here"))
    monkeypatch.delenv("PLIANT_CACHE", raising=False)
    cache.forget()
    assert cache.cache_dir() == tmp_path / "here" and cache.enabled()
    cache.cached_arrays("test", "v1", "env", build)
    assert len(list((tmp_path / "here" / "test").glob("*.npz"))) == 1
    monkeypatch.delenv("PLIANT_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.cache_dir() == tmp_path / "xdg" / "pliant"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.cache_dir() == tmp_path / "home" / ".cache" / "pliant"
    monkeypatch.setenv("PLIANT_CACHE_DIR", str(tmp_path / "off"))
    for off in ("0", "false", "off"):
        monkeypatch.setenv("PLIANT_CACHE", off)
        assert not cache.enabled()
        cache.cached_arrays("test", "v1", "env", build)
    assert len(calls) == 4 and not (tmp_path / "off").exists()      # built every time, nothing written
    monkeypatch.setenv("PLIANT_CACHE", "1")
    monkeypatch.setenv("PLIANT_CACHE_DIR", str(tmp_path / "here"))
    assert cache.clear("test") == 1 and cache.clear() == 0
    cache.forget()


def test_the_directory_is_bounded(cache_dir, monkeypatch):
    foreign = cache_dir / "viewer" / "robot-0123.npz"           # another tool's file in the same directory
    foreign.parent.mkdir(parents=True)
    foreign.write_bytes(b"x" * 10_000)
    monkeypatch.setenv("PLIANT_CACHE_MAX_BYTES", "3000")
    for i in range(6):
        cache.cached_arrays("test", "v1", i, lambda: {"a": np.zeros(100)})   # about 1 kB each
    files = list((cache_dir / "test").glob("*.npz"))
    assert 1 <= len(files) <= 3 and sum(f.stat().st_size for f in files) <= 3000
    assert cache.clear() == len(files) and foreign.exists()          # neither pruned nor cleared


_WORKER = textwrap.dedent("""
    import sys, time
    import numpy as np
    from pliant import cache

    def build():
        time.sleep(0.3)
        return {"big": np.arange(2_000_000, dtype=np.float64), "tag": np.array([7])}

    out = cache.cached_arrays("concurrent", "v1", "one key", build)
    assert np.array_equal(out["big"], np.arange(2_000_000, dtype=np.float64))
    print(cache.counts["built"], cache.counts["disk"])
""")


def test_concurrent_writers_leave_one_whole_file(cache_dir):
    procs = [subprocess.Popen([sys.executable, "-c", _WORKER], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(3)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert all(p.returncode == 0 for p in procs), [err for _, err in outs]
    built = sum(int(out.split()[0]) for out, _ in outs)
    assert built == 1                                    # one build, the others waited and read it
    files = list((cache_dir / "concurrent").glob("*"))
    assert [f.suffix for f in files if f.suffix != ".lock"] == [".npz"]    # no temporary file left
    cache.forget()
    out = cache.cached_arrays("concurrent", "v1", "one key", lambda: pytest.fail("rebuilt"))
    assert np.array_equal(out["big"], np.arange(2_000_000, dtype=np.float64)) and out["tag"].tolist() == [7]


@pytest.mark.parametrize("name", ["triple-wall", "se2-maze", "hollow-cube"])
def test_the_validity_checkers_far_clearance_equals_a_fresh_build(cache_dir, scene_context, name):
    from pliant.planning.validity import ValidityChecker

    context = scene_context(name)
    checker = ValidityChecker(context.scene, context.robot)
    fresh = checker._far_clearance_build(checker._grids)
    assert np.array_equal(checker._far_clearance(checker._grids), fresh)        # built
    cache.forget()
    again = ValidityChecker(context.scene, context.robot)
    assert np.array_equal(again._far_clearance(again._grids), fresh)            # read
    assert cache.counts["disk"] >= 1


def test_the_memo_is_bounded(cache_dir, monkeypatch):
    monkeypatch.setattr(cache._memo, "max_bytes", 3000)
    for i in range(5):
        cache.cached_arrays("test", "v1", i, lambda: {"a": np.zeros(100)})     # 800 bytes each
    assert len(cache._memo) == 3
    monkeypatch.setattr(cache._memo, "max_bytes", 10)
    cache.cached_arrays("test", "v1", 99, lambda: {"a": np.zeros(100)})
    assert len(cache._memo) == 1                       # the newest stays, however large


def test_a_process_memo_builds_once_per_key_is_bounded_and_forgotten_with_the_cache(monkeypatch):
    from pliant.cache import ProcessMemo

    builds = []

    def build(k, size=10):
        builds.append(k)
        return {"a": np.zeros(size)}

    memo = ProcessMemo(entries=2, max_bytes=800)
    first = memo.get("x", lambda: build("x"))
    assert memo.get("x", lambda: build("x")) is first and builds == ["x"]           # the same object, built once
    memo.get("y", lambda: build("y"))
    memo.get("x", lambda: build("x"))                                               # x is now the most recent
    memo.get("z", lambda: build("z"))                                               # drops y, the least recent
    assert len(memo) == 2 and builds == ["x", "y", "z"]
    memo.get("x", lambda: build("x"))
    memo.get("y", lambda: build("y"))
    assert builds == ["x", "y", "z", "y"]
    memo.get("big", lambda: build("big", size=95))          # 760 bytes: with another 80 over the 800
    assert len(memo) == 1 and memo.nbytes() == 760
    cache.forget()                                          # emptied with the cache's own memo
    assert len(memo) == 0
    monkeypatch.setenv("PLIANT_CACHE", "0")                 # off: every call builds, nothing is kept
    memo.get("x", lambda: build("x"))
    memo.get("x", lambda: build("x"))
    assert builds[-2:] == ["x", "x"] and len(memo) == 0
    with pytest.raises(ConfigError, match="entries"):
        ProcessMemo(entries=0)
