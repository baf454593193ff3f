"""PIIRL parameter recovery (thesis 4.3.3): a ranking of each demonstration against its samples (the default),
eq. 4.1 as printed, and the likelihood of Kalakrishnan et al. it modifies.

``objective = "ranking"`` (the default): every sample should cost more than its demonstration.  Each
(demonstration, sample) pair is one comparison, scored by the logistic loss of the sample's relative margin::

    S_hat = argmin_S  (K / sum_k L_k)  sum_k sum_l log(1 + exp(-h m_kl)),    lower <= S_i <= upper
    m_kl = (c_kl - c_k0) / cbar_k,    cbar_k = (1 / L_k) sum_l c_kl          (margin = "samples", the default)
    m_kl = (c_kl - c_k0) / c_k0                                             (margin = "demonstration")

``h`` is ``temperature`` (10 with the demonstration's scale; with the samples' scale, by default, the ranking is
solved at h = 5 and at h = 10 and the two sensitivity vectors are combined by their geometric mean: chosen on
development trials, because one h overshoots the ratios of near-optimal demonstrations and the other undershoots
the simulated expert's).  A sample ``1 / h`` of the scale
costlier than its demonstration adds ``log(1 + 1/e)``, one as costly adds ``log 2``, and a cheaper one about
``h |m|``.  Either scale makes the objective invariant to the scale of ``S`` without the likelihood's normalisation
by the costliest sample, which compresses the recovered ratios.  The scale decides what happens along a direction
the demonstrations avoid (a class a near-optimal demonstrator keeps away from, but some samples touch): measured
against the demonstration's own cost, which does not grow along it, the margins grow without bound, and the ratios
overshoot (high / low 31.8 where the demonstrations allow at most 16.8); measured against the samples' mean cost,
which grows along it too, every margin stays below ``max_l c_kl / cbar_k - 1``, and the recovery stops where the
comparisons balance.  docs/plugins/piirl.md gives the measurements, on development and held-out sets.

**Alternatives** (the learner's default since session 38): each demonstration is also compared with the straight
insertions of its own task (:mod:`pliant_piirl.alternatives`), each such comparison weighing ``alternative_weight``
(2) samples', the margins still relative to its samples' mean cost; the ranking's default temperature is then
h = 5 alone.  The samples say which way is better near the demonstration, the alternatives whether another way
into the same target would have been cheaper: only those bound the ratios a near-optimal demonstrator allows
(docs/plugins/piirl.md, "Alternatives", has the development and held-out figures).

``objective = "ratio"`` is thesis eq. 4.1, the chapter's "modified form" of Kalakrishnan et al.'s objective::

    S_hat = argmin_S  sum_k  (S . V_k) / (sum_l S . V_kl),     lower <= S_i <= upper

``objective = "likelihood"`` is the form eq. 4.1 modifies, the PIIRL likelihood of the demonstration among its
samples (the chapter's [8]), with PI^2's per-demonstration cost normalisation::

    S_hat = argmin_S  sum_k  [ h u_k0 + log sum_j exp(-h u_kj) ],    lower <= S_i <= upper
    u_kj = (c_kj - min_j c_kj) / (max_j c_kj - min_j c_kj)

where ``c_k0 = S . V_k`` is the demonstration's cost, ``c_kl = S . V_kl`` (``l >= 1``) its samples' and ``j`` runs
over the demonstration and its samples; ``h`` is ``temperature`` (30 for this objective).  ``exp(-h u_k0) / sum_j
exp(-h u_kj)`` is the
probability of the demonstration among its samples; without the normalisation it grows without bound along
any direction in which the demonstration is cheaper than every sample, and the optimum sits at the bounds (the scale
problem of maximum-likelihood IRL); with it, only ratios matter, and a demonstration that is optimal among its
samples has an interior optimum.  ``h`` sets how much the samples nearest the demonstration's cost weigh: as
``h`` grows the objective tends to the smallest normalised margin between the demonstration and its samples (the
chapter's "maximize the margin").  PI^2 uses 10; 30 was chosen after h = 10 recovered one active-learning
trial out of order (docs/plugins/piirl.md gives the measurements).

All three objectives are homogeneous of degree 0 in ``S``: only ratios are recovered.  ``V_k`` are the features of
demonstration ``k`` and ``V_kl`` those of its ``l``-th sample path, all divided by the largest feature value (the
chapter's normalisation).  A demonstration with no deformation at all, or whose samples deform nothing, carries no
information and is left out (the chapter: "can be removed from the optimization").

Why eq. 4.1 is not the default (docs/plugins/piirl.md, "PIIRL"): eq. 4.1 compares the demonstration with the *sum*
(the mean) of its samples.  Each term is a linear-fractional function of ``S``, smallest at a vertex of the box:
it puts all the weight on the feature the demonstration deforms least relative to its samples' mean.  The chapter
states that its minimisation "maximize[s] the margin between the cost of the demonstrations and the costs of their
samples" and that "all samples around a demonstration will be sub-optimal"; on our expert's demonstrations eq. 4.1's
optimum makes 23 to 50 of each demonstration's 100 samples cheaper than it.  The likelihood and the ranking score
the demonstration against every sample.

Solver: scipy's L-BFGS-B (bounded quasi-Newton) with the analytic gradient, stopping when the relative change of the
objective falls below ``tolerance`` or the projected gradient below ``tolerance`` times the objective. Eq. 4.1 is
solved in ``S`` (gradient ``V_k / b - a W_k / b^2`` with ``a = S . V_k``, ``W_k = sum_l V_kl``, ``b = S . W_k``);
the likelihood and the ranking in ``log S`` (their gradients are orthogonal to the ray ``S``, so a step never only
rescales). The chapter used MATLAB's function minimisation. None of the objectives is convex, and L-BFGS-B from the
chapter's start alone can stop in a local minimum (a property test found one for eq. 4.1); so the objective is also
evaluated at ``screen`` points spread log-uniformly over the box (a fixed seed: the answer is deterministic),
L-BFGS-B runs again from the ``restarts`` best of them (2 for eq. 4.1, 4 for the others), and the best solution is
returned. The likelihood's and the ranking's solution is a ray; it is returned scaled so that the smallest
sensitivity of an object some used demonstration or sample deforms is ``lower`` (as eq. 4.1's least sensitive
objects end at the lower bound); objects no used path deforms keep their start value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import ConfigError, option, stream
from scipy.optimize import minimize

OBJECTIVES = ("likelihood", "ratio", "ranking")
#: the likelihood's temperature when ``temperature`` is None (ratio has none; the ranking's is below)
TEMPERATURES = {"likelihood": 30.0}
#: the ranking's temperatures by the scale of its margins, when ``temperature`` is None: with the samples' scale one
#: recovery at h = 5 and one at h = 10, combined by the geometric mean (chosen on development trials, session 25:
#: h = 5 overshoots the large ratios of near-optimal demonstrations, h = 10 undershoots the simulated expert's)
RANKING_TEMPERATURES = {"samples": (5.0, 10.0), "demonstration": (10.0,)}
#: the ranking's temperature when ``temperature`` is None and the demonstrations come with alternatives (session 38:
#: chosen with them on 44 development trials, docs/plugins/piirl.md "Alternatives")
RANKING_TEMPERATURES_WITH_ALTERNATIVES = {"samples": (5.0,), "demonstration": (10.0,)}
MARGINS = ("samples", "demonstration")
#: each objective's extra L-BFGS-B runs when ``restarts`` is None.  The likelihood and the ranking are solved in
#: log S inside the box, where the ray of solutions can stop at a bound: with 2 restarts a property test found the
#: likelihood at 9.544 where a random point gave 9.320 (4 restarts: 9.273)
RESTARTS = {"ratio": 2, "likelihood": 4, "ranking": 4}


@dataclass(frozen=True)
class RecoveryOptions:
    """Options of the recovery's minimisation."""

    objective: str = option("ranking", "ranking: every sample should cost more than its demonstration (logistic "
                            "loss of the relative margin); likelihood: PIIRL's likelihood with PI^2's "
                            "normalisation; ratio: eq. 4.1",
                            choices=OBJECTIVES)
    temperature: float | None = option(None, "h of the likelihood or the ranking (None: likelihood 30; ranking 5 "
                                       "with alternatives, else the geometric mean of h = 5 and 10, or 10 with "
                                       "margin 'demonstration'; unused by ratio)", minimum=1e-9)
    margin: str = option("samples", "the ranking's margins are relative to: samples (each demonstration's samples' "
                         "mean cost) or demonstration (its own cost, the default before 2026-11-29); unused by "
                         "likelihood and ratio", choices=MARGINS)
    alternative_weight: float = option(2.0, "weight of one comparison with an alternative straight insertion, in "
                                       "comparisons with a sample (the ranking only)", minimum=0.0)
    lower: float = option(0.1, "lower bound of every sensitivity (thesis 0.1)", minimum=1e-12)
    upper: float = option(1000.0, "upper bound of every sensitivity (thesis 1000)", minimum=1e-12)
    initial: float = option(500.0, "initial value of every sensitivity (thesis 500)", minimum=1e-12)
    tolerance: float = option(1e-12, "L-BFGS-B's ftol and (relative) pgtol", minimum=0.0)
    max_iterations: int = option(10_000, "L-BFGS-B iteration limit", minimum=1)
    screen: int = option(512, "points of the box screened for restarts (log-uniform, fixed seed)", minimum=0)
    restarts: int | None = option(None, "extra L-BFGS-B runs from the best screened points (None: 2 for ratio, 4 for "
                                  "likelihood and ranking)", minimum=0)

    def validate(self) -> None:
        """``lower <= initial <= upper``, checked when the options are built (before any sample is drawn)."""
        if self.lower > self.upper:
            raise ConfigError(f"lower ({self.lower:g}) is above upper ({self.upper:g}): the sensitivities' box is "
                              "empty", field="lower", value=self.lower)
        if not self.lower <= self.initial <= self.upper:
            raise ConfigError(f"initial must lie within lower .. upper ({self.lower:g} .. {self.upper:g}); set it "
                              "with the bounds", field="initial", value=self.initial)


def recover(demonstrations: np.ndarray, samples: list[np.ndarray], options: RecoveryOptions | None = None,
            rng: np.random.Generator | None = None, alternatives: list[np.ndarray] | None = None) -> dict:
    """Recover the sensitivities.  ``demonstrations`` ``(K, n)``; ``samples[k]`` ``(L_k, n)``.  Returns
    ``sensitivities`` ``(n,)``, ``objective``, ``used`` (indices of the informative demonstrations), ``iterations``,
    ``message`` and ``temperatures`` (the h used: none for ratio, one (5) for the ranking's default with
    alternatives, two without them, whose ``objective`` is then the mean of the two minima and ``iterations`` their
    sum).  ``rng``: draws the screen's candidate starting
    points (the learner passes its learning stream; every temperature uses the same points); without one they are a
    fixed design (the stream of seed 0's "piirl-screen" task), so that the recovery is a function of its data and
    options.  ``alternatives[k]`` ``(m_k, n)``: other paths of demonstration ``k``'s task
    (:func:`~pliant_piirl.alternatives.straight_alternatives`); the ranking compares the demonstration with them as
    with its samples, each comparison weighing ``alternative_weight`` samples', its margins still relative to the
    samples' mean cost.  The likelihood and eq. 4.1 use the samples alone, as printed."""
    o = options or RecoveryOptions()
    if not o.lower <= o.initial <= o.upper:
        raise ConfigError("lower <= initial <= upper is required", field="recovery",
                          value=[o.lower, o.initial, o.upper])
    if o.objective not in OBJECTIVES:
        raise ConfigError(f"must be one of {', '.join(OBJECTIVES)}", field="objective", value=o.objective)
    if o.margin not in MARGINS:
        raise ConfigError(f"must be one of {', '.join(MARGINS)}", field="margin", value=o.margin)
    demos = np.asarray(demonstrations, dtype=np.float64)
    if demos.ndim != 2 or len(samples) != len(demos):
        raise ConfigError("one sample set per demonstration, features (K, n)", field="samples",
                          value=[demos.shape, len(samples)])
    n = demos.shape[1]
    samples = [np.asarray(s, dtype=np.float64).reshape(-1, n) for s in samples]
    if alternatives is not None and len(alternatives) != len(demos):
        raise ConfigError("one set of alternatives per demonstration", field="alternatives",
                          value=[len(demos), len(alternatives)])
    others = [np.zeros((0, n)) if alternatives is None else np.asarray(alternatives[k], dtype=np.float64).reshape(-1, n)
              for k in range(len(demos))]
    sums = np.array([s.sum(axis=0) if len(s) else np.zeros(n) for s in samples])
    if not (np.all(np.isfinite(demos)) and all(np.all(np.isfinite(s)) and np.all(s >= 0) for s in samples + others)
            and np.all(demos >= 0)):
        raise ConfigError("features must be finite and non-negative", field="features")
    used = np.flatnonzero((demos.sum(axis=1) > 0) & (sums.sum(axis=1) > 0))
    if len(used) == 0:
        return {"sensitivities": np.full(n, o.initial), "objective": float("nan"), "used": [], "iterations": 0,
                "message": "no informative demonstration", "temperatures": []}
    scale = max(demos[used].max(), max(samples[k].max() for k in used))
    compared = o.objective == "ranking" and o.alternative_weight > 0 and any(len(others[k]) for k in used)
    if o.temperature is not None:
        temperatures = (o.temperature,)
    elif o.objective == "ranking":
        temperatures = (RANKING_TEMPERATURES_WITH_ALTERNATIVES if compared else RANKING_TEMPERATURES)[o.margin]
    else:
        temperatures = (TEMPERATURES.get(o.objective),)
    restarts = RESTARTS[o.objective] if o.restarts is None else o.restarts
    points = None
    if o.screen and restarts:
        rng = rng if rng is not None else stream(0, "task", "piirl-screen")
        points = np.exp(rng.uniform(np.log(o.lower), np.log(o.upper), (o.screen, n)))
    runs = [_solve(demos, samples, sums, used, scale, o, h, points, restarts, others if compared else None)
            for h in temperatures]
    if len(runs) == 1:
        return {**runs[0], "temperatures": [] if temperatures[0] is None else [float(temperatures[0])]}
    # several temperatures: the geometric mean of their sensitivities, scaled again as one recovery is (the least
    # sensitive object some used path deforms at ``lower``)
    s = np.exp(np.mean([np.log(r["sensitivities"]) for r in runs], axis=0))
    s = _scaled_to_lower(s, demos, sums, used, o)
    return {"sensitivities": s, "objective": float(np.mean([r["objective"] for r in runs])), "used": runs[0]["used"],
            "iterations": sum(r["iterations"] for r in runs), "message": "; ".join(r["message"] for r in runs),
            "temperatures": [float(h) for h in temperatures]}


def _solve(demos: np.ndarray, samples: list[np.ndarray], sums: np.ndarray, used: np.ndarray, scale: float,
           o: RecoveryOptions, h: float | None, points: np.ndarray | None, restarts: int,
           others: list[np.ndarray] | None = None) -> dict:
    """One recovery at temperature ``h``: L-BFGS-B from ``initial`` and from the ``restarts`` best screened
    ``points``; the result as :func:`recover` returns it.  ``others``: the ranking's alternatives (or None)."""
    n = demos.shape[1]
    if o.objective == "ratio":
        objective, batch, log_space = _ratio(demos[used] / scale, sums[used] / scale)
    elif o.objective == "ranking":
        objective, batch, log_space = _ranking([demos[k] / scale for k in used], [samples[k] / scale for k in used], h,
                                               o.margin, None if others is None else [others[k] / scale for k in used],
                                               o.alternative_weight)
    else:
        objective, batch, log_space = _likelihood([demos[k] / scale for k in used], [samples[k] / scale for k in used],
                                                  h)
    starts = [np.full(n, o.initial)]
    if points is not None:
        starts += [points[k] for k in np.argsort(batch(points))[:restarts]]
    if log_space:
        def fun(x):
            f, g = objective(np.exp(x))
            return f, g * np.exp(x)
        bounds = [(np.log(o.lower), np.log(o.upper))] * n
        starts = [np.log(s) for s in starts]
    else:
        fun, bounds = objective, [(o.lower, o.upper)] * n
    best, iterations = None, 0
    for start in starts:
        result = minimize(fun, start, jac=True, method="L-BFGS-B", bounds=bounds,
                          options={"ftol": o.tolerance, "gtol": o.tolerance, "maxiter": o.max_iterations})
        iterations += int(result.nit)
        if best is None or result.fun < best.fun - 1e-15:
            best = result
    s = np.exp(best.x) if log_space else np.asarray(best.x)
    if log_space:
        s = _scaled_to_lower(s, demos, sums, used, o)
    return {"sensitivities": s, "objective": float(best.fun), "used": used.tolist(), "iterations": iterations,
            "message": str(best.message)}


def _scaled_to_lower(s: np.ndarray, demos: np.ndarray, sums: np.ndarray, used: np.ndarray,
                     o: RecoveryOptions) -> np.ndarray:
    """A ray of solutions ``s`` scaled so that the least sensitive object some used demonstration or sample deforms
    is at ``lower`` (clipped to the box); objects no used path deforms keep their value."""
    touched = (demos[used].sum(axis=0) + sums[used].sum(axis=0)) > 0
    return np.where(touched, np.clip(s * (o.lower / s[touched].min()), o.lower, o.upper), s)


def _ratio(v: np.ndarray, w: np.ndarray):
    """Eq. 4.1 with ``v`` the demonstrations' features and ``w`` the sums of their samples' (both scaled)."""

    def objective(s):
        a, b = v @ s, w @ s
        f = float(np.sum(a / b))
        grad = (v / b[:, None] - (a / b**2)[:, None] * w).sum(axis=0)
        return f, grad

    def batch(points):
        return np.sum((points @ v.T) / (points @ w.T), axis=1)

    return objective, batch, False


def _likelihood(demos: list[np.ndarray], samples: list[np.ndarray], h: float):
    """The normalised PIIRL negative log-likelihood.  ``F[k, 0]`` is demonstration ``k``, ``F[k, 1:]`` its samples;
    a demonstration with fewer samples than the most is padded with copies of itself, which cost what it costs (so
    they move neither the minimum nor the maximum) and carry weight 0 in the sum of exponentials."""
    K, n = len(demos), len(demos[0])
    M = 1 + max(len(s) for s in samples)
    F = np.empty((K, M, n))
    weight = np.zeros((K, M))
    for k, (v, s) in enumerate(zip(demos, samples)):
        F[k] = v
        F[k, 1:1 + len(s)] = s
        weight[k, :1 + len(s)] = 1.0
    rows = np.arange(K)

    def normalised(c):
        lo_i, hi_i = c.argmin(axis=-1), c.argmax(axis=-1)
        lo = np.take_along_axis(c, lo_i[..., None], -1)
        span = np.take_along_axis(c, hi_i[..., None], -1) - lo
        varies = span > 1e-12 * np.abs(lo) + 1e-300      # a demonstration whose paths all cost the same says nothing
        u = (c - lo) / np.where(varies, span, 1.0)
        return u, lo_i, hi_i, span[..., 0], varies[..., 0]

    def objective(s):
        u, lo_i, hi_i, span, varies = normalised(F @ s)
        e = weight * np.exp(-h * u)
        total = e.sum(axis=1)
        f = float(np.sum(np.where(varies, h * u[:, 0] + np.log(total), 0.0)))
        wts = -h * e / total[:, None]
        wts[:, 0] += h
        wts *= (varies / np.where(varies, span, 1.0))[:, None]
        grad = np.einsum("km,kmn->n", wts, F) - (wts * u).sum(axis=1) @ (F[rows, hi_i] - F[rows, lo_i])
        return f, grad

    def batch(points):
        u, _, _, _, varies = normalised(np.einsum("kmn,pn->pkm", F, points))
        terms = h * u[..., 0] + np.log((weight * np.exp(-h * u)).sum(axis=-1))
        return np.where(varies, terms, 0.0).sum(axis=-1)

    return objective, batch, True


def _ranking(demos: list[np.ndarray], samples: list[np.ndarray], h: float, margin: str = "samples",
             alternatives: list[np.ndarray] | None = None, alternative_weight: float = 1.0):
    """The ranking objective: every sample should cost more than its demonstration.  Each (demonstration, sample)
    pair is one comparison and adds the logistic loss ``log(1 + exp(-h m))`` of the relative margin ``m = (c_l -
    c_0) / b``, with ``b`` the mean cost of the demonstration's samples (``margin = "samples"``) or its own cost
    ``c_0`` (``"demonstration"``); the sum is divided by the mean number of samples per demonstration (with equal
    counts, each demonstration weighs one; a demonstration with fewer valid samples offers fewer comparisons and weighs
    less).  ``F0[k]`` is demonstration ``k``, ``F[k]`` its samples, padded with weight 0, ``Fb[k]`` the features of
    ``b`` (``b = Fb[k] . S``: the samples' mean, or the demonstration).  Demonstrations that deform nothing, or whose
    samples deform nothing, are left out before this is called, so ``b > 0`` for ``S > 0``.  ``alternatives[k]``:
    more paths to compare demonstration ``k`` with, each comparison weighing ``alternative_weight`` times a
    sample's; ``b`` stays the samples' mean (or the demonstration's cost)."""
    from scipy.special import expit

    K, n = len(demos), len(demos[0])
    others = alternatives if alternatives is not None else [np.zeros((0, n))] * K
    L = max(len(s) + len(a) for s, a in zip(samples, others))
    F0 = np.array(demos)
    F = np.zeros((K, L, n))
    weight = np.zeros((K, L))
    each = K / sum(len(s) for s in samples)
    for k, (s, a) in enumerate(zip(samples, others)):
        F[k, :len(s)] = s
        weight[k, :len(s)] = each
        F[k, len(s):len(s) + len(a)] = a
        weight[k, len(s):len(s) + len(a)] = each * alternative_weight
    Fb = np.array([s.mean(axis=0) for s in samples]) if margin == "samples" else F0

    def objective(s):
        c0, b = F0 @ s, Fb @ s                              # (K,)
        c = F @ s                                           # (K, L)
        m = (c - c0[:, None]) / b[:, None]
        f = float(np.sum(weight * np.logaddexp(0.0, -h * m)))
        dm = -h * weight * expit(h * -m)                    # d loss / d m
        # dm/dS = (F - F0) / b - m Fb / b
        grad = (np.einsum("kl,kln->n", dm / b[:, None], F) - (dm.sum(axis=1) / b) @ F0
                - ((dm * m).sum(axis=1) / b) @ Fb)
        return f, grad

    def batch(points):
        c0, b = points @ F0.T, points @ Fb.T                # (P, K)
        c = np.einsum("kln,pn->pkl", F, points)
        m = (c - c0[..., None]) / b[..., None]
        return np.sum(weight * np.logaddexp(0.0, -h * m), axis=(1, 2))

    return objective, batch, True
