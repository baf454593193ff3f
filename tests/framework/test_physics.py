"""Scene physics (pliant.physics): parsing, validation errors naming field and value, derived inertia, and the
one-line report of properties a simulator ignores."""

from __future__ import annotations

import copy
import logging

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import SceneError
from pliant.geometry.shapes import Box, Cylinder, Sphere
from pliant.physics import (
    DEFAULT_SUPPORT_FRICTION,
    ScenePhysics,
    footprint_mean_radius,
    inertia_diagonal,
    report_ignored,
    support_limits,
)
from pliant.scene import Scene

BASE = {
    "name": "physics", "planar": True, "start": [0.2, 0.2, 0.0], "goal": [0.8, 0.2, 0.0],
    "bounds": {"lower": [0.0, 0.0, -0.01], "upper": [1.0, 0.4, 0.01], "resolution": 0.02},
    "objects": [
        {"name": "crate", "shape": "box", "size": [0.1, 0.1, 0.1], "position": [0.5, 0.2, 0.0], "mass": 1.0,
         "friction": 0.6, "deformability": 0.0, "sensitivity": 1.0},
        {"name": "post", "shape": "box", "size": [0.04, 0.04, 0.02], "position": [0.9, 0.35, 0.0],
         "deformability": 0.0, "sensitivity": 1.0},
    ],
    "robot": {"kind": "rigid", "space": "se2", "parts": [{"shape": "box", "size": [0.04, 0.1, 0.02]}]},
}


def scene(crate=None, robot=None, top=None, post=None) -> Scene:
    data = copy.deepcopy(BASE)
    data["objects"][0].update(crate or {})
    data["objects"][1].update(post or {})
    data["robot"].update(robot or {})
    data.update(top or {})
    return Scene.from_dict(data, source="test.toml")


def test_every_property_is_read_and_stated():
    s = scene(crate={"static_friction": 0.8, "rolling_friction": 0.01, "restitution": 0.2, "linear_damping": 0.1,
                     "angular_damping": 0.3, "inertia": [0.002, 0.002, 0.003]},
              robot={"mass": 0.5, "friction": 0.4, "restitution": 0.1},
              top={"physics": {"support": {"friction": 0.3}}})
    crate = s.physics.body("crate")
    assert (crate.mass, crate.friction, crate.static_friction, crate.rolling_friction) == (1.0, 0.6, 0.8, 0.01)
    assert (crate.restitution, crate.linear_damping, crate.angular_damping) == (0.2, 0.1, 0.3)
    np.testing.assert_allclose(crate.inertia, [0.002, 0.002, 0.003])
    assert (s.physics.robot.mass, s.physics.robot.friction, s.physics.robot.restitution) == (0.5, 0.4, 0.1)
    assert s.physics.support.friction == 0.3 and s.physics.support.stated
    kinds = [kind for kind, _ in s.physics.stated()]
    assert "objects.inertia" in kinds and "robot.mass" in kinds and "support.friction" in kinds
    assert ("support.friction", "physics.support.friction") in s.physics.stated()


def test_defaults_state_nothing_new():
    s = scene()
    assert s.physics.support.friction == DEFAULT_SUPPORT_FRICTION and not s.physics.support.stated
    assert s.physics.stated() == [("objects.friction", "objects.crate.friction"),
                                  ("objects.mass", "objects.crate.mass")]
    assert ScenePhysics().support_friction == DEFAULT_SUPPORT_FRICTION       # a scene built without physics


@pytest.mark.parametrize(("kwargs", "field", "value"), [
    ({"crate": {"restitution": 1.5}}, "objects[0].restitution", 1.5),
    ({"crate": {"static_friction": 0.2}}, "objects[0].static_friction", 0.2),
    ({"crate": {"linear_damping": 1.0}}, "objects[0].linear_damping", 1.0),
    ({"crate": {"angular_damping": -0.1}}, "objects[0].angular_damping", -0.1),
    ({"crate": {"inertia": [0.001, 0.001, 0.01]}}, "objects[0].inertia", [0.001, 0.001, 0.01]),
    ({"crate": {"inertia": [0.001, -0.001, 0.001]}}, "objects[0].inertia[1]", -0.001),
    ({"crate": {"rolling_friction": -1.0}}, "objects[0].rolling_friction", -1.0),
    ({"crate": {"stiction": 0.3}}, "objects[0].stiction", 0.3),
    ({"post": {"linear_damping": 0.1}}, "objects[1].linear_damping", 0.1),
    ({"post": {"inertia": [1.0, 1.0, 1.0]}}, "objects[1].inertia", [1.0, 1.0, 1.0]),
    ({"robot": {"mass": 0.0}}, "robot.mass", 0.0),
    ({"robot": {"friction": -0.5}}, "robot.friction", -0.5),
    ({"top": {"physics": {"support": {"friction": -0.1}}}}, "physics.support.friction", -0.1),
    ({"top": {"physics": {"support": {"friction": 0.5, "spin": 1}}}}, "physics.support.spin", 1),
    ({"top": {"physics": {"gravity": 9.8}}}, "physics.gravity", 9.8),
    ({"top": {"planar": False, "physics": {"support": {"friction": 0.5}}}}, "physics.support", {"friction": 0.5}),
])
def test_bad_values_name_field_and_value(kwargs, field, value):
    with pytest.raises(SceneError) as info:
        scene(**kwargs)
    assert info.value.field == field
    assert info.value.value == value


def test_a_urdf_robot_takes_no_mass():
    data = copy.deepcopy(BASE)
    data["robot"] = {"kind": "urdf", "model": "iiwa", "mass": 3.0}
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data, source="test.toml")
    assert info.value.field == "robot.mass"


@settings(max_examples=40, deadline=None)
@given(mu=st.floats(0.0, 2.0), extra=st.floats(0.0, 1.0), e=st.floats(0.0, 1.0), d=st.floats(0.0, 0.99))
def test_valid_values_round_trip(mu, extra, e, d):
    s = scene(crate={"friction": mu, "static_friction": mu + extra, "restitution": e, "linear_damping": d},
              top={"physics": {"support": {"friction": mu}}})
    body = s.physics.body("crate")
    assert (body.friction, body.static_friction, body.restitution, body.linear_damping) == (mu, mu + extra, e, d)
    assert s.physics.support.friction == mu


@settings(max_examples=40, deadline=None)
@given(st.tuples(*[st.floats(0.01, 2.0)] * 3), st.floats(0.01, 10.0))
def test_derived_inertia_matches_the_solid(size, mass):
    box = inertia_diagonal(Box(np.array(size)), mass)
    a, b, c = size
    np.testing.assert_allclose(box, mass / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b]))
    assert max(box) <= sum(box) - max(box) + 1e-12          # the triangle inequality every body's moments obey
    r, h = size[0], size[1]
    cyl = inertia_diagonal(Cylinder(r, h), mass)
    assert cyl[2] == pytest.approx(0.5 * mass * r * r) and cyl[0] == cyl[1]
    assert inertia_diagonal(Sphere(r), mass)[0] == pytest.approx(0.4 * mass * r * r)


def test_footprint_and_support_limits():
    # a disc's mean radius is 2r/3; a square's is ~0.3826 of its side
    assert footprint_mean_radius(Cylinder(0.3, 0.1)) == pytest.approx(0.2)
    assert footprint_mean_radius(Box(np.array([1.0, 1.0, 0.1]))) == pytest.approx(0.38260, abs=1e-4)
    force, torque = support_limits(0.5, 2.0, 0.1)
    assert force == pytest.approx(0.5 * 2.0 * 9.80665) and torque == pytest.approx(force * 0.1)


def test_ignored_properties_are_logged_once_in_one_line(caplog):
    s = scene(crate={"static_friction": 0.8}, top={"physics": {"support": {"friction": 0.3}}})
    with caplog.at_level(logging.WARNING, logger="pliant.physics"):
        ignored = report_ignored(s.physics, "toy", ["objects.mass", "objects.friction"], "no reason")
    assert ignored == ["objects.crate.static_friction", "physics.support.friction"]
    assert len(caplog.records) == 1
    assert "toy" in caplog.text and "objects.static_friction (crate)" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="pliant.physics"):
        assert report_ignored(scene().physics, "toy", ["objects.mass", "objects.friction"]) == []
    assert not caplog.records
