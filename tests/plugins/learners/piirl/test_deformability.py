"""Deformability from presses (thesis appendix A): the known object recovers itself, stiffer objects change less,
estimates stay in [0, 1] by construction and a change beyond the reference's response is reported."""

import numpy as np
import pliant
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import ConfigError, DimensionError
from pliant.interfaces import Context
from pliant_piirl import deformability
from pliant_piirl.deformability import DeformabilityRangeWarning, PressOptions, invert, press

QUICK = {"steps": 600, "window": 300}


def learner(**options):
    return pliant.registry.create("learner", "press-deformability", Context(scene=pliant.load_scene("hollow-cube")),
                                  **options)


def test_a_stiffer_object_changes_less_and_the_same_press_gives_the_same_change():
    options = PressOptions(**QUICK)
    changes = [press(d, options, np.random.default_rng(0)) for d in (0.75, 0.5, 0.25)]
    assert changes[0] > changes[1] > changes[2] > 0
    assert press(0.5, options, np.random.default_rng(0)) == pytest.approx(changes[1], rel=1e-9)


def test_estimates_are_ordered_in_range_and_the_known_object_recovers_its_own_value():
    fitted = learner(repetitions=1, calibration=2, calibration_repetitions=1, force=1.0, **QUICK).fit(
        {"a": 0.75, "b": 0.5, "c": 0.25}, np.random.default_rng(1))
    d = fitted["deformability"]
    assert d["a"] > d["b"] > d["c"]
    assert all(0.0 <= v <= 1.0 for v in d.values())
    assert d["b"] == pytest.approx(0.5, abs=0.03)              # the same material as the reference
    assert abs(d["c"] - 0.25) < 0.05


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 1e3), min_size=1, max_size=8), st.floats(-1.0, 1e4))
def test_an_estimate_read_off_any_response_curve_lies_in_the_models_range(changes, change):
    grid = np.arange(1, len(changes) + 1) / len(changes)
    value, raw = invert(grid, np.array(changes), change)
    assert 0.0 <= value <= 1.0
    assert raw == value or (raw > 1.0 and value == 1.0)


def fake_press(deformability_, options, rng, force=None):
    """A quasi-static body that stiffens: its change depends on force x deformability only (as the stresses scale
    with 1/d), here g(x) = x + x^2, plus an offset an object's ``d`` above 1 would give."""
    x = (force if force is not None else options.probe) * deformability_
    return 1e-5 * (x + x * x)


def test_known_answer_through_a_nonlinear_response_and_the_force_is_chosen_from_the_reference(monkeypatch):
    monkeypatch.setattr(deformability, "press", fake_press)
    truth = {"a": 0.85, "b": 0.3, "c": 0.6, "d": 0.15, "e": 0.45}
    fitted = learner(repetitions=1, calibration=20, calibration_repetitions=1, target=0.02, probes=10).fit(
        truth, np.random.default_rng(0))
    # a deformability-1 body of the reference's kind changes by target x rest volume under the force chosen
    assert fake_press(1.0, None, None, fitted["force"]) == pytest.approx(0.02 * 0.1 ** 3, rel=0.1)
    for name, d in truth.items():                          # a ratio of changes would say 0.85 -> 1.1 here
        assert fitted["deformability"][name] == pytest.approx(d, abs=0.01)
    assert fitted["above_range"] == {}


def test_a_change_beyond_the_references_response_is_reported_as_1_with_a_warning(monkeypatch):
    def softer(d, options, rng, force=None):                # the unknown object's material is softer than its kind
        return fake_press(d * (1.4 if d == 0.9 else 1.0), options, rng, force)

    monkeypatch.setattr(deformability, "press", softer)
    with pytest.warns(DeformabilityRangeWarning, match=r"'soft'.*the data say 1\.\d+"):
        fitted = learner(repetitions=1, calibration=4, calibration_repetitions=1, force=1.0).fit(
            {"soft": 0.9}, np.random.default_rng(0))
    assert fitted["deformability"]["soft"] == 1.0
    assert fitted["above_range"]["soft"] > 1.0


def test_bad_data_is_a_clear_error():
    with pytest.raises(DimensionError, match="non-empty"):
        learner().fit({}, np.random.default_rng(0))
    with pytest.raises(ConfigError, match=r"learner.data.x"):
        learner().fit({"x": 1.5}, np.random.default_rng(0))
