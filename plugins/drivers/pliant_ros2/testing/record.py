"""Every command a ROS 2 peer received (its record, read with :func:`pliant.api.read_jsonl`) checked against a limits
file."""

from __future__ import annotations

import numpy as np


def command_violations(records: list[dict], limits, *, tolerance: float = 1e-6) -> list[str]:
    """Every command received (forward controller messages and trajectory points, in the controllers' joint order)
    that broke ``limits`` (a :class:`pliant.api.JointLimits` in the same order), in words: a joint missing or
    non-finite, a position outside ``[lower + margin, upper - margin]``, a step between consecutive streamed
    commands larger than the step limit."""
    out = []
    previous = None
    slack = tolerance + 1e-6 * np.maximum(np.abs(limits.lower), np.abs(limits.upper))
    for record in records:
        if record.get("kind") != "command":
            continue
        t = record["t"]
        p = np.array([np.nan if x is None else x for x in record["positions"]], dtype=np.float64)
        if p.shape != (limits.dof,) or not np.all(np.isfinite(p)):
            out.append(f"t={t:.3f}: a joint missing or non-finite: {record['positions']}")
            continue
        bad = np.flatnonzero((p < limits.command_lower - slack) | (p > limits.command_upper + slack))
        if bad.size:
            i = bad[0]
            out.append(f"t={t:.3f}: {limits.names[i]} at {p[i]:.6f} outside "
                       f"[{limits.command_lower[i]:.6f}, {limits.command_upper[i]:.6f}]")
        if previous is not None and record.get("source") != "trajectory":
            step = np.abs(p - previous)
            bad = np.flatnonzero(step > limits.max_step + 2 * slack)
            if bad.size:
                i = bad[0]
                out.append(f"t={t:.3f}: {limits.names[i]} stepped {step[i]:.6f} > {limits.max_step[i]:.6f}")
        previous = p
    return out
