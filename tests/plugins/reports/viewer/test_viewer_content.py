"""The scene-to-viewer translation (no browser): voxel counts and colours per object, polylines equal to the path,
the policy tree, the Pareto front, run folders, and the viser scene graph the page receives."""

from __future__ import annotations

import json

import numpy as np
import pliant
import pytest
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.scene import Scene
from pliant_viewer import content, glb
from pliant_viewer.commands import resolve
from pliant_viewer.viewer import Viewer, build_content


def small_scene() -> Scene:
    """A 10 x 10 x 10 grid of 0.1 m voxels: a rigid 4 x 4 x 4 cube, a soft 2 x 3 x 1 slab and a forbidden voxel."""
    return Scene.from_dict({
        "name": "known", "start": [0.05, 0.05, 0.95], "goal": [0.95, 0.95, 0.95],
        "bounds": {"lower": [0, 0, 0], "upper": [1, 1, 1], "resolution": 0.1},
        "objects": [
            {"name": "cube", "cells": [[1, 5], [1, 5], [1, 5]], "deformability": 0.0, "sensitivity": 1.0},
            {"name": "slab", "cells": [[6, 8], [6, 9], [0, 1]], "deformability": 1.0, "sensitivity": 0.2},
            {"name": "forbidden", "cells": [[9, 10], [0, 1], [0, 1]], "deformability": 0.0,
             "sensitivity": float("nan")},
        ],
        "robot": {"kind": "rigid", "name": "dot", "space": "r3", "deformability": 0.0, "sensitivity": 1.0,
                  "parts": [{"cells": [[0, 1], [0, 1], [0, 1]]}]},
    })


def test_material_colours_known_answers():
    rgb = content.material_colours(np.array([0.0, 1.0, 0.5, np.nan, 0.3]), np.array([1.0, 0.0, 1.0, 1.0, np.nan]))
    assert rgb.dtype == np.uint8
    np.testing.assert_array_equal(rgb[0], content.RIGID)
    np.testing.assert_array_equal(rgb[1], content.SOFT)
    np.testing.assert_array_equal(rgb[2], np.rint((content.RIGID + content.SOFT) / 2))
    np.testing.assert_array_equal(rgb[3], content.FORBIDDEN)
    np.testing.assert_array_equal(rgb[4], content.FORBIDDEN)


def test_voxel_objects_counts_and_colours():
    grid = VoxelGrid.from_scene(small_scene())
    objects = {o.name: o for o in content.voxel_objects(grid)}
    assert list(objects) == ["cube", "slab", "forbidden"]
    assert objects["cube"].total == 64 and len(objects["cube"].centres) == 64 - 8      # a 2x2x2 core is hidden
    assert objects["slab"].total == 6 and len(objects["slab"].centres) == 6
    assert objects["forbidden"].total == 1
    np.testing.assert_array_equal(objects["cube"].colours, np.tile(content.RIGID, (56, 1)))
    np.testing.assert_array_equal(objects["slab"].colours, np.tile(content.SOFT, (6, 1)))
    np.testing.assert_array_equal(objects["forbidden"].colours, [content.FORBIDDEN])
    # the slab's voxel centres, exactly
    expected = {(x + 0.05, y + 0.05, 0.05) for x in (0.6, 0.7) for y in (0.6, 0.7, 0.8)}
    assert {tuple(np.round(c, 9)) for c in objects["slab"].centres} == {tuple(np.round(e, 9)) for e in expected}
    full = {o.name: o for o in content.voxel_objects(grid, surface_only=False)}
    assert len(full["cube"].centres) == 64


def _area(obj) -> float:
    tri = obj.vertices[obj.faces]
    return float(np.sum(np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)) / 2)


def test_voxel_meshes_are_the_exposed_faces_merged_into_strips():
    objects = {o.name: o for o in content.voxel_objects(VoxelGrid.from_scene(small_scene()))}
    cube, slab = objects["cube"], objects["slab"]
    assert _area(cube) == pytest.approx(6 * 0.4 * 0.4)
    assert _area(slab) == pytest.approx(2 * (0.2 * 0.3 + 0.2 * 0.1 + 0.3 * 0.1))
    assert len(cube.faces) == 2 * 6 * 4                 # each 4 x 4 side: four strips of four faces
    np.testing.assert_allclose(cube.vertices.min(axis=0), [0.1, 0.1, 0.1])
    np.testing.assert_allclose(cube.vertices.max(axis=0), [0.5, 0.5, 0.5])
    np.testing.assert_array_equal(np.unique(cube.vertex_colours, axis=0), [content.RIGID])


def test_tracer_places_free_flyers_at_their_translation():
    q = np.array([[0.1, 0.2, 0.3, 0, 0, 0, 1], [0.4, 0.5, 0.6, 0, 0, 0, 1]])
    np.testing.assert_array_equal(content.Tracer("se3").points(q), q[:, :3])
    np.testing.assert_array_equal(content.Tracer("se2", z=0.5).points(q[:, :3]), [[0.1, 0.2, 0.5], [0.4, 0.5, 0.5]])


def test_policy_tree_from_json():
    policy = {"nodes": [
        {"particles": [[0, 0, 0], [0.2, 0, 0]], "parent": None, "expected": [0.1, 0, 0], "path_probability": 1.0},
        {"particles": [[1, 1, 1]], "parent": 0, "expected": None, "path_probability": 0.25},
        {"particles": [], "parent": 1, "expected": [2, 2, 2], "path_probability": 0.0}],
        "actions": [{"target": [1, 1, 1]}, {"target": [2, 2, 2]}], "solutions": [[0, 1, 2]]}
    tree = content.policy_tree(policy, content.Tracer("r3"))
    np.testing.assert_allclose(tree.nodes, [[0.1, 0, 0], [1, 1, 1], [2, 2, 2]])
    np.testing.assert_array_equal(tree.edges, [[0, 1], [1, 2]])
    np.testing.assert_array_equal(tree.particle_node, [0, 0, 1])
    np.testing.assert_allclose(tree.action_targets, [[1, 1, 1], [2, 2, 2]])
    np.testing.assert_array_equal(tree.solution_nodes, [0, 1, 2])
    colours = content.probability_colours(tree.probability)
    assert colours[0, 1] > colours[0, 0] and colours[2, 0] > colours[2, 1]       # green at 1, red at 0


def test_pareto_paths_are_world_positions_of_cells():
    stats = {"pareto": [{"p_values": [0.1], "length_voxels": 3.0, "deformation": 2.5}],
             "pareto_paths": [[[0, 0, 0], [1, 0, 0], [1, 1, 0]]]}
    (front,) = content.pareto_paths(stats, np.array([1.0, 2.0, 3.0]), 0.5)
    np.testing.assert_allclose(front["points"], [[1.25, 2.25, 3.25], [1.75, 2.25, 3.25], [1.75, 2.75, 3.25]])


@pytest.fixture
def viewer():
    v = Viewer(host="127.0.0.1")
    yield v
    v.stop()


def test_viewer_scene_graph_of_a_run(tmp_path, viewer):
    """A scene with a planned path and an execution: the nodes sent to the page, the polyline equal to the path,
    and the time slider moving the robot."""
    scene = small_scene()
    path = np.array([[0.05, 0.05, 0.95], [0.5, 0.5, 0.95], [0.95, 0.95, 0.95]])
    times = np.array([0.0, 0.5, 1.0, 1.5])
    executed = np.array([[0.05, 0.05, 0.95], [0.3, 0.3, 0.95], [0.6, 0.6, 0.95], [0.9, 0.9, 0.95]])
    (tmp_path / "run.json").write_text(json.dumps({"pipeline": {"name": "t", "scene": "known.toml"}}))
    (tmp_path / "result.json").write_text(json.dumps({"status": "solved", "planner": "x", "statistics": {},
                                                      "path": {"configurations": path.tolist()}}))
    (tmp_path / "execution.json").write_text(json.dumps({"times": times.tolist(), "outcome": "success",
                                                         "configurations": executed.tolist(), "world": "w"}))
    view = build_content(scene, run=content.read_run(tmp_path))
    viewer.show(view)
    for name in ("/scene/objects/cube", "/scene/objects/slab", "/scene/objects/forbidden", "/scene/start",
                 "/scene/goal", "/robot", "/path/planned", "/path/executed", "/path/now"):
        assert name in viewer.nodes, name
    cube = viewer.nodes["/scene/objects/cube"]
    assert len(cube.faces) == 48 and tuple(cube.color) == tuple(content.RIGID)
    segments = np.asarray(viewer.nodes["/path/planned"].points)
    np.testing.assert_allclose(segments[:, 0], path[:-1], atol=1e-6)
    np.testing.assert_allclose(segments[:, 1], path[1:], atol=1e-6)
    segments = np.asarray(viewer.nodes["/path/executed"].points)
    np.testing.assert_allclose(np.vstack([segments[:, 0], segments[-1:, 1]]), executed, atol=1e-6)
    assert viewer.slider is not None and viewer.slider.max == pytest.approx(1.5)
    viewer.slider.value = 1.0                    # the server-side slider drives the robot like a page's would
    viewer.set_time(1.0)
    np.testing.assert_allclose(viewer.nodes["/path/now"].position, executed[2], atol=1e-6)
    np.testing.assert_allclose(viewer.robot_drawing.frame.position, executed[2], atol=1e-6)


def test_live_steps_move_the_robot(viewer):
    from pliant.execution.loop import ExecutionStep

    scene = small_scene()
    viewer.show(build_content(scene))
    for i, q in enumerate(np.linspace([0.05, 0.05, 0.95], [0.5, 0.5, 0.95], 5)):
        viewer._live_sent = 0.0              # do not throttle in the test (each step is sent at once)
        viewer.on_step(ExecutionStep(0.1 * i, q, np.zeros(3), q, False, {}))
    np.testing.assert_allclose(viewer.robot_drawing.frame.position, [0.5, 0.5, 0.95], atol=1e-6)
    assert viewer.live_steps == 5 and "/path/live" in viewer.nodes


def test_resolve_targets(tmp_path):
    scene, run, policy = resolve("triple-wall", None)
    assert scene.name == "triple-wall" and run is None and policy is None
    (tmp_path / "run.json").write_text(json.dumps({"pipeline": {"scene": "triple-wall"}}))
    (tmp_path / "policy.json").write_text(json.dumps({"nodes": [], "actions": []}))
    scene, run, policy = resolve(str(tmp_path / "policy.json"), None)
    assert scene.name == "triple-wall" and policy == {"nodes": [], "actions": []}
    scene, run, policy = resolve(str(tmp_path), None)
    assert run.scene_name == "triple-wall"
    with pytest.raises(pliant.errors.PliantError):
        resolve(str(tmp_path / "policy.json").replace("policy", "nothing"), None)
    # a run of a scene variant (`--set scene.variant=...`: run.json holds {name, variant})
    (tmp_path / "run.json").write_text(json.dumps({"pipeline": {"scene": {"name": "se2-maze",
                                                                          "variant": "blocked"}}}))
    scene, run, policy = resolve(str(tmp_path), None)
    assert (scene.name, scene.variant) == ("se2-maze", "blocked") and run.scene_name == "se2-maze"


def test_view_command_exports_html(tmp_path):
    from pliant.cli import main

    out = tmp_path / "view.html"
    assert main(["view", "triple-wall", "--export", str(out)]) == 0
    text = out.read_text()
    assert "__VISER_EMBED_DATA__" in text and "http://" not in text.replace("http://www.w3.org", "")
    assert "pliant viewer (see pliant_viewer/page.py): on a software WebGL renderer" in text     # pliant_viewer.page


def test_run_with_view_streams_the_execution(tmp_path, capsys):
    """``pliant run maze-slide --view``: the page is served on loopback, every step streams through the execution
    hook, then the finished run is shown (here for 0 s)."""
    import re

    from pliant.cli import main

    assert main(["run", "maze-slide", "--output", str(tmp_path / "run"), "--view", "--view-hold", "0"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"viewer: http://127\.0\.0\.1:\d+/  \(live", out)
    steps = int(re.search(r"the finished run; (\d+) steps streamed live", out).group(1))
    execution = json.loads((tmp_path / "run" / "execution.json").read_text())
    assert steps == len(execution["times"]) - 1 > 10           # every step after the initial state


def test_cache_round_trip_for_an_arm(tmp_path, viewer):
    """A baxter-reach run folder: the cached view equals the built one, draws without a robot model, and goes stale
    when the run's files change."""
    import os

    from pliant_viewer import cache

    scene = pliant.load_scene("baxter-reach")
    path = np.linspace(scene.start, scene.goal, 4)
    (tmp_path / "run.json").write_text(json.dumps({"pipeline": {"name": "b", "scene": "baxter-reach"}}))
    (tmp_path / "result.json").write_text(json.dumps({"status": "solved", "planner": "x", "statistics": {},
                                                      "path": {"configurations": path.tolist()}}))
    (tmp_path / "execution.json").write_text(json.dumps({"times": [0.0, 1.0, 2.0, 3.0], "outcome": "success",
                                                         "configurations": path.tolist(), "world": "w"}))
    built = build_content(scene, run=content.read_run(tmp_path))
    assert built.articulated and built.urdf is not None
    assert cache.save(built, tmp_path) == tmp_path / cache.NAME
    cached = cache.load(tmp_path, scene)
    assert cached is not None and cached.robot is None and cached.tracer is None
    for name in ("ends", "path", "path_xyz", "timeline_xyz"):
        np.testing.assert_array_equal(getattr(cached, name), getattr(built, name))
    np.testing.assert_array_equal(cached.trajectory.times, built.trajectory.times)
    for a, b in zip(cached.objects, built.objects):
        assert a.name == b.name and a.total == b.total
        np.testing.assert_array_equal(a.faces, b.faces)
        np.testing.assert_array_equal(a.vertex_colours, b.vertex_colours)
    assert cached.urdf.joint_names == built.urdf.joint_names and cached.urdf.posture == built.urdf.posture
    viewer.show(cached)
    viewer.set_time(3.0)
    np.testing.assert_allclose(viewer.nodes["/path/now"].position, built.timeline_xyz[-1], atol=1e-6)
    assert viewer.robot_drawing.ready.wait(60) and viewer.robot_drawing.error is None
    st = (tmp_path / "result.json").stat()
    os.utime(tmp_path / "result.json", ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    assert cache.load(tmp_path, scene) is None


def _edges(handle) -> np.ndarray:
    """The segments ``(n, 2, 3)`` of a tree's edges as sent: WebGL lines in a GLB, or viser's line segments."""
    if hasattr(handle, "glb_data"):
        return glb.read_lines(handle.glb_data)[0]
    return np.asarray(handle.points, dtype=np.float64)


def test_large_trees_drawn_from_their_first_nodes_and_solutions(monkeypatch):
    """Beyond ``tree_limit`` nodes: the first ones and every solution's; the "whole tree" switch draws all.  Edges
    of a tree beyond ``GLB_EDGES`` go as WebGL lines (a GLB), of a smaller one as line segments."""
    from pliant_viewer import viewer as viewer_module

    chain = [{"particles": [[i, 0, 0]], "parent": i - 1 if i else None, "expected": [i, 0, 0],
              "path_probability": 0.5} for i in range(10)]
    policy = {"nodes": chain, "actions": [], "solutions": [[0, 1, 2, 8, 9]]}
    scene = small_scene()
    viewer = Viewer(tree_limit=4)
    try:
        viewer.show(build_content(scene, policy=policy))
        assert viewer.tree_drawn == 6                                        # nodes 0-3, and 8 and 9
        np.testing.assert_allclose(np.asarray(viewer.nodes["/policy/nodes"].points)[:, 0], [0, 1, 2, 3, 8, 9])
        assert not hasattr(viewer.nodes["/policy/edges"], "glb_data")      # 4 edges: line segments
        np.testing.assert_allclose(_edges(viewer.nodes["/policy/edges"])[:, :, 0], [[0, 1], [1, 2], [2, 3], [8, 9]],
                                   atol=1e-6)
        assert "6 nodes drawn" in viewer.summary.content
        monkeypatch.setattr(viewer_module, "GLB_EDGES", 5)
        viewer._whole_tree(type("Event", (), {"target": type("Box", (), {"value": True})()})())
        edges, colour = glb.read_lines(viewer.nodes["/policy/edges"].glb_data)    # 9 edges: WebGL lines (a GLB)
        assert viewer.tree_drawn == 10 and len(edges) == 9
        np.testing.assert_allclose(edges[:, :, 0], np.stack([np.arange(9), np.arange(1, 10)], axis=1), atol=1e-6)
        np.testing.assert_allclose(colour, content.TREE_COLOUR, atol=1e-6)
        assert "10 nodes, 10 particles" in viewer.summary.content and "nodes drawn" not in viewer.summary.content
    finally:
        viewer.stop()


def test_pipeline_run_writes_the_view_cache(tmp_path, monkeypatch):
    """``pliant run`` of an arm writes ``view-cache.npz`` beside the run (the viewer's report hook): it is what
    ``pliant view`` of the folder would build, it is fresh for that view, and the robot's meshes are converted
    into the user's cache; a rigid robot's run gets none."""
    from pliant.pipeline import Pipeline
    from pliant_viewer import cache, robot_mesh
    from pliant_viewer.commands import resolve

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user-cache"))
    out = tmp_path / "arm"
    record = Pipeline("baxter-reach", planner="straight", output=out).run()
    assert out / cache.NAME in record.files
    assert cache.NAME not in (out / "report.md").read_text()              # not listed as a figure
    scene, run, policy = resolve(str(out), None)
    cached = cache.load(out, scene)
    assert cached is not None and cached.robot is None
    built = build_content(scene, run=run, policy=policy)
    # the straight line crosses the wall: the run is infeasible and has no path (issue 31, "valid means valid"),
    # so the cache must hold none either; test_cache_round_trip_for_an_arm compares a path
    assert record.result.path is None and cached.path is None and cached.path_xyz is None
    np.testing.assert_allclose(cached.ends, built.ends, atol=1e-12)
    assert [o.name for o in cached.objects] == [o.name for o in built.objects]
    assert (robot_mesh.cache_dir() / f"robot-{robot_mesh.key(built.urdf, 'collision')}.npz").is_file()

    rigid = tmp_path / "rigid"
    record = Pipeline("triple-wall", planner="straight", output=rigid).run()
    assert (rigid / "run.json").is_file() and not (rigid / cache.NAME).exists()


def test_voxel_faces_look_out_of_their_object():
    """Every merged face is wound counter-clockwise seen from outside: its normal points from the object's voxel
    behind it to the free voxel in front of it (the page draws front faces only)."""
    scene = small_scene()
    grid = VoxelGrid.from_scene(scene)
    for obj in content.voxel_objects(grid):
        tri = obj.vertices[obj.faces]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        centre = tri.mean(axis=1)
        step = 0.25 * grid.resolution
        ahead = np.floor((centre + step * normal - grid.lower) / grid.resolution).astype(int)
        behind = np.floor((centre - step * normal - grid.lower) / grid.resolution).astype(int)
        k = grid.object_names.index(obj.name)
        assert np.all(grid.object_id[tuple(behind.T)] == k), obj.name
        inside = np.all((ahead >= 0) & (ahead < grid.object_id.shape), axis=1)
        assert np.all(grid.object_id[tuple(ahead[inside].T)] != k), obj.name


def test_drawn_quads_overlap_their_neighbours_in_their_plane():
    """The page draws each merged face grown by a fraction of a voxel in its own plane (closing the cracks of
    T-junctions): a unit square at z = 2 grown by 0.01 stays at z = 2 and spans -0.01 .. 1.01."""
    from pliant_viewer.viewer import _widen_quads

    square = np.array([[0, 0, 2], [1, 0, 2], [1, 1, 2], [0, 1, 2]], dtype=np.float64)
    grown = _widen_quads(np.vstack([square, square + [5, 0, 0]]), 0.01)
    np.testing.assert_allclose(grown[:4], [[-0.01, -0.01, 2], [1.01, -0.01, 2], [1.01, 1.01, 2], [-0.01, 1.01, 2]])
    np.testing.assert_allclose(grown[4:], grown[:4] + [5, 0, 0])


def test_the_served_page_is_vipers_with_the_software_webgl_script(tmp_path, monkeypatch):
    """The viewer serves viser's page with its script first in the head (before viser's own script), written once
    into the user's cache; viser's page itself is unchanged."""
    import urllib.request
    from pathlib import Path

    import viser
    from pliant_viewer import page

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    original = (Path(viser.__file__).parent / "client" / "build" / "index.html").read_text(encoding="utf-8")
    patched = page.patch(original)
    head = original.index("<head>") + len("<head>")
    assert head < original.index("<script") and page.SOFTWARE_WEBGL not in original
    assert patched.index(page.SOFTWARE_WEBGL) == head                      # before any script of viser's
    assert patched.replace(page.SOFTWARE_WEBGL, "") == original
    root = page.client_root()
    assert root.parent == tmp_path / "pliant" / "viewer" and (root / "index.html").read_text() == patched
    v = Viewer()
    try:
        assert v.page_patched
        served = urllib.request.urlopen(v.url, timeout=30).read().decode("utf-8")
        assert served == patched
    finally:
        v.stop()


def test_lines_glb_is_a_valid_gltf_of_one_lines_primitive():
    """The tree's edges go to the page as a GLB (glTF 2.0, binary) of one LINES primitive: header and chunks as the
    glTF spec lays them out (4-byte aligned, lengths adding up), positions and the colour read back."""
    import struct

    rng = np.random.default_rng(3)
    segments = rng.uniform(-1, 1, (7, 2, 3))
    data = glb.lines(segments, (150, 150, 150))
    magic, version, length = struct.unpack_from("<III", data, 0)
    assert (magic, version, length) == (0x46546C67, 2, len(data)) and len(data) % 4 == 0
    json_length, json_kind = struct.unpack_from("<II", data, 12)
    assert json_kind == 0x4E4F534A and json_length % 4 == 0
    doc = json.loads(data[20:20 + json_length])
    (primitive,) = doc["meshes"][0]["primitives"]
    assert primitive["mode"] == 1 and "indices" not in primitive                 # gl.LINES, one drawArrays
    accessor = doc["accessors"][primitive["attributes"]["POSITION"]]
    assert accessor["count"] == 14 and accessor["type"] == "VEC3" and accessor["componentType"] == 5126
    np.testing.assert_allclose(accessor["min"], segments.reshape(-1, 3).min(axis=0), atol=1e-6)
    np.testing.assert_allclose(accessor["max"], segments.reshape(-1, 3).max(axis=0), atol=1e-6)
    bin_length, bin_kind = struct.unpack_from("<II", data, 20 + json_length)
    assert bin_kind == 0x004E4942 and bin_length == 14 * 12
    back, colour = glb.read_lines(data)
    np.testing.assert_allclose(back, segments, atol=1e-6)
    np.testing.assert_allclose(colour, (150, 150, 150), atol=1e-6)
    # glTF colours are linear: 150 in sRGB is 0.305 linear
    assert doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"][0] == pytest.approx(0.3050, abs=1e-4)


def test_particles_are_sent_in_an_order_whose_prefixes_sample_the_tree():
    """The page may draw only the first points of the particle cloud while the camera moves (pliant_viewer.page):
    the cloud holds every particle of the drawn nodes, shuffled, so its first tenth already spans most nodes."""
    rng = np.random.default_rng(1)
    nodes = [{"particles": (rng.uniform(0, 1, 3) + rng.normal(0, 0.01, (10, 3))).tolist(),
              "parent": i - 1 if i else None, "path_probability": 0.5} for i in range(200)]
    scene = small_scene()
    view = build_content(scene, policy={"nodes": nodes, "actions": [], "solutions": []})
    viewer = Viewer()
    try:
        viewer.show(view)
        cloud = np.asarray(viewer.nodes["/policy/particles"].points)          # viser keeps them as float16
        tree = view.tree
        sent = tree.particles.astype(np.float32).astype(cloud.dtype)
        assert sorted(p.tobytes() for p in cloud) == sorted(p.tobytes() for p in sent)   # the same points
        owner = {p.tobytes(): n for p, n in zip(sent, tree.particle_node)}
        first = [owner[p.tobytes()] for p in cloud[: len(cloud) // 10]]
        assert len(set(first)) > 100                        # 200 particles from more than half of the 200 nodes
    finally:
        viewer.stop()


def _run_folder(tmp_path, scene_name: str = "triple-wall"):
    """A run folder as `pliant run` leaves it (run.json, result.json, execution.json) for the scene's start and goal."""
    scene = pliant.load_scene(scene_name)
    path = np.stack([scene.start, (scene.start + scene.goal) / 2, scene.goal]).tolist()
    folder = tmp_path / "run"
    folder.mkdir(parents=True)
    (folder / "run.json").write_text(json.dumps({"pipeline": {"scene": scene_name, "robot": "rigid"}}, indent=1))
    (folder / "result.json").write_text(json.dumps({"status": "solved", "planner": "straight",
                                                    "path": {"configurations": path}, "statistics": {}}, indent=1))
    (folder / "execution.json").write_text(json.dumps({"times": [0.0, 1.0, 2.0], "configurations": path,
                                                       "outcome": "reached", "world": "kinematic"}, indent=1))
    return folder


@pytest.mark.parametrize("name", ["run.json", "result.json", "execution.json"])
def test_a_run_file_cut_off_anywhere_is_an_error_naming_it(tmp_path, name):
    folder = _run_folder(tmp_path)
    text = (folder / name).read_text()
    assert content.read_run(folder).path.shape == (3, 3)
    for cut in range(0, len(text) - 1, max(1, len(text) // 7)):
        (folder / name).write_text(text[:cut])
        with pytest.raises(pliant.errors.ConfigError, match="cut off") as caught:
            content.read_run(folder)
        assert str(caught.value).startswith(str(folder / name) + ":line ")


@pytest.mark.parametrize("name, change, field", [
    ("run.json", lambda d: {"pipeline": [1]}, "pipeline"),
    ("run.json", lambda d: {"pipeline": {"scene": 5}}, "pipeline.scene"),
    ("run.json", lambda d: {"pipeline": {"scene": "triple-wall", "robot": 3}}, "pipeline.robot"),
    ("run.json", lambda d: [d], "<top level>"),
    ("result.json", lambda d: {**d, "path": "x"}, "path"),
    ("result.json", lambda d: {**d, "path": {"configurations": [[1, 2, 3], [4]]}}, "path.configurations"),
    ("result.json", lambda d: {**d, "path": {"configurations": [[1, 2, None]]}}, "path.configurations"),
    ("result.json", lambda d: {**d, "path": {"configurations": [1, 2, 3]}}, "path.configurations"),
    ("result.json", lambda d: {**d, "policy": {"nodes": [5]}}, "policy.nodes[0]"),
    ("result.json", lambda d: {**d, "policy": {"nodes": [{"expected": [0, 0, 0], "parent": "root"}]}},
     "policy.nodes[0].parent"),
    ("result.json", lambda d: {**d, "policy": {"nodes": [{"parent": None}]}}, "policy.nodes[0]"),
    ("result.json", lambda d: {**d, "statistics": []}, "statistics"),
    ("execution.json", lambda d: {**d, "times": [0.0, 1.0]}, "times"),
    ("execution.json", lambda d: {**d, "times": "soon"}, "times"),
])
def test_run_files_of_the_wrong_form_are_an_error_naming_file_and_field(tmp_path, name, change, field):
    folder = _run_folder(tmp_path)
    data = json.loads((folder / name).read_text())
    (folder / name).write_text(json.dumps(change(data)))
    with pytest.raises(pliant.errors.ConfigError) as caught:
        content.read_run(folder)
    assert str(caught.value).startswith(f"{folder / name}:{field}:")


def test_a_run_of_another_dimension_is_refused_naming_the_field(tmp_path):
    folder = _run_folder(tmp_path)
    (folder / "result.json").write_text(json.dumps({"status": "solved", "path": {"configurations": [[0, 0, 0, 1]]}}))
    run = content.read_run(folder)
    with pytest.raises(pliant.errors.ConfigError, match=r"result.json:path.configurations: holds configurations of "
                                                        r"4 coordinates; the scene's robot has 3"):
        content.check_dimension(run, None, 3, "policy.json")
    with pytest.raises(pliant.errors.ConfigError, match=r"policy.json:nodes\[0\].expected"):
        content.check_dimension(None, {"nodes": [{"expected": [0.0, 1.0]}]}, 3, "policy.json")
    content.check_dimension(content.read_run(_run_folder(tmp_path / "b")), None, 3, "-")


def test_page_addresses_the_server_cannot_serve_on_are_refused_at_once():
    import socket

    from pliant_viewer.commands import check_address, check_hold

    for port in (-1, 65536, 70000, True):
        with pytest.raises(pliant.errors.ConfigError, match=f"--port: .*{port!r}"):
            check_address("127.0.0.1", port)
    for host, why in (("999.1.1.1", "is not an IPv4 address"), ("", "must name"),
                      ("203.0.113.7", "is not an address of this machine")):           # TEST-NET-3: bound, never sent
        with pytest.raises(pliant.errors.ConfigError, match=f"--view-host: {why}"):
            check_address(host, 0, "view-")
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        with pytest.raises(pliant.errors.ConfigError, match=f"--port: is in use .*{port}"):
            check_address("127.0.0.1", port)
    check_address("127.0.0.1", 0)
    for hold in (-5.0, float("nan")):
        with pytest.raises(pliant.errors.ConfigError, match="--hold"):
            check_hold(hold)
    check_hold(None), check_hold(0.0), check_hold(float("inf"))


def test_an_export_to_a_directory_a_device_or_below_a_file_is_refused(tmp_path):
    from pliant_viewer.commands import MAX_FRAMES, check_export

    (tmp_path / "file").write_text("x")
    for target, why in ((str(tmp_path), "is a directory"), ("", "must name"), ("/dev/null", "is not a regular file"),
                        (str(tmp_path / "file" / "v.html"), "cannot be written: .* is not a directory")):
        with pytest.raises(pliant.errors.ConfigError, match=f"--export: {why}"):
            check_export(target, 60)
    for frames in (0, 1, -3, MAX_FRAMES + 1):
        with pytest.raises(pliant.errors.ConfigError, match=f"--frames: .*{frames}"):
            check_export(str(tmp_path / "v.html"), frames)
    assert check_export(str(tmp_path / "new" / "v.html"), 2) == tmp_path / "new" / "v.html"


def test_the_viewer_reports_the_port_it_serves_on():
    """viser moves to the next port when one is taken; the page's address is the port actually bound."""
    import socket

    v = Viewer(host="127.0.0.1")
    try:
        with socket.socket() as s:
            with pytest.raises(OSError):
                s.bind(("127.0.0.1", v.port))
        assert v.port == v.server.get_port() and v.url == f"http://127.0.0.1:{v.port}/"
    finally:
        v.stop()
