"""The demonstrations file: round trips exactly, and every malformed input is a ConfigError naming the field."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import ConfigError
from pliant_piirl.demonstration import Demonstration, DemonstrationTask, load_demonstrations, save_demonstrations

finite = st.floats(-10, 10, allow_nan=False)


@st.composite
def demonstrations(draw):
    d = draw(st.integers(2, 7))
    k = draw(st.integers(2, 6))
    normals = draw(st.lists(st.tuples(finite, finite, finite).filter(lambda n: np.linalg.norm(n) > 1e-3),
                            max_size=4))
    planes = [list(np.asarray(n) / np.linalg.norm(n)) + [draw(finite)] for n in normals]
    task = DemonstrationTask(np.array(draw(st.lists(finite, min_size=d, max_size=d))),
                             np.array(draw(st.lists(finite, min_size=3, max_size=3))),
                             np.array(planes).reshape(-1, 4), tuple(draw(st.lists(st.sampled_from("ABC"), max_size=2))),
                             np.array(draw(st.lists(finite, min_size=3, max_size=3))) if draw(st.booleans()) else None,
                             np.array(draw(st.lists(finite, min_size=d, max_size=d))) if draw(st.booleans()) else None)
    path = np.array([draw(st.lists(finite, min_size=d, max_size=d)) for _ in range(k)])
    return Demonstration(task, path, draw(st.sampled_from(["simulated-expert", "capture"])))


@settings(max_examples=60, deadline=None)
@given(st.lists(demonstrations(), min_size=1, max_size=3))
def test_a_file_round_trips_exactly(tmp_path_factory, demos):
    path = tmp_path_factory.mktemp("demos") / "d.json"
    save_demonstrations(path, demos, "some-scene")
    scene, back = load_demonstrations(path)
    assert scene == "some-scene" and len(back) == len(demos)
    for a, b in zip(demos, back):
        assert np.array_equal(a.path, b.path) and a.source == b.source
        assert np.array_equal(a.task.start, b.task.start) and np.array_equal(a.task.target, b.task.target)
        assert np.allclose(a.task.planes, b.task.planes) and a.task.objects == b.task.objects
        assert (a.task.edge is None) == (b.task.edge is None)
        assert (a.task.goal is None and b.task.goal is None) or np.array_equal(a.task.goal, b.task.goal)


GOOD = {"format": "pliant-demonstrations", "version": 1, "scene": "s", "demonstrations": [
    {"task": {"start": [0.0, 0.0, 0.0], "target": [1.0, 0.0, 0.0], "planes": [[1.0, 0.0, 0.0, 2.0]]},
     "path": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], "source": "capture"}]}


def _with(change):
    data = json.loads(json.dumps(GOOD))
    change(data)
    return data


@pytest.mark.parametrize(("change", "field"), [
    (lambda d: d.update(format="other"), "format"),
    (lambda d: d.update(version=2), "version"),
    (lambda d: d.pop("scene"), "scene"),
    (lambda d: d.update(demonstrations={}), "demonstrations"),
    (lambda d: d["demonstrations"][0].pop("task"), "demonstrations[0].task"),
    (lambda d: d["demonstrations"][0]["task"].update(target=[1.0, 2.0]), "demonstrations[0].task.target"),
    (lambda d: d["demonstrations"][0]["task"].update(start=["a", 1, 2]), "demonstrations[0].task.start"),
    (lambda d: d["demonstrations"][0]["task"].update(planes=[[2.0, 0.0, 0.0, 1.0]]), "demonstrations[0].task.planes"),
    (lambda d: d["demonstrations"][0]["task"].update(planes=[[1.0, 0.0, 0.0]]), "demonstrations[0].task.planes"),
    (lambda d: d["demonstrations"][0]["task"].update(colour="red"), "demonstrations[0].task"),
    (lambda d: d["demonstrations"][0]["task"].update(goal=[1.0, 2.0]), "demonstrations[0].task.goal"),
    (lambda d: d["demonstrations"][0].update(path=[[0.0, 0.0, 0.0]]), "demonstrations[0].path"),
    (lambda d: d["demonstrations"][0].update(path=[[0.0, 0.0], [1.0, 1.0]]), "demonstrations[0].path"),
    (lambda d: d["demonstrations"][0].update(path=[[0.0, 0.0, float("nan")], [1.0, 1.0, 1.0]]),
     "demonstrations[0].path"),
    (lambda d: d["demonstrations"][0].update(source=3), "demonstrations[0].source"),
])
def test_malformed_files_name_the_field(tmp_path, change, field):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(_with(change)))
    with pytest.raises(ConfigError) as error:
        load_demonstrations(path)
    assert error.value.field == field and error.value.source == str(path)


def test_unreadable_inputs_are_clear_errors(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        load_demonstrations(tmp_path / "missing.json")
    (tmp_path / "x.json").write_text("{not json")
    with pytest.raises(ConfigError, match="not a JSON file"):
        load_demonstrations(tmp_path / "x.json")
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ConfigError):
        load_demonstrations(tmp_path / "deep.json")
    with pytest.raises(ConfigError, match="file path"):
        load_demonstrations(None)


def test_planes_are_half_spaces_every_point_must_satisfy():
    task = DemonstrationTask(np.zeros(3), np.zeros(3), np.array([[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 0.0]]))
    inside = task.allows(np.array([[0.5, -1.0, 7.0], [1.0, 0.0, 0.0], [1.5, -1.0, 0.0], [0.0, 0.1, 0.0]]))
    assert inside.tolist() == [True, True, False, False]
