"""The held-out checks (pliant_piirl.heldout): the interval of ratios the demonstrations allow, on hand cases; the
near-optimal demonstrator; the default objective on one small held-out set (docs/experiments.md, "Development
and held-out sets")."""

import numpy as np
import pytest
from pliant_piirl.heldout import (
    WIDENING,
    NearOptimalDemonstrator,
    allowed_ratio_interval,
    class_ratios,
    groups_of,
    in_order,
    object_order_intervals,
    order_determined,
)


def test_the_allowed_interval_of_a_hand_case():
    # shown (1, 1), on offer (4, 0), (0, 2) and the shown path itself.  With r = S2 / S1 they cost 1 + r, 4 and 2r:
    # the shown path is the cheapest for 1 <= r <= 3; within a slack of 50%, 1 + r <= 6 and 1 + r <= 3r: 0.5 .. 5
    shown, offer = np.array([[1.0, 1.0]]), [np.array([[4.0, 0.0], [0.0, 2.0], [1.0, 1.0]])]
    assert allowed_ratio_interval(shown, offer, 0.0, np.eye(2), 1, 0) == pytest.approx((1.0, 3.0), rel=1e-7)
    assert allowed_ratio_interval(shown, offer, 0.5, np.eye(2), 1, 0) == pytest.approx((0.5, 5.0), rel=1e-7)
    lo, hi = allowed_ratio_interval(shown, offer, 0.0, np.eye(2), 0, 1)         # the other way round
    assert (lo, hi) == pytest.approx((1 / 3, 1.0), rel=1e-7)


def test_two_demonstrations_intersect_and_classes_share_a_value():
    # objects 0 and 1 form one class (value a), object 2 another (value b), r = b / a.  Demonstration 1 deforms the
    # class-0 objects 2 + 1 where it could have deformed object 2 by 1: 3a <= b, r >= 3.  Demonstration 2 deforms
    # object 2 by 1 where it could have deformed object 0 by 5: b <= 5a, r <= 5
    groups = groups_of(["a", "b", "c"], {"a": "low", "b": "low", "c": "high"}, ["low", "high"])
    shown = np.array([[2.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    offer = [np.array([[0.0, 0.0, 1.0]]), np.array([[5.0, 0.0, 0.0]])]
    assert allowed_ratio_interval(shown, offer, 0.0, groups, 1, 0) == pytest.approx((3.0, 5.0), rel=1e-7)
    # demonstration 1 alone: nothing bounds r from above but the box
    assert allowed_ratio_interval(shown[:1], offer[:1], 0.0, groups, 1, 0)[1] == pytest.approx(1e4)
    # contradicting demonstrations allow no ratio: the first needs r >= 1, the second r <= 0.5
    with pytest.raises(ValueError, match="no ratio"):
        allowed_ratio_interval(np.array([[1.0, 0.0], [0.0, 2.0]]), [np.array([[0.0, 1.0]]), np.array([[1.0, 0.0]])],
                               0.0, np.eye(2), 1, 0)


def test_class_ratios_and_order():
    classes = {"L1": "low", "L2": "low", "H1": "high"}
    values = {"L1": 1.0, "L2": 4.0, "H1": 8.0}
    assert class_ratios(values, classes, ["low", "high"]) == {"high/low": pytest.approx(4.0)}
    assert in_order(values, classes, ["low", "high"])
    assert not in_order({**values, "L2": 8.0}, classes, ["low", "high"])


def test_the_order_of_two_objects_is_determined_only_when_no_allowed_value_reverses_it():
    # one low object "a" and one high object "b", r = S_b / S_a.  Shown: 1 unit of "a"; on offer: "b" by 0.5, so
    # S_a <= (1 + slack) 0.5 S_b, r >= 1 / (0.5 (1 + slack)) = 1 / 0.51 with 2% slack: every allowed r is above 1
    names, classes = ["a", "b"], {"a": "low", "b": "high"}
    shown = np.array([[1.0, 0.0]])
    intervals = object_order_intervals(shown, [np.array([[0.0, 0.5]])], 0.02, names, classes, ["low", "high"])
    assert list(intervals) == ["b/a"]
    assert intervals["b/a"] == pytest.approx((1 / 0.51, 1e4), rel=1e-7)
    assert order_determined(intervals)
    # on offer "b" by 1: r >= 1 / 1.02, so a shown path within its slack allows "b" a little below "a"
    intervals = object_order_intervals(shown, [np.array([[0.0, 1.0]])], 0.02, names, classes, ["low", "high"])
    assert intervals["b/a"][0] == pytest.approx(1 / 1.02, rel=1e-7)
    assert not order_determined(intervals)


def test_objects_free_of_their_class_allow_what_a_shared_value_forbids():
    # "a1" and "a2" are low, "b" high.  Shown: a1 by 2 and a2 by 1 where b by 3 was on offer: with a shared low value
    # 3 S_a <= 3 S_b, so r >= 1 (the class interval); each object free, S_a1 may be small and S_a2 large: 2 S_a1 +
    # S_a2 <= 3 S_b allows S_b / S_a2 down to 1 / 3 (and a little more: the other object stays at the box's lower end,
    # 1e-4 with the compared one at 1)
    names, classes = ["a1", "a2", "b"], {"a1": "low", "a2": "low", "b": "high"}
    shown, offer = np.array([[2.0, 1.0, 0.0]]), [np.array([[0.0, 0.0, 3.0]])]
    groups = groups_of(names, classes, ["low", "high"])
    assert allowed_ratio_interval(shown, offer, 0.0, groups, 1, 0)[0] == pytest.approx(1.0, rel=1e-7)
    intervals = object_order_intervals(shown, offer, 0.0, names, classes, ["low", "high"])
    assert intervals["b/a2"][0] == pytest.approx((2e-4 + 1) / 3, rel=1e-7)
    assert intervals["b/a1"][0] == pytest.approx((2 + 1e-4) / 3, rel=1e-7)
    assert not order_determined(intervals)


@pytest.fixture(scope="module")
def cube():
    import pliant
    from pliant_piirl.features import DeformationFeatures
    from pliant_piirl.tasks import TaskSpace

    scene = pliant.load_scene("hollow-cube")
    return DeformationFeatures(scene), TaskSpace(scene)


def test_the_default_objective_on_a_small_held_out_set(cube):
    """Held-out ratios 1 : 2.5 : 5 with low on y, medium on x, high on z, shown by the near-optimal demonstrator
    (coarse search), 6 demonstrations that touch every face twice, 30 samples each, seed 100: the default objective
    (learner.fit's steps otherwise) orders the classes and puts every class ratio within the interval the
    demonstrations allow, widened by 1.25 at each end.  A regression check on one seeded case: sets this small fail
    the order for every objective on some seeds (docs/plugins/piirl.md, "Held-out figures"); the figures are
    ``pliant bench piirl_heldout``'s."""
    from pliant_piirl.expert import ExpertOptions
    from pliant_piirl.piirl import RecoveryOptions, recover
    from pliant_piirl.sampling import PathSampler, SampleOptions
    from pliant_piirl.tasks import rotation_onto

    features, tasks = cube
    order = ["low", "medium", "high"]
    classes = {"M1": "low", "M2": "low", "L1": "medium", "L2": "medium", "H1": "high", "H2": "high"}
    truth = {o: 0.2 * {"low": 1.0, "medium": 2.5, "high": 5.0}[c] for o, c in classes.items()}
    tip = np.array([0.0, 0.0, -0.06])
    demonstrator = NearOptimalDemonstrator(features, truth, tip, ExpertOptions(grid=7, refine=1))
    sampler = PathSampler(features, tip, SampleOptions(samples=30))
    rng = np.random.default_rng(100)
    weights = features.sensitivity_vector(truth)
    shown, offer, demos, samples = [], [], [], []
    for a, b in [("H1", "L1"), ("H2", "M1"), ("L2", "M2"), ("H2", "L2"), ("H1", "M2"), ("L1", "M1")]:
        task = tasks.generate_task(a, b, rng, tip, rotation_onto)
        demonstration = demonstrator.demonstrate(task, rng)
        v = features.of_path(demonstration.path)
        np.testing.assert_allclose(v, demonstrator.shown)
        # the demonstrator's promise: within 2% of the cheapest straight insertion it measured
        assert v @ weights <= 1.02 * (demonstrator.candidates @ weights).min() + 1e-9
        shown.append(v)
        offer.append(demonstrator.candidates)
        better, _, mine, drawn = sampler.improve_with_samples(demonstration, rng)
        if drawn is None:
            _, drawn = sampler.draw_with_features(better, rng)
        demos.append(mine)
        samples.append(drawn)
    recovered = recover(np.array(demos), samples, RecoveryOptions(), rng)["sensitivities"]
    values = dict(zip(features.names, recovered))
    assert in_order(values, classes, order)
    groups = groups_of(features.names, classes, order)
    for key, ratio in class_ratios(values, classes, order).items():
        high, low = (order.index(c) for c in key.split("/"))
        lo, hi = allowed_ratio_interval(shown, offer, 0.02, groups, high, low)
        truth_ratio = class_ratios(truth, classes, order)[key]
        assert lo <= truth_ratio * (1 + 1e-9) and truth_ratio <= hi * (1 + 1e-9)      # the truth is allowed
        assert lo / WIDENING <= ratio <= hi * WIDENING, (key, ratio, lo, hi)
