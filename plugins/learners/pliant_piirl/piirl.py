"""PIIRL parameter recovery, thesis eq. 4.1 (the chapter's modified form of Kalakrishnan et al.'s objective).

    S_hat = argmin_S  sum_k  (S . V_k) / (sum_l S . V_kl),     lower <= S_i <= upper

``V_k`` are the features of demonstration ``k`` and ``V_kl`` those of its ``l``-th sample path, all divided by
the largest feature value (the chapter's normalisation).  The objective is homogeneous of degree 0 in ``S``: only
ratios are recovered, and the bounds fix the scale (the chapter: lower 0.1, upper 1000, start 500).  A
demonstration with no deformation at all, or whose samples deform nothing, carries no information and is left
out (the chapter: "can be removed from the optimization").

Solver: scipy's L-BFGS-B (bounded quasi-Newton) with the analytic gradient
``d/dS [a / b] = V_k / b - a * W_k / b^2`` (``a = S . V_k``, ``W_k = sum_l V_kl``, ``b = S . W_k``), stopping when
the relative change of the objective falls below ``tolerance`` or the projected gradient below ``tolerance``
times the objective.  The chapter used MATLAB's function minimisation.  A sum of ratios is not convex, and
L-BFGS-B from the chapter's start alone can stop in a local minimum (a property test found one); so the objective
is also evaluated at ``screen`` points spread log-uniformly over the box (a fixed seed: the answer is
deterministic), L-BFGS-B runs again from the ``restarts`` best of them, and the best solution is returned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.errors import ConfigError
from pliant.options import option
from scipy.optimize import minimize


@dataclass(frozen=True)
class RecoveryOptions:
    """Options of eq. 4.1's minimisation."""

    lower: float = option(0.1, "lower bound of every sensitivity (thesis 0.1)", minimum=1e-12)
    upper: float = option(1000.0, "upper bound of every sensitivity (thesis 1000)", minimum=1e-12)
    initial: float = option(500.0, "initial value of every sensitivity (thesis 500)", minimum=1e-12)
    tolerance: float = option(1e-12, "L-BFGS-B's ftol and (relative) pgtol", minimum=0.0)
    max_iterations: int = option(10_000, "L-BFGS-B iteration limit", minimum=1)
    screen: int = option(512, "points of the box screened for restarts (log-uniform, fixed seed)", minimum=0)
    restarts: int = option(2, "extra L-BFGS-B runs from the best screened points", minimum=0)


def recover(demonstrations: np.ndarray, samples: list[np.ndarray], options: RecoveryOptions | None = None) -> dict:
    """Solve eq. 4.1.  ``demonstrations`` ``(K, n)``; ``samples[k]`` ``(L_k, n)``.  Returns ``sensitivities``
    ``(n,)``, ``objective``, ``used`` (indices of the informative demonstrations), ``iterations``, ``message``."""
    o = options or RecoveryOptions()
    if not o.lower <= o.initial <= o.upper:
        raise ConfigError("lower <= initial <= upper is required", field="recovery",
                          value=[o.lower, o.initial, o.upper])
    demos = np.asarray(demonstrations, dtype=np.float64)
    if demos.ndim != 2 or len(samples) != len(demos):
        raise ConfigError("one sample set per demonstration, features (K, n)", field="samples",
                          value=[demos.shape, len(samples)])
    sums = np.array([np.asarray(s, dtype=np.float64).reshape(-1, demos.shape[1]).sum(axis=0) if len(s) else
                     np.zeros(demos.shape[1]) for s in samples])
    if not (np.all(np.isfinite(demos)) and np.all(np.isfinite(sums)) and np.all(demos >= 0) and np.all(sums >= 0)):
        raise ConfigError("features must be finite and non-negative", field="features")
    used = np.flatnonzero((demos.sum(axis=1) > 0) & (sums.sum(axis=1) > 0))
    n = demos.shape[1]
    if len(used) == 0:
        return {"sensitivities": np.full(n, o.initial), "objective": float("nan"), "used": [], "iterations": 0,
                "message": "no informative demonstration"}
    scale = max(demos[used].max(), max(np.asarray(samples[k]).max() for k in used))
    v = demos[used] / scale
    w = sums[used] / scale

    def objective(s):
        a, b = v @ s, w @ s
        f = float(np.sum(a / b))
        grad = (v / b[:, None] - (a / b**2)[:, None] * w).sum(axis=0)
        return f, grad

    starts = [np.full(n, o.initial)]
    if o.screen and o.restarts:
        rng = np.random.default_rng(0)
        points = np.exp(rng.uniform(np.log(o.lower), np.log(o.upper), (o.screen, n)))
        values = np.sum((points @ v.T) / (points @ w.T), axis=1)
        starts += [points[k] for k in np.argsort(values)[:o.restarts]]
    best, iterations = None, 0
    for start in starts:
        result = minimize(objective, start, jac=True, method="L-BFGS-B", bounds=[(o.lower, o.upper)] * n,
                          options={"ftol": o.tolerance, "gtol": o.tolerance, "maxiter": o.max_iterations})
        iterations += int(result.nit)
        if best is None or result.fun < best.fun - 1e-15:
            best = result
    return {"sensitivities": np.asarray(best.x), "objective": float(best.fun), "used": used.tolist(),
            "iterations": iterations, "message": str(best.message)}
