"""A robot peer's record file (JSON lines: every command received, the arm's state at 50 Hz, every fault switch)
read back, and every received command checked against a limits file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from pliant.api import JointLimits


def read_record(path: str | Path) -> list[dict]:
    """Every line of a peer's record file (a partly written last line is skipped)."""
    out = []
    for line in Path(path).read_text().splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return out


def command_violations(records: list[dict], limits: JointLimits, *, tolerance: float = 1e-6) -> list[str]:
    """Every received command that broke ``limits``, in words: a joint missing or non-finite, a position outside
    ``[lower + margin, upper - margin]``, a velocity beyond its limit, or a step between consecutive commands larger
    than the step limit.  ``tolerance`` (rad, rad/s) absorbs float32 rounding (the iiwa's messages)."""
    out = []
    previous = None
    slack = tolerance + 1e-6 * np.maximum(np.abs(limits.lower), np.abs(limits.upper))
    for record in records:
        if record.get("kind") != "command":
            continue
        t = record["t"]
        p = np.array([np.nan if x is None else x for x in record["positions"]], dtype=np.float64)
        if not np.all(np.isfinite(p)):
            out.append(f"t={t:.3f}: a joint missing or non-finite: {record['positions']}")
            continue
        bad = np.flatnonzero((p < limits.command_lower - slack) | (p > limits.command_upper + slack))
        if bad.size:
            i = bad[0]
            out.append(f"t={t:.3f}: {limits.names[i]} at {p[i]:.6f} outside "
                       f"[{limits.command_lower[i]:.6f}, {limits.command_upper[i]:.6f}]")
        if record.get("velocities") is not None:
            v = np.array([np.nan if x is None else x for x in record["velocities"]], dtype=np.float64)
            bad = np.flatnonzero(~np.isfinite(v) | (np.abs(v) > limits.velocity * (1 + 1e-6) + tolerance))
            if bad.size:
                i = bad[0]
                out.append(f"t={t:.3f}: {limits.names[i]} velocity {v[i]:.6f} beyond {limits.velocity[i]:.6f}")
        if previous is not None:
            step = np.abs(p - previous)
            bad = np.flatnonzero(step > limits.max_step + 2 * slack)
            if bad.size:
                i = bad[0]
                out.append(f"t={t:.3f}: {limits.names[i]} stepped {step[i]:.6f} > {limits.max_step[i]:.6f}")
        previous = p
    return out
