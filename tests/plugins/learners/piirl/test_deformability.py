"""Deformability from presses (thesis appendix A): the known object recovers itself, stiffer objects change less."""

import numpy as np
import pliant
import pytest
from pliant.errors import ConfigError, DimensionError
from pliant.interfaces import Context
from pliant_piirl.deformability import PressOptions, press


def learner(**options):
    return pliant.registry.create("learner", "press-deformability", Context(scene=pliant.load_scene("hollow-cube")),
                                  **options)


def test_a_stiffer_object_changes_less_and_the_same_press_gives_the_same_change():
    options = PressOptions(steps=600)
    changes = [press(d, options, np.random.default_rng(0)) for d in (0.75, 0.5, 0.25)]
    assert changes[0] > changes[1] > changes[2] > 0
    assert press(0.5, options, np.random.default_rng(0)) == pytest.approx(changes[1], rel=1e-9)


def test_estimates_are_ordered_and_the_known_object_recovers_its_own_value():
    fitted = learner(repetitions=2).fit({"a": 0.75, "b": 0.5, "c": 0.25}, np.random.default_rng(1))
    d = fitted["deformability"]
    assert d["a"] > d["b"] > d["c"]
    assert d["b"] == pytest.approx(0.5, abs=0.03)              # the same material as the reference
    assert abs(d["c"] - 0.25) < 0.05


def test_bad_data_is_a_clear_error():
    with pytest.raises(DimensionError, match="non-empty"):
        learner().fit({}, np.random.default_rng(0))
    with pytest.raises(ConfigError, match=r"learner.data.x"):
        learner().fit({"x": 1.5}, np.random.default_rng(0))
