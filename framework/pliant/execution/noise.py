"""Actuation noise models shared by every simulator (thesis 5.4.1, 5.4.2 and eq. 6.14-6.15).

Noise is an error added to a commanded tangent velocity (m/s, rad/s), drawn from a zero-mean normal
distribution truncated to ``[-lim, lim]`` with ``sigma = lim / 2`` — a bounded model of real
actuators (thesis 5.4.1).  The models differ in the bound ``lim`` of each actuator ``d``:

``none``
    no noise.
``bounded``
    a fixed bound per actuator: ``lim_d = bound_d`` (thesis 5.4.1: ``gamma`` m/s for translation,
    ``gamma / 4`` rad/s for rotation).
``proportional``
    proportional to the commanded velocity: ``lim_d = gamma * |v_d|`` (thesis 5.4.2, Baxter).
``floor``
    eq. 6.14: ``lim_d = max(alpha * |v_d|, alpha / 4 * vmax_d)`` with the actuator's velocity limit
    ``vmax_d`` (thesis 6.5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pliant.errors import ConfigError

NOISE_MODELS = ("none", "bounded", "proportional", "floor")


def truncated_normal(rng: np.random.Generator, limit: np.ndarray) -> np.ndarray:
    """Zero-mean normal samples with ``sigma = limit / 2``, truncated to ``[-limit, limit]`` (same shape).

    Rejection sampling: about 95% of draws are accepted, the rest are redrawn.
    """
    limit = np.asarray(limit, dtype=np.float64)
    out = rng.standard_normal(limit.shape) * 0.5
    bad = np.abs(out) > 1.0
    while bad.any():
        out[bad] = rng.standard_normal(int(bad.sum())) * 0.5
        bad = np.abs(out) > 1.0
    return out * limit


@dataclass(frozen=True)
class ActuationNoise:
    """A noise model; see the module docstring for the models.

    model: one of :data:`NOISE_MODELS`.
    scale: ``(t,)`` per-actuator parameter: the bound (``bounded``, m/s or rad/s) or the
        dimensionless factor gamma / alpha (``proportional`` / ``floor``).
    velocity_limit: ``(t,)`` actuator velocity limits, needed by ``floor``.
    """

    model: str = "none"
    scale: np.ndarray | None = None
    velocity_limit: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.model not in NOISE_MODELS:
            raise ConfigError(f"unknown noise model (models: {', '.join(NOISE_MODELS)})", field="noise",
                              value=self.model)
        if self.model != "none":
            scale = np.asarray(self.scale, dtype=np.float64)
            if scale.ndim != 1 or not np.all(np.isfinite(scale)) or np.any(scale < 0):
                raise ConfigError("noise scale must be finite and non-negative per actuator", field="noise_scale",
                                  value=None if self.scale is None else np.asarray(self.scale).tolist())
        if self.model == "floor" and self.velocity_limit is None:
            raise ConfigError("the floor model (eq. 6.14) needs the actuators' velocity limits",
                              field="velocity_limit")

    def limits(self, velocity: np.ndarray) -> np.ndarray:
        """Per-actuator bounds ``lim`` for commanded velocities ``(..., t)``."""
        velocity = np.asarray(velocity, dtype=np.float64)
        if self.model == "none":
            return np.zeros_like(velocity)
        scale = np.asarray(self.scale, dtype=np.float64)
        if self.model == "bounded":
            return np.broadcast_to(scale, velocity.shape).copy()
        if self.model == "proportional":
            return scale * np.abs(velocity)
        return np.maximum(scale * np.abs(velocity), scale / 4 * np.asarray(self.velocity_limit, dtype=np.float64))

    def sample(self, rng: np.random.Generator, velocity: np.ndarray) -> np.ndarray:
        """A velocity error ``(..., t)`` for commanded velocities ``(..., t)``; zeros for ``none``."""
        if self.model == "none":
            return np.zeros(np.shape(velocity))
        return truncated_normal(rng, self.limits(velocity))
