"""The kinematic simulator's contact tables come from the preprocessing cache (pliant.cache) equal to a fresh build."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import cache, load_scene
from pliant.geometry.voxelgrid import VoxelGrid
from pliant_kinematic.contact import ContactModel

TABLES = ("exposed", "occupied_flat", "free_clearance", "deep_normal", "deep_depth", "lower", "upper", "_shape")


@pytest.mark.parametrize(("name", "planar"), [("se2-maze", True), ("triple-wall", False), ("hollow-cube", False)])
def test_cached_contact_tables_equal_a_fresh_build(tmp_path, monkeypatch, name, planar):
    scene = load_scene(name)
    monkeypatch.setenv("PLIANT_CACHE", "0")
    fresh = ContactModel(VoxelGrid.from_scene(scene), planar=planar)
    monkeypatch.setenv("PLIANT_CACHE", "1")
    monkeypatch.setenv("PLIANT_CACHE_DIR", str(tmp_path))
    cache.forget()
    models = [ContactModel(VoxelGrid.from_scene(scene), planar=planar)]     # built
    models.append(ContactModel(VoxelGrid.from_scene(scene), planar=planar))  # memo
    cache.forget()
    models.append(ContactModel(VoxelGrid.from_scene(scene), planar=planar))  # file
    for model in models:
        assert model.planar == fresh.planar
        for attr in TABLES:
            a, b = getattr(fresh, attr), getattr(model, attr)
            assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b), attr
    assert len(list((tmp_path / "kinematic-contact").glob("*.npz"))) == 1
    cache.forget()


def test_models_of_one_occupancy_share_their_read_only_arrays_and_others_do_not(monkeypatch):
    """A metric's cells and a session's simulators over one scene build the per-voxel arrays once (the padded
    copies and the dense deep-voxel tables took about 0.16 s per model on se3-peg-tight)."""
    from pliant_kinematic import contact

    builds = []
    derive = contact._derive
    monkeypatch.setattr(contact, "_derive", lambda *a: builds.append(a) or derive(*a))
    cache.forget()
    grid = VoxelGrid.from_scene(load_scene("se2-maze"))
    a, b = ContactModel(grid, planar=True), ContactModel(VoxelGrid.from_scene(load_scene("se2-maze")), planar=True)
    assert len(builds) == 1
    for name in contact.SHARED:
        assert getattr(a, name) is getattr(b, name) and not getattr(a, name).flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        a.free_clearance[0] = 1.0
    c = ContactModel(grid, planar=False)                    # the z faces are walls: other bounds, its own arrays
    assert len(builds) == 2 and not np.array_equal(c.free_clearance, a.free_clearance)
    cache.forget()
