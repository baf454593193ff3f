"""Robots swap by name: ``robot.model=NAME`` (``--set robot.model=pr2``) replaces the scene's URDF robot where the
scene's start and goal are configurations of the new robot's group, and says what the scene requires otherwise."""

from __future__ import annotations

import numpy as np
import pytest
from pliant.errors import ConfigError
from pliant.pipeline import Pipeline


def test_robot_options_without_a_robot_table_apply_to_the_scenes_default_robot():
    pipeline = Pipeline.from_file("iiwa-policy", overrides=["robot.resolution=0.05"])
    assert pipeline.components["robot"].name == "" and pipeline.components["robot"].options == {"resolution": 0.05}
    context = pipeline.build()
    assert type(context.robot).__name__ == "PinocchioRobot"
    assert pipeline.to_dict()["robot"] == {"resolution": 0.05}


def test_a_robot_swapped_for_the_same_robot_from_its_urdf_file_plans_the_same_space():
    from pliant_pinocchio.catalog import named_robot

    urdf = str(named_robot("iiwa", "test").urdf)
    named = Pipeline.from_file("iiwa-policy").build()
    swapped = Pipeline.from_file("iiwa-policy", overrides=[f'robot.model="{urdf}"', "robot.group=all"]).build()
    assert swapped.robot.model_name == urdf
    assert swapped.robot.urdf_description().joint_names == named.robot.urdf_description().joint_names
    assert np.allclose(swapped.space.lower, named.space.lower) and np.allclose(swapped.space.upper, named.space.upper)
    q = np.asarray(named.scene.start, dtype=float)
    assert np.allclose(swapped.robot.body_points(q), named.robot.body_points(q))


@pytest.mark.parametrize(("pipeline", "model", "field", "says"), [
    ("baxter-policy", "pr2", "robot.model", "set up for baxter"),
    ("pr2-policy", "baxter", "robot.model", "set up for pr2"),
    ("baxter-policy", "iiwa", "robot.group", "unknown joint group for iiwa"),
    ("iiwa-policy", "nosuchrobot", "robot.model", "unknown robot"),
])
def test_a_robot_the_scene_does_not_allow_is_refused_naming_the_requirement(pipeline, model, field, says):
    with pytest.raises(ConfigError, match=says) as info:
        Pipeline.from_file(pipeline, overrides=[f"robot.model={model}"]).build()
    assert info.value.field == field
