"""Push models P(delta s | a, o) (poster ICHR 2010, LEARN_MODEL's UPDATE_DISTR and VARIANCE) and their file format."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import ConfigError
from pliant_tsrrt.models import Displacement, PushModels, compose, object_class, relative

finite = st.floats(-0.2, 0.2, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(finite, finite, finite), min_size=2, max_size=30))
def test_running_distribution_matches_numpy(rows):
    d = Displacement()
    for r in rows:
        d.update(np.array(r))
    data = np.array(rows)
    assert np.allclose(d.mean, data.mean(axis=0), atol=1e-12)
    assert np.allclose(d.cov, np.cov(data.T), atol=1e-12)
    assert np.allclose(d.mean_variance(), data.var(axis=0, ddof=1) / len(rows), atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(-3.1, 3.1), finite, finite, st.floats(-1.5, 1.5))
def test_compose_and_relative_are_inverse(x, y, t, dx, dy, dt):
    pose = np.array([x, y, t])
    delta = np.array([dx, dy, dt])
    assert np.allclose(relative(pose, compose(pose, delta)), delta, atol=1e-9)


def test_object_class_strips_the_number():
    assert object_class("plate-2") == "plate" and object_class("book") == "book" and object_class("a-b-10") == "a-b"


def _models() -> PushModels:
    m = PushModels()
    m.footprints["can"] = (1, np.array([0.05, 0.05]))
    m.models["can"] = []
    for p in range(6):
        d = Displacement()
        for k in range(3):
            d.update(np.array([0.01 * p, 0.001 * k, 0.0]))
        m.models["can"].append(d)
    return m


def test_models_file_round_trip(tmp_path):
    m = _models()
    m.save(tmp_path / "m.json")
    back = PushModels.load(tmp_path / "m.json")
    assert np.allclose(back.means(["can", "can"]), m.means(["can", "can"]))
    assert back.footprints["can"][0] == 1


def test_bad_models_files_name_the_field(tmp_path):
    data = _models().to_dict()
    data["classes"]["can"]["primitives"].pop("turn-")
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ConfigError, match=r"classes\.can\.primitives"):
        PushModels.load(path)
    path.write_text(json.dumps({"format": "something else"}))
    with pytest.raises(ConfigError, match="format"):
        PushModels.load(path)
    with pytest.raises(ConfigError, match="no push model"):
        _models().means(["plate"])
