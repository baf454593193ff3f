"""Malformed scenes and pipelines: only PliantError may come out, and it names the field.

Property-based: hypothesis mutates a valid scene (and a valid pipeline) at a random field — deleting
it, replacing it with junk of any type, NaN or infinity, or adding an unknown field — at least 250
times each.  Targeted cases check that the message names ``file:field`` and the value.
"""

from __future__ import annotations

import copy
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pliant.errors import PipelineError, PliantError, SceneError
from pliant.pipeline import Pipeline
from pliant.scene import Scene

VALID_SCENE = {
    "name": "valid", "description": "a valid scene",
    "start": [0.1, 0.1, 0.1], "goal": [0.9, 0.9, 0.1], "goal_tolerance": 0.01, "planar": False,
    "bounds": {"lower": [0.0, 0.0, 0.0], "upper": [1.0, 1.0, 0.2], "resolution": 0.05},
    "objects": [
        {"name": "wall", "shape": "box", "size": [0.1, 0.5, 0.2], "position": [0.5, 0.5, 0.1],
         "orientation": [0.0, 0.0, 0.0, 1.0], "deformability": 0.5, "sensitivity": 1.0,
         "cutouts": [{"shape": "sphere", "radius": 0.05, "position": [0.5, 0.5, 0.1]}]},
        {"name": "post", "shape": "cylinder", "radius": 0.05, "length": 0.2, "position": [0.2, 0.8, 0.1],
         "deformability": 0.0, "sensitivity": float("nan")},
        {"name": "aligned", "cells": [[0, 2], [0, 2], [0, 1]], "deformability": 0.2, "sensitivity": 0.3},
    ],
    "regions": [{"name": "left", "lower": [0.0, 0.0], "upper": [0.5, 1.0]}],
    "robot": {"kind": "rigid", "name": "box", "space": "r3", "deformability": 0.0, "sensitivity": 1.0,
              "parts": [{"shape": "box", "size": [0.1, 0.1, 0.1]}]},
    "variants": {"soft": {"robot.deformability": 0.5}},
}

JUNK = (st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=True, allow_infinity=True)
        | st.text(max_size=12) | st.lists(st.floats(allow_nan=True), max_size=8)
        | st.lists(st.text(max_size=3), max_size=3) | st.dictionaries(st.text(max_size=5), st.integers(), max_size=3))


def _paths(node, prefix=()):
    """Every key path of a nested dict/list (tables, arrays and leaves)."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield (*prefix, k)
            yield from _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield (*prefix, i)
            yield from _paths(v, (*prefix, i))


SCENE_PATHS = list(_paths(VALID_SCENE))


def _mutate(data, path, op, junk, unknown_key):
    out = copy.deepcopy(data)
    holder = out
    for key in path[:-1]:
        holder = holder[key]
    last = path[-1]
    if op == "delete":
        del holder[last]
    elif op == "replace":
        holder[last] = junk
    elif op == "unknown" and isinstance(holder, dict):
        holder[f"x_{unknown_key}"] = junk
    else:
        holder[last] = junk
    return out


MUTATION = st.tuples(st.sampled_from(SCENE_PATHS), st.sampled_from(["delete", "replace", "unknown"]), JUNK,
                     st.text(min_size=1, max_size=6))


def test_the_valid_scene_is_valid():
    scene = Scene.from_dict(copy.deepcopy(VALID_SCENE), source="valid.toml")
    assert scene.object("post").material.forbidden


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
@given(MUTATION)
def test_malformed_scenes_raise_only_pliant_errors(mutation):
    path, op, junk, key = mutation
    data = _mutate(VALID_SCENE, path, op, junk, key)
    try:
        Scene.from_dict(data, source="m.toml")
    except PliantError as exc:
        assert str(exc).startswith("m.toml:"), str(exc)


@pytest.mark.parametrize(("path", "value", "field"), [
    (("objects", 0, "deformability"), 1.5, "objects[0].deformability"),
    (("objects", 0, "sensitivity"), -1.0, "objects[0].sensitivity"),
    (("objects", 0, "deformability"), float("nan"), "objects[0].deformability"),
    (("objects", 0, "orientation"), [0.0, 0.0, 0.0, 2.0], "objects[0].orientation"),
    (("objects", 0, "size"), [0.1, float("inf"), 0.2], "objects[0].size[1]"),
    (("objects", 1, "shape"), "torus", "objects[1].shape"),
    (("bounds", "resolution"), 0.0, "bounds.resolution"),
    (("bounds", "resolution"), 0.03, "bounds.resolution"),
    (("start",), [2.0, 0.1, 0.1], "start"),
    (("goal",), [0.5, 0.5], "goal"),
    (("robot", "space"), "se4", "robot.space"),
    (("robot", "parts"), [], "robot.parts"),
    (("regions", 0, "upper"), [0.5, -1.0], "regions[0].upper"),
    (("objects", 2, "cells"), [[0, 2], [0, 2], [1, 1]], "objects[2].cells"),
    (("objects", 2, "cells"), [[0, 2.5], [0, 2], [0, 1]], "objects[2].cells"),
])
def test_targeted_scene_errors_name_the_field(path, value, field):
    data = _mutate(VALID_SCENE, path, "replace", value, "")
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data, source="bad.toml")
    assert f"bad.toml:{field}:" in str(info.value)
    if not (isinstance(value, float) and math.isnan(value)):
        assert "(got " in str(info.value)


def test_missing_and_unknown_fields():
    data = copy.deepcopy(VALID_SCENE)
    del data["name"]
    with pytest.raises(SceneError, match=r"bad.toml:name: is required"):
        Scene.from_dict(data, source="bad.toml")
    data = copy.deepcopy(VALID_SCENE)
    data["objects"][0]["colour"] = "red"
    with pytest.raises(SceneError, match=r"objects\[0\]\.colour: is not a known field"):
        Scene.from_dict(data, source="bad.toml")


def test_missing_mesh_file(tmp_path):
    data = copy.deepcopy(VALID_SCENE)
    data["objects"][0] = {"name": "m", "shape": "mesh", "file": "nowhere.stl", "deformability": 0.1,
                          "sensitivity": 1.0}
    with pytest.raises(SceneError, match=r"objects\[0\]\.file: cannot read file"):
        Scene.from_dict(data, source="bad.toml", base_dir=tmp_path)


def test_bad_toml_file(tmp_path):
    from pliant import load_scene

    path = tmp_path / "broken.toml"
    path.write_text("name = 'x'\n[bounds\n")
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(path)


VALID_PIPELINE = {"name": "p", "scene": "triple-wall", "seed": 1, "description": "d", "disable": [],
                  "planner": {"name": "straight", "step": 0.01}, "robot": {"name": "rigid", "resolution": 0.008}}
PIPELINE_PATHS = list(_paths(VALID_PIPELINE))
PIPELINE_MUTATION = st.tuples(st.sampled_from(PIPELINE_PATHS), st.sampled_from(["delete", "replace", "unknown"]),
                              JUNK, st.text(min_size=1, max_size=6))
OVERRIDES = st.lists(st.text(max_size=20) | st.sampled_from(
    ["planner.step=-1", "planner=nope", "seed=-3", "scene=nowhere", "scene.variant=soft-robot-soft-walls",
     "planner.stepp=1", "robot.resolution=abc", "cost=voxel", "planner.step=[1,2]", "=3", "a.b.c=4"]), max_size=3)


def test_the_valid_pipeline_builds():
    ctx = Pipeline.from_dict(copy.deepcopy(VALID_PIPELINE), source="valid.toml").build()
    assert ctx.robot is not None and "planner" in ctx.extras


@settings(max_examples=250, suppress_health_check=[HealthCheck.too_slow])
@given(PIPELINE_MUTATION, OVERRIDES)
def test_malformed_pipelines_raise_only_pliant_errors(mutation, overrides):
    path, op, junk, key = mutation
    data = _mutate(VALID_PIPELINE, path, op, junk, key)
    try:
        Pipeline.from_dict(data, source="m.toml", overrides=overrides).build()
    except PliantError:
        pass


@pytest.mark.parametrize(("override", "field", "text"), [
    ("planner.step=-1", "planner.step", "must be >="),
    ("planner.stepp=1", "planner.stepp", "unknown option"),
    ("planner=nope", "planner", "unknown planner"),
    ("seed=-3", "seed", "non-negative"),
    ("robot.resolution=abc", "robot.resolution", "must be a number"),
    ("colour=red", "colour", "no pipeline field"),
    ("scene.variant=squishy", "variants", "unknown variant"),
])
def test_targeted_pipeline_errors_name_the_field(override, field, text):
    with pytest.raises(PliantError) as info:
        Pipeline.from_dict(copy.deepcopy(VALID_PIPELINE), source="p.toml", overrides=[override]).build()
    assert field in str(info.value) and text in str(info.value)


def test_unknown_component_lists_the_alternatives():
    with pytest.raises(PliantError, match=r"available: .*straight"):
        Pipeline.from_dict({"scene": "triple-wall", "planner": "strait"}).build()


def test_pipeline_without_scene():
    with pytest.raises(PipelineError, match="scene"):
        Pipeline.from_dict({"planner": "straight"})
