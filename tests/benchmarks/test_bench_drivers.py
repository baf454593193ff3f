"""The drivers benchmark's tracking figure on records with known answers."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from bench_drivers import RECOVERY, _pooled_tracking, tracking


def _records(delay: float, noise: float, contact_window: tuple[float, float] | None = None, offset: float = 0.05):
    rng = np.random.default_rng(0)
    records = []
    for t in np.arange(0.0, 10.0, 0.01):            # commands at 100 Hz: a slow sinusoid on 7 joints
        records.append({"kind": "command", "t": t, "accepted": True,
                        "positions": (0.3 * np.sin(t + np.arange(7))).tolist()})
    for t in np.arange(0.0, 10.0, 0.02):            # states at 50 Hz, ``delay`` behind, with noise
        q = 0.3 * np.sin(t - delay + np.arange(7)) + rng.normal(0.0, noise, 7)
        touching = contact_window is not None and contact_window[0] <= t <= contact_window[1]
        if touching:
            q = q + offset                          # pressed against something: away from the reference
        records.append({"kind": "state", "t": t, "positions": q.tolist(), "contact": bool(touching)})
    return records


def test_a_delayed_noisy_arm_tracks_with_the_noise_rms_at_the_best_delay():
    out = tracking(_records(delay=0.0125, noise=2e-4))
    assert out["delay_s"] == pytest.approx(0.0125, abs=1e-9)
    assert out["rms_free_rad"] == pytest.approx(2e-4, rel=0.15)
    assert out["free_fraction"] == 1.0


def test_contact_and_the_recovery_after_it_are_kept_out_of_free_motion():
    out = tracking(_records(delay=0.01, noise=1e-4, contact_window=(3.0, 4.0)))
    assert out["rms_free_rad"] == pytest.approx(1e-4, rel=0.2)
    assert out["rms_contact_rad"] > 0.04            # the 0.05 rad press, and free samples during the recovery
    # contact 3..4 s plus RECOVERY after it, out of about 9.95 s of states
    assert out["free_fraction"] == pytest.approx(1 - (1.0 + RECOVERY) / 9.95, abs=0.02)
    assert out["free_0.1s_fraction"] > out["free_fraction"]


def test_pooled_figures_weigh_each_execution_by_its_samples():
    a = {"driver": {"tracking": {"samples": 300, "free_fraction": 1 / 3, "free_0.1s_fraction": 1 / 3,
                                 "rms_free_rad": 1e-3, "rms_free_0.1s_rad": 1e-3, "rms_contact_rad": 0.0}}}
    b = {"driver": {"tracking": {"samples": 300, "free_fraction": 2 / 3, "free_0.1s_fraction": 2 / 3,
                                 "rms_free_rad": 2e-3, "rms_free_0.1s_rad": 2e-3, "rms_contact_rad": 0.0}}}
    pooled = _pooled_tracking([a, b, {"driver": {}}])
    assert pooled["free_samples"] == 300
    assert pooled["rms_free_rad"] == pytest.approx(np.sqrt((100 * 1e-6 + 200 * 4e-6) / 300))
