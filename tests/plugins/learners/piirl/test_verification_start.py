"""Table 4.1's verification (pliant_piirl.verification): where the local search starts on the real hollow cube."""

import numpy as np
import pliant
import pytest
from pliant_piirl.demonstration import Demonstration
from pliant_piirl.expert import ExpertOptions, SimulatedExpert
from pliant_piirl.features import DeformationFeatures, true_sensitivities
from pliant_piirl.tasks import TaskSpace, rotation_onto
from pliant_piirl.verification import _cheaper_start, plan_task, straight_insertion

TIP = np.array([0.0, 0.0, -0.06])


@pytest.fixture(scope="module")
def cube():
    scene = pliant.load_scene("hollow-cube")
    features = DeformationFeatures(scene)
    task = TaskSpace(scene).generate_task("L1", "M1", np.random.default_rng(1), TIP, rotation_onto)
    return scene, features, task


def test_the_straight_insertion_is_the_noiseless_experts_path_for_the_values_given(cube):
    scene, features, task = cube
    truth = true_sensitivities(scene)
    path = straight_insertion(features, truth, task, TIP)
    expert = SimulatedExpert(features, truth, TIP, ExpertOptions(noise=0.0))
    assert np.array_equal(path, expert.path(task, *expert.optimum(task)))
    rot, pos, _ = features.robot.rigid_placement(path[-1:])
    assert np.allclose(rot[0] @ TIP + pos[0], task.target, atol=1e-9)
    # with M1 made nearly free the cheapest insertion leans into M1 and costs less in those values
    cheap_m1 = {**truth, "M1": 0.01}
    leaning = straight_insertion(features, cheap_m1, task, TIP)
    weights = features.sensitivity_vector(cheap_m1)
    assert features.of_path(leaning) @ weights < features.of_path(path) @ weights
    m1 = features.names.index("M1")
    assert features.of_path(leaning)[m1] > features.of_path(path)[m1]


def test_with_no_rrt_path_the_search_starts_from_the_straight_insertion(cube):
    scene, features, task = cube
    values = {**true_sensitivities(scene), "H1": 1.0}
    shown = Demonstration(task, straight_insertion(features, values, task, TIP))
    rng = np.random.default_rng(0)
    result, path = plan_task(scene, values, shown, TIP, rng, max_time=None, planner_options={"max_iterations": 1},
                             straight=True)
    assert result.path is None                                # one iteration reaches no goal
    assert result.statistics["verification"]["start"] == "straight"
    assert result.statistics["verification"]["rrtstar_cost"] is None
    assert np.array_equal(path, straight_insertion(features, values, task, TIP))
    _, nothing = plan_task(scene, values, shown, TIP, np.random.default_rng(0), max_time=None,
                           planner_options={"max_iterations": 1}, straight=False)
    assert nothing is None


class _Counts:
    """Features whose cost is the first coordinate of the path's first waypoint."""

    def of_path(self, path):
        return np.array([path[0][0]])


def test_the_cheaper_start_is_taken_unless_it_punctures():
    searched, straight = np.array([[3.0]]), np.array([[2.0]])
    statistics = {}
    assert _cheaper_start(searched, straight, _Counts(), np.ones(1), lambda p: True, statistics) is straight
    assert statistics["verification"] == {"start": "straight", "rrtstar_cost": 3.0, "straight_cost": 2.0,
                                          "straight_intact": True}
    assert _cheaper_start(searched, straight, _Counts(), np.ones(1), lambda p: False, statistics) is searched
    assert statistics["verification"]["start"] == "rrtstar" and statistics["verification"]["straight_cost"] is None
    assert _cheaper_start(np.array([[1.0]]), straight, _Counts(), np.ones(1), lambda p: True, statistics)[0, 0] == 1
    assert _cheaper_start(None, None, _Counts(), np.ones(1), lambda p: True, statistics) is None
    assert statistics["verification"]["start"] is None
