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
