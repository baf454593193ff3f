"""The viewer's URDF robot: merged meshes and its own forward kinematics against yourdfpy's, the disk cache, and
what a pose update sends."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pliant
import pytest
from pliant_viewer import content, robot_mesh
from pliant_viewer.viewer import Viewer, build_content, make_robot


@pytest.fixture(scope="module")
def baxter():
    scene = pliant.load_scene("baxter-reach")
    return scene, make_robot(scene).urdf_description()


def test_groups_follow_yourdfpy_kinematics(baxter):
    """Every group's frame equals yourdfpy's transform of its joint's child link at random configurations, and the
    merged meshes hold the collision geometry (spheres lighter)."""
    import yourdfpy

    _, description = baxter
    meshes = robot_mesh.convert(description)
    assert meshes.names == ["base", *description.joint_names]          # the planned joints, parents first
    assert 10_000 < meshes.triangles < 18_955 and len(meshes.meshes) == len(meshes.names)
    urdf = yourdfpy.URDF.load(str(description.urdf), build_scene_graph=False, load_meshes=False,
                              build_collision_scene_graph=True, load_collision_meshes=False)
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = rng.uniform(-1.0, 1.0, len(description.joint_names))
        cfg = np.array([q[description.joint_names.index(n)] if n in description.joint_names
                        else description.posture.get(n, 0.0) for n in urdf.actuated_joint_names])
        urdf.update_cfg(cfg)
        poses = meshes.poses(q)
        for g, name in enumerate(meshes.names[1:], start=1):
            expected = urdf.get_transform(urdf.joint_map[name].child, urdf.base_link, collision_geometry=True)
            np.testing.assert_allclose(poses[g], expected, atol=1e-9)


def test_disk_cache_round_trip(baxter, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    _, description = baxter
    first = robot_mesh.load_or_convert(description)
    files = list((tmp_path / "pliant" / "viewer").glob("robot-*.npz"))
    assert len(files) == 1
    again = robot_mesh.load_or_convert(description)
    assert again.names == first.names and again.kind == first.kind
    np.testing.assert_array_equal(again.origin, first.origin)
    for a, b in zip(again.meshes, first.meshes):
        assert a[0] == b[0] and a[3] == b[3]
        np.testing.assert_array_equal(a[1], b[1])
        np.testing.assert_array_equal(a[2], b[2])
    other = robot_mesh.key(description, "visual")
    assert other != robot_mesh.key(description, "collision")


def test_a_pose_update_moves_only_the_groups_that_moved(baxter, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    scene, _ = baxter
    viewer = Viewer()
    try:
        viewer.show(build_content(scene))
        drawing = viewer.robot_drawing
        assert drawing.ready.wait(120) and drawing.error is None
        q = np.array(scene.start, dtype=np.float64)
        q[-1] += 0.5                                   # the last wrist joint only
        before = [np.array(f.position) for f in drawing.group_frames]
        drawing.set(q)
        after = [np.array(f.position) for f in drawing.group_frames]
        np.testing.assert_allclose(after[:-1], before[:-1])
        from pliant.geometry.rotations import quat_to_matrix

        w, x, y, z = drawing.group_frames[-1].wxyz
        np.testing.assert_allclose(quat_to_matrix(np.array([x, y, z, w])), drawing.urdf.poses(q)[-1][:3, :3],
                                   atol=1e-9)
    finally:
        viewer.stop()


def test_objects_of_many_materials_are_one_mesh_per_colour():
    """A voxel object with two materials: two meshes, which together are the object's exposed faces."""
    code = np.full((4, 1, 1), -1)
    code[:2], code[2:] = 0, 1
    vertices, faces, quad_codes = content.exposed_faces(code, np.zeros(3), 1.0)
    palette = np.array([[10, 20, 30], [200, 100, 50]], dtype=np.uint8)
    obj = content.VoxelObject("two", np.zeros((4, 3)), palette[[0, 0, 1, 1]], 4, 0.5, 1.0, vertices, faces,
                              np.repeat(palette[quad_codes], 4, axis=0))
    viewer = Viewer()
    try:
        viewer._voxel_mesh("/scene/objects/two", obj, 1.0)
        parts = [h for name, h in viewer.server.scene._handle_from_node_name.items()
                 if name.startswith("/scene/objects/two/")]
        assert len(parts) == 2
        assert sum(len(p.faces) for p in parts) == len(faces)
        assert {tuple(p.color) for p in parts} == {tuple(c) for c in palette}
    finally:
        viewer.stop()


def test_resolve_file_finds_the_urdfs_meshes(baxter):
    import re

    _, description = baxter
    names = set(re.findall(r'filename\s*=\s*"([^"]+)"', Path(description.urdf).read_text()))
    assert names
    for name in names:
        found = robot_mesh.resolve_file(name, Path(description.urdf), description.package_dirs)
        assert found is not None and found.is_file(), name


@pytest.mark.slow
def test_visual_meshes_keep_their_colours(baxter):
    """``--robot-meshes visual``: Baxter's detailed meshes, merged per group and colour."""
    _, description = baxter
    meshes = robot_mesh.convert(description, "visual")
    assert meshes.names == ["base", *description.joint_names]
    assert meshes.triangles > 300_000
    assert len({colour for _, _, _, colour in meshes.meshes}) > 1
    for _, v, f, _ in meshes.meshes:
        assert f.max() < len(v)
