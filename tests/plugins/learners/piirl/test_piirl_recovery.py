"""Eq. 4.1 (objective "ratio"), the normalised PIIRL likelihood and the ranking objective (the default, its margins
relative to the samples' mean cost or to the demonstration's): known answers on small cases, gradients against finite
differences, invariances, bad input."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from pliant.errors import ConfigError
from pliant_piirl.piirl import RecoveryOptions, _likelihood, _ranking, recover
from scipy.special import expit, logsumexp

RATIO = RecoveryOptions(objective="ratio")
LIKELIHOOD = RecoveryOptions(objective="likelihood")


def test_an_object_the_demonstration_avoids_gets_the_upper_bound_and_the_deformed_one_the_lower():
    # the demonstration deforms object 0 only; its samples also deform object 1
    demos = np.array([[1.0, 0.0]])
    samples = [np.array([[1.0, 1.0], [2.0, 0.5], [1.5, 2.0]])]
    s = recover(demos, samples, RATIO)["sensitivities"]
    assert s[0] == pytest.approx(0.1) and s[1] == pytest.approx(1000.0)


@pytest.mark.parametrize("objective", ["likelihood", "ratio", "ranking"])
def test_a_chain_of_preferences_is_ordered(objective):
    # demo 1 prefers a over b, demo 2 prefers b over c: a < b < c
    demos = np.array([[2.0, 0.5, 0.0], [0.0, 2.0, 0.5]])
    samples = [np.array([[1.0, 2.0, 0.0], [1.5, 1.0, 0.0]]), np.array([[0.0, 1.0, 2.0], [0.0, 1.5, 1.0]])]
    s = recover(demos, samples, RecoveryOptions(objective=objective))["sensitivities"]
    assert s[0] < s[1] < s[2]


def test_the_likelihood_has_the_interior_optimum_where_eq_4_1_goes_to_a_vertex():
    # demonstration (1, 1), samples (4, 0) and (0, 2); with r = S2 / S1 they cost 1 + r, 4 and 2r.  The demonstration
    # is the cheapest for 1 < r < 3, and both samples are farthest above it (each at the top of the normalised range)
    # at r = 2: the likelihood's unique optimum for every h, returned with the smaller sensitivity at the lower bound.
    # (h = 10 here: with a larger h the objective near this optimum, about 2 exp(-h), falls below L-BFGS-B's ftol
    # before r is exact.)
    demos, samples = np.array([[1.0, 1.0]]), [np.array([[4.0, 0.0], [0.0, 2.0]])]
    s = recover(demos, samples, RecoveryOptions(objective="likelihood", temperature=10.0))["sensitivities"]
    assert s == pytest.approx([0.1, 0.2], rel=1e-4)
    assert recover(demos, samples, LIKELIHOOD)["sensitivities"] == pytest.approx([0.1, 0.2], rel=1e-2)
    # eq. 4.1, (1 + r) / (4 + 2r), falls as r falls: it ends at the vertex S1 = upper, S2 = lower, where the sample
    # (0, 2) costs 0.2 and the demonstration 1000.1
    s = recover(demos, samples, RATIO)["sensitivities"]
    assert s == pytest.approx([1000.0, 0.1])


def test_the_ranking_balances_the_samples_relative_margins():
    # the same case: with r = S2 / S1 the samples' relative margins over the demonstration are u1 = (3 - r) / (1 + r)
    # and u2 = (r - 1) / (1 + r).  The ranking's optimum is where 2 sigmoid(-h u1) = sigmoid(-h u2): between the
    # ratios at which the demonstration is the cheapest (1 < r < 3), tending to the equal-margin point r = 2 as h grows
    demos, samples = np.array([[1.0, 1.0]]), [np.array([[4.0, 0.0], [0.0, 2.0]])]
    for h in (3.0, 10.0, 30.0):
        options = RecoveryOptions(objective="ranking", temperature=h, margin="demonstration")
        s = recover(demos, samples, options)["sensitivities"]
        r = s[1] / s[0]
        assert s[0] == pytest.approx(0.1) and 1.0 < r < 3.0
        u1, u2 = (3 - r) / (1 + r), (r - 1) / (1 + r)
        assert 2 * expit(-h * u1) == pytest.approx(expit(-h * u2), rel=1e-4)
    s = recover(demos, samples, RecoveryOptions(objective="ranking", temperature=100.0, margin="demonstration"))[
        "sensitivities"]
    assert s[1] / s[0] == pytest.approx(2.0, rel=1e-2)
    # symmetric samples (3, 0) and (0, 3): equal sensitivities, whatever h and scale
    for margin in ("samples", "demonstration"):
        assert recover(demos, [np.array([[3.0, 0.0], [0.0, 3.0]])], RecoveryOptions(margin=margin))[
            "sensitivities"] == pytest.approx([0.1, 0.1], rel=1e-6)


def test_with_the_samples_scale_the_margins_balance_at_the_same_ratio_by_another_weighting():
    # the same case with the default scale, the samples' mean cost (4 + 2r) / 2 = 2 + r: the margins are
    # u1 = (3 - r) / (2 + r) and u2 = (r - 1) / (2 + r), with the same signs as before, so the optimum stays between
    # the ratios at which the demonstration is the cheapest; with u1' = -5 / (2 + r)^2 and u2' = 3 / (2 + r)^2 it is
    # where 5 sigmoid(-h u1) = 3 sigmoid(-h u2)
    demos, samples = np.array([[1.0, 1.0]]), [np.array([[4.0, 0.0], [0.0, 2.0]])]
    for h in (3.0, 5.0, 30.0):
        s = recover(demos, samples, RecoveryOptions(objective="ranking", temperature=h))["sensitivities"]
        r = s[1] / s[0]
        assert s[0] == pytest.approx(0.1) and 1.0 < r < 3.0
        u1, u2 = (3 - r) / (2 + r), (r - 1) / (2 + r)
        assert 5 * expit(-h * u1) == pytest.approx(3 * expit(-h * u2), rel=1e-4)


def test_along_a_class_the_demonstration_avoids_only_the_samples_scale_keeps_the_ratio_finite():
    # the demonstration deforms object 0 only; of its samples, one deforms object 0 more, one both a little less and
    # object 1.  With r = S1 / S0: c0 = 1, samples 2 and 0.8 + 0.5 r.  Relative to the demonstration, the second
    # sample's margin -0.2 + 0.5 r grows without bound with r, so the ranking drives r to the box's end (1000 / 0.1);
    # relative to the samples' mean (1.4 + 0.25 r) both margins tend to finite limits (-4, 2) and r stops inside
    demos, samples = np.array([[1.0, 0.0]]), [np.array([[2.0, 0.0], [0.8, 0.5]])]
    own = recover(demos, samples, RecoveryOptions(margin="demonstration"))["sensitivities"]
    mean = recover(demos, samples, RecoveryOptions())["sensitivities"]
    assert own[1] / own[0] > 1000
    assert 1.0 < mean[1] / mean[0] < 100


def test_each_objective_has_its_own_default_temperature_and_restarts():
    rng = np.random.default_rng(3)
    demos, samples = rng.uniform(0, 1, (3, 3)), [rng.uniform(0, 2, (6, 3)) for _ in range(3)]
    for objective, h, restarts in (("likelihood", 30.0, 4), ("ratio", None, 2)):
        a = recover(demos, samples, RecoveryOptions(objective=objective))
        b = recover(demos, samples, RecoveryOptions(objective=objective, temperature=h, restarts=restarts))
        assert a["sensitivities"] == pytest.approx(b["sensitivities"]) and a["objective"] == b["objective"]
        assert a["iterations"] == b["iterations"]
        assert a["temperatures"] == ([] if h is None else [h])
    a = recover(demos, samples, RecoveryOptions(margin="demonstration"))
    b = recover(demos, samples, RecoveryOptions(margin="demonstration", temperature=10.0))
    assert a["sensitivities"] == pytest.approx(b["sensitivities"]) and a["objective"] == b["objective"]


def test_the_default_ranking_is_the_geometric_mean_of_its_recoveries_at_h_5_and_10():
    """With the samples' scale and no temperature, the ranking is solved at h = 5 and at h = 10 (the same screened
    starts) and the sensitivities combined by their geometric mean, scaled so that the least sensitive is ``lower``."""
    rng = np.random.default_rng(3)
    demos, samples = rng.uniform(0, 1, (3, 3)), [rng.uniform(0, 2, (6, 3)) for _ in range(3)]
    both = recover(demos, samples, RecoveryOptions())
    five = recover(demos, samples, RecoveryOptions(temperature=5.0, restarts=4))
    ten = recover(demos, samples, RecoveryOptions(temperature=10.0, restarts=4))
    mean = np.sqrt(five["sensitivities"] * ten["sensitivities"])
    np.testing.assert_allclose(both["sensitivities"], mean * (0.1 / mean.min()), rtol=1e-12)
    assert both["temperatures"] == [5.0, 10.0]
    assert both["iterations"] == five["iterations"] + ten["iterations"]
    assert both["sensitivities"].min() == pytest.approx(0.1)
    # between the two: every ratio to the least sensitive lies between the two recoveries' ratios
    r5, r10, rb = (x["sensitivities"] / x["sensitivities"].min() for x in (five, ten, both))
    assert np.all(rb >= np.minimum(r5, r10) - 1e-12) and np.all(rb <= np.maximum(r5, r10) + 1e-12)


def ranking(s, demos, samples, h=5.0, margin="samples"):
    """The ranking objective at ``s`` (one point ``(n,)`` or many ``(P, n)``): the logistic loss of every
    (demonstration, sample) pair's margin relative to the samples' mean cost (or the demonstration's), summed and
    divided by the mean number of samples per demonstration."""
    s = np.atleast_2d(s)
    total = np.zeros(len(s))
    for v, w in zip(demos, samples):
        costs = s @ w.T
        scale = costs.mean(axis=1) if margin == "samples" else s @ v
        m = (costs - (s @ v)[:, None]) / scale[:, None]
        total += np.logaddexp(0.0, -h * m).sum(axis=1)
    total *= len(demos) / sum(len(w) for w in samples)
    return total if len(total) > 1 else float(total[0])


def likelihood(s, demos, samples, h=30.0):
    """The normalised PIIRL negative log-likelihood at ``s`` (one point ``(n,)`` or many ``(P, n)``)."""
    s = np.atleast_2d(s)
    total = np.zeros(len(s))
    for v, w in zip(demos, samples):
        c = np.c_[s @ v, s @ w.T]
        lo, hi = c.min(axis=1, keepdims=True), c.max(axis=1, keepdims=True)
        u = (c - lo) / (hi - lo)
        total += h * u[:, 0] + logsumexp(-h * u, axis=1)
    return total if len(total) > 1 else float(total[0])


#: each objective: its options, its reference implementation above, its batched builder and its default temperature
def ranking_own(s, demos, samples, h=10.0):
    return ranking(s, demos, samples, h, margin="demonstration")


def _ranking_own(demos, samples, h):
    return _ranking(demos, samples, h, margin="demonstration")


OBJECTIVES = {"ranking": (RecoveryOptions(temperature=5.0), ranking, _ranking, 5.0),
              "ranking-demonstration": (RecoveryOptions(margin="demonstration"), ranking_own, _ranking_own, 10.0),
              "likelihood": (LIKELIHOOD, likelihood, _likelihood, 30.0)}


def _no_worse_than_a_random_search(name, seed):
    options, reference, _, _ = OBJECTIVES[name]
    rng = np.random.default_rng(seed)
    demos = rng.uniform(0, 1, (3, 4))
    samples = [rng.uniform(0, 2, (5, 4)) for _ in range(3)]
    result = recover(demos, samples, options)
    s = result["sensitivities"]
    # an absolute tolerance too: near its optimum the likelihood is a small difference of terms of order h (3.2e-4
    # from terms near 30 with seed 1333), where the batched and the reference sums differed by 7e-11 in one CI run
    assert result["objective"] == pytest.approx(reference(s, demos, samples), rel=1e-9, abs=1e-9)
    assert reference(s * 123.0, demos, samples) == pytest.approx(result["objective"], rel=1e-9, abs=1e-9)
    best = reference(rng.uniform(0.1, 1000, (2000, 4)), demos, samples).min()
    assert result["objective"] <= best + 1e-9
    assert s.min() == pytest.approx(0.1) and s.max() <= 1000 + 1e-9


@pytest.mark.parametrize("name", ["ranking", "ranking-demonstration"])
@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000))
def test_the_recovery_is_no_worse_than_any_point_of_a_random_search_and_invariant_to_scale(name, seed):
    _no_worse_than_a_random_search(name, seed)


# The likelihood at h = 30 is multimodal on random features: its screen (512 points) and 4 restarts miss the global
# optimum in about 1 case in 200 (seeds 11 and 206 of 0-399: 4.17 against a random search's 3.90, 11.01 against
# 10.14; docs/plugins/piirl.md).  So it is checked on hypothesis's fixed sequence, not on new draws every run.
@settings(max_examples=15, deadline=None, derandomize=True, database=None)
@given(st.integers(0, 10_000))
@example(2028)                  # with 2 restarts the likelihood stopped at a bound of the log-S box (9.544 > 9.320)
def test_the_likelihoods_recovery_is_no_worse_than_a_random_search_on_a_fixed_sequence(seed):
    _no_worse_than_a_random_search("likelihood", seed)


@pytest.mark.parametrize("name", OBJECTIVES)
def test_the_gradient_matches_finite_differences_with_unequal_sample_counts(name):
    from scipy.optimize import check_grad

    _, reference, build, temperature = OBJECTIVES[name]
    rng = np.random.default_rng(1)
    demos = [rng.uniform(0, 1, 3) for _ in range(4)]
    samples = [rng.uniform(0, 2, (6, 3)) for _ in range(3)] + [rng.uniform(0, 2, (2, 3))]
    objective, batch, _ = build(demos, samples, temperature)
    for s in rng.uniform(0.1, 10, (5, 3)):
        f, g = (lambda x: objective(x)[0]), (lambda x: objective(x)[1])
        assert f(s) == pytest.approx(reference(s, demos, samples), rel=1e-12)   # padding changes nothing
        assert batch(s[None])[0] == pytest.approx(f(s), rel=1e-12)
        assert check_grad(f, g, s, epsilon=1e-7) < 1e-5 * np.linalg.norm(g(s)) + 1e-9


def objective(s, demos, samples):
    scale = max(demos.max(), max(x.max() for x in samples))
    return sum((s @ v / scale) / (s @ w.sum(axis=0) / scale) for v, w in zip(demos, samples))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000))
@example(1707)                  # a local minimum of L-BFGS-B from the chapter's start alone
def test_the_solution_is_no_worse_than_any_point_of_a_random_search(seed):
    rng = np.random.default_rng(seed)
    demos = rng.uniform(0, 1, (3, 4))
    samples = [rng.uniform(0, 2, (5, 4)) for _ in range(3)]
    result = recover(demos, samples, RATIO)
    assert result["objective"] == pytest.approx(objective(result["sensitivities"], demos, samples), rel=1e-9)
    trials = rng.uniform(0.1, 1000, (2000, 4))
    best = min(objective(s, demos, samples) for s in trials)
    assert result["objective"] <= best + 1e-9
    assert np.all(result["sensitivities"] >= 0.1 - 1e-12) and np.all(result["sensitivities"] <= 1000 + 1e-9)


def test_the_gradient_matches_finite_differences():
    from scipy.optimize import check_grad

    rng = np.random.default_rng(1)
    demos, samples = rng.uniform(0, 1, (4, 3)), [rng.uniform(0, 2, (6, 3)) for _ in range(4)]
    scale = max(demos.max(), max(x.max() for x in samples))
    v, w = demos / scale, np.array([x.sum(axis=0) for x in samples]) / scale

    def f(s):
        return float(np.sum((v @ s) / (w @ s)))

    def g(s):
        a, b = v @ s, w @ s
        return (v / b[:, None] - (a / b**2)[:, None] * w).sum(axis=0)

    for s in rng.uniform(0.1, 1000, (5, 3)):
        assert check_grad(f, g, s, epsilon=1e-6 * s.mean()) < 1e-6 * np.linalg.norm(g(s)) + 1e-12


@pytest.mark.parametrize("objective", ["likelihood", "ratio", "ranking"])
def test_scaling_the_features_changes_nothing_and_empty_demonstrations_are_left_out(objective):
    demos = np.array([[1.0, 0.2], [0.0, 0.0]])
    samples = [np.array([[1.0, 1.0], [0.5, 2.0]]), np.array([[1.0, 1.0]])]
    options = RecoveryOptions(objective=objective)
    a, b = recover(demos, samples, options), recover(demos * 37.0, [s * 37.0 for s in samples], options)
    assert np.allclose(a["sensitivities"], b["sensitivities"]) and a["used"] == [0]


def test_nothing_to_learn_from_says_so_and_bad_input_is_an_error():
    assert recover(np.zeros((1, 2)), [np.ones((2, 2))])["message"] == "no informative demonstration"
    with pytest.raises(ConfigError, match="non-negative"):
        recover(np.array([[1.0, -1.0]]), [np.ones((2, 2))])
    with pytest.raises(ConfigError, match="one sample set"):
        recover(np.ones((2, 2)), [np.ones((2, 2))])
    with pytest.raises(ConfigError, match="lower <= initial"):
        recover(np.ones((1, 2)), [np.ones((2, 2))], RecoveryOptions(lower=5.0, initial=1.0))
    with pytest.raises(ConfigError, match="likelihood"):
        recover(np.ones((1, 2)), [np.ones((2, 2))], RecoveryOptions(objective="margin"))
    with pytest.raises(ConfigError, match="samples, demonstration") as raised:
        recover(np.ones((1, 2)), [np.ones((2, 2))], RecoveryOptions(margin="costs"))
    assert raised.value.field == "margin"


# --- alternatives: other paths of each demonstration's task, compared with it by the ranking -------------------

def ranking_with_alternatives(s, demos, samples, alternatives, weight, h=5.0):
    """The ranking at ``s`` ``(P, n)`` with each demonstration also compared with its alternatives, each comparison
    weighing ``weight`` samples'; the margins relative to the samples' mean cost alone."""
    s = np.atleast_2d(s)
    total = np.zeros(len(s))
    for v, w, a in zip(demos, samples, alternatives):
        scale = (s @ w.T).mean(axis=1)
        for paths, each in ((w, 1.0), (a, weight)):
            m = (s @ paths.T - (s @ v)[:, None]) / scale[:, None]
            total += each * np.logaddexp(0.0, -h * m).sum(axis=1)
    return total * len(demos) / sum(len(w) for w in samples)


def test_an_alternative_pulls_the_ratio_toward_where_the_demonstration_stays_cheaper_than_it():
    # the case above (demonstration (1, 1), samples (4, 0) and (0, 2), r = S2 / S1, margins over the samples' mean
    # 2 + r) with one alternative (2.5, 0), weighing w samples: its margin u3 = (1.5 - r) / (2 + r) is negative for
    # r > 1.5, where the demonstration costs more than it.  With u1' = -5, u2' = 3, u3' = -3.5 (over (2 + r)^2) the
    # optimum is where 3 sigmoid(-h u2) = 5 sigmoid(-h u1) + 3.5 w sigmoid(-h u3), lower the more it weighs
    demos, samples, alternative = np.array([[1.0, 1.0]]), [np.array([[4.0, 0.0], [0.0, 2.0]])], [np.array([[2.5, 0.0]])]
    h = 5.0
    plain = recover(demos, samples, RecoveryOptions(temperature=h))["sensitivities"]
    ratios = [plain[1] / plain[0]]
    for w in (1.0, 2.0, 4.0):
        s = recover(demos, samples, RecoveryOptions(temperature=h, alternative_weight=w), alternatives=alternative)[
            "sensitivities"]
        r = s[1] / s[0]
        u1, u2, u3 = (3 - r) / (2 + r), (r - 1) / (2 + r), (1.5 - r) / (2 + r)
        assert 3 * expit(-h * u2) == pytest.approx(5 * expit(-h * u1) + 3.5 * w * expit(-h * u3), rel=1e-4)
        ratios.append(r)
    assert np.all(np.diff(ratios) < 0)          # the more it weighs, the further down (0.82 at w = 4: below 1)


def test_with_alternatives_the_ranking_defaults_to_h_5_and_the_other_objectives_ignore_them():
    rng = np.random.default_rng(4)
    demos, samples = rng.uniform(0, 1, (3, 3)), [rng.uniform(0, 2, (6, 3)) for _ in range(3)]
    alternatives = [rng.uniform(0, 2, (k, 3)) for k in (4, 0, 2)]
    compared = recover(demos, samples, RecoveryOptions(), alternatives=alternatives)
    five = recover(demos, samples, RecoveryOptions(temperature=5.0), alternatives=alternatives)
    assert compared["temperatures"] == [5.0]
    np.testing.assert_array_equal(compared["sensitivities"], five["sensitivities"])
    plain = recover(demos, samples, RecoveryOptions())
    assert plain["temperatures"] == [5.0, 10.0]
    assert not np.allclose(compared["sensitivities"], plain["sensitivities"])
    # none given, none to compare with, or a weight of 0: the recovery without them
    for kwargs, options in (({"alternatives": [np.zeros((0, 3))] * 3}, RecoveryOptions()),
                            ({"alternatives": alternatives}, RecoveryOptions(alternative_weight=0.0))):
        np.testing.assert_array_equal(recover(demos, samples, options, **kwargs)["sensitivities"],
                                      plain["sensitivities"])
    for options in (LIKELIHOOD, RATIO):
        np.testing.assert_array_equal(recover(demos, samples, options, alternatives=alternatives)["sensitivities"],
                                      recover(demos, samples, options)["sensitivities"])


def test_the_ranking_with_alternatives_matches_its_reference_and_finite_differences():
    from scipy.optimize import check_grad

    rng = np.random.default_rng(2)
    demos = [rng.uniform(0, 1, 3) for _ in range(3)]
    samples = [rng.uniform(0, 2, (k, 3)) for k in (6, 3, 5)]
    alternatives = [rng.uniform(0, 2, (k, 3)) for k in (2, 0, 7)]
    objective, batch, _ = _ranking(demos, samples, 5.0, "samples", alternatives, 3.0)
    for s in rng.uniform(0.1, 10, (5, 3)):
        f, g = (lambda x: objective(x)[0]), (lambda x: objective(x)[1])
        assert f(s) == pytest.approx(ranking_with_alternatives(s, demos, samples, alternatives, 3.0)[0], rel=1e-12)
        assert batch(s[None])[0] == pytest.approx(f(s), rel=1e-12)
        assert check_grad(f, g, s, epsilon=1e-7) < 1e-5 * np.linalg.norm(g(s)) + 1e-9


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000))
def test_the_recovery_with_alternatives_is_no_worse_than_any_point_of_a_random_search(seed):
    rng = np.random.default_rng(seed)
    demos = rng.uniform(0, 1, (3, 4))
    samples = [rng.uniform(0, 2, (5, 4)) for _ in range(3)]
    alternatives = [rng.uniform(0, 2, (3, 4)) for _ in range(3)]
    result = recover(demos, samples, RecoveryOptions(), alternatives=alternatives)
    s = result["sensitivities"]
    assert result["objective"] == pytest.approx(
        ranking_with_alternatives(s, demos, samples, alternatives, 2.0)[0], rel=1e-9, abs=1e-9)
    best = ranking_with_alternatives(rng.uniform(0.1, 1000, (2000, 4)), demos, samples, alternatives, 2.0).min()
    assert result["objective"] <= best + 1e-9


def test_alternatives_are_checked_like_samples():
    demos, samples = np.ones((2, 2)), [np.ones((2, 2))] * 2
    with pytest.raises(ConfigError, match="one set of alternatives") as raised:
        recover(demos, samples, alternatives=[np.ones((1, 2))])
    assert raised.value.field == "alternatives"
    with pytest.raises(ConfigError, match="non-negative"):
        recover(demos, samples, alternatives=[np.ones((1, 2)), -np.ones((1, 2))])
