"""The planar environment of thesis 4.4.3: its passages, the planner expert, and PIIRL on one demonstration."""

import numpy as np
import pliant
import pytest
from pliant_piirl.demonstration import Demonstration, DemonstrationTask
from pliant_piirl.features import DeformationFeatures, true_sensitivities
from pliant_piirl.sampling import PathSampler, SampleOptions


@pytest.fixture(scope="module")
def planar():
    scene = pliant.load_scene("planar-objects")
    features = DeformationFeatures(scene)
    task = DemonstrationTask(scene.start, np.r_[scene.goal[:2], 0.0], goal=scene.goal)
    return scene, features, task


def through(gap_x, scene):
    turn = np.pi / 2
    return np.array([scene.start, [gap_x, 0.2, turn], [gap_x, 0.4, turn], scene.goal])


def test_uniform_sensitivities_prefer_the_wide_gap_and_the_true_ones_a_narrow_gap_beside_low_objects(planar):
    scene, features, _ = planar
    truth = features.sensitivity_vector(true_sensitivities(scene))
    gaps = {"O1|O2": 0.1275, "O2|O3": 0.2675, "O3|O4": 0.4025, "O4|O5": 0.5125}
    best = {}
    for name, x in gaps.items():                     # the cheapest sideways offset in each gap
        v = [features.of_path(through(x + dx, scene)) for dx in np.linspace(-0.01, 0.01, 5)]
        best[name] = (min(f.sum() for f in v), min(f @ truth for f in v))
    assert min(best, key=lambda k: best[k][0]) == "O3|O4"                      # uniform: the 35 mm gap
    assert min(best, key=lambda k: best[k][1]) in ("O1|O2", "O2|O3")           # true: pressing into O1 or O2
    assert all(b[0] > 0 for b in best.values())                               # every way deforms something


def test_samples_around_a_goal_task_keep_both_ends(planar):
    scene, features, task = planar
    demo = Demonstration(task, through(0.1275, scene))
    samples = PathSampler(features, (0.0, 0.0, 0.0), SampleOptions(samples=10)).draw(demo, np.random.default_rng(0))
    assert len(samples) == 10
    for s in samples:
        assert np.array_equal(s[0], scene.start) and np.array_equal(s[-1], scene.goal)
    assert not all(np.allclose(samples[0], s) for s in samples[1:])


@pytest.fixture(scope="module")
def expert_demonstration(planar):
    """The planner expert and its demonstration on a work budget (2,000 RRT* iterations, no time limit: the same
    path on any machine under any load; a 10 s budget once found another path, or none, on a loaded machine)."""
    from pliant_piirl.experiments import PLANAR_PLANNER
    from pliant_piirl.verification import PlannerExpert

    scene, features, task = planar
    options = {**PLANAR_PLANNER, "max_time": None, "max_iterations": 2000}
    expert = PlannerExpert(features, true_sensitivities(scene), max_time=None, planner_options=options,
                           shortcut_iterations=50)
    return expert, expert.demonstrate(task, np.random.default_rng(3))


@pytest.mark.slow
def test_the_planner_expert_reaches_the_goal_and_piirl_learns_from_it(planar, expert_demonstration):
    scene, features, _ = planar
    _, demo = expert_demonstration
    assert np.array_equal(demo.path[0], scene.start)
    assert scene.goal_tolerance >= float(features.space.distance(demo.path[-1], scene.goal))
    assert np.all(np.isfinite(features.of_path(demo.path)))
    from pliant.interfaces import Context

    context = Context(scene=scene)
    context.robot = pliant.registry.create("robot", "rigid", context)
    learner = pliant.registry.create("learner", "piirl", context, tip=(0.0, 0.0, 0.0), lower=1.0, upper=200.0,
                                     initial=100.0, samples=30)
    fitted = learner.fit([demo], np.random.default_rng(1))
    assert set(fitted["sensitivities"]) == {"O1", "O2", "O3", "O4", "O5"}
    assert all(1.0 - 1e-9 <= v <= 200.0 + 1e-9 for v in fitted["sensitivities"].values())


@pytest.mark.parametrize("budget, field", [({}, "--max-time"), ({"max_time": 5.0, "max_iterations": 100}, "--max-time"),
                                           ({"max_iterations": 0}, "--max-iterations"),
                                           ({"max_iterations": 2.5}, "--max-iterations"),
                                           ({"max_time": -1.0}, "--max-time")])
def test_table_42_takes_exactly_one_valid_budget(budget, field, tmp_path):
    from pliant.errors import ConfigError
    from pliant_piirl.experiments import run_table42

    with pytest.raises(ConfigError) as caught:
        run_table42(**budget, seed=0, output=tmp_path, echo=lambda _: None)
    assert caught.value.field == field
    assert not (tmp_path / "learn-table-4.2").exists()


def test_an_iteration_budget_makes_the_expert_a_function_of_the_seed(planar, expert_demonstration):
    _, _, task = planar
    expert, shown = expert_demonstration
    np.testing.assert_array_equal(expert.demonstrate(task, np.random.default_rng(3)).path, shown.path)
