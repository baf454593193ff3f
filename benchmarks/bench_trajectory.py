"""pliant's time parameterisation (pliant.planning.trajectory) against TOPP-RA on the same straight motions.

A planned path is piecewise linear and its trajectory rests at every corner, so each segment is a rest-to-rest move
along a straight line; TOPP-RA (``toppra``, the time-optimal path parameterisation by reachability analysis) gives
the time-optimal duration of the same straight motion under the same joint velocity and acceleration limits.  For
random 7-joint segments (joint limits of the order of an arm's: 1-3 rad/s, 2-10 rad/s^2) this prints both durations,
their ratio, and the largest |velocity| / limit and |acceleration| / limit of both trajectories sampled at 1 kHz.

    pliant bench trajectory [-- --segments 50]        (needs `pip install toppra`: the `bench` extra)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402
from pliant.planning.trajectory import time_parameterize  # noqa: E402


def toppra_segment(a: np.ndarray, b: np.ndarray, v: np.ndarray, acc: np.ndarray, gridpoints: int) -> dict:
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    path = ta.SplineInterpolator([0.0, 1.0], np.stack([a, b]), bc_type="natural")   # the straight line
    constraints = [constraint.JointVelocityConstraint(np.stack([-v, v], axis=1)),
                   constraint.JointAccelerationConstraint(np.stack([-acc, acc], axis=1))]
    instance = algo.TOPPRA(constraints, path, gridpoints=np.linspace(0, 1, gridpoints),
                           parametrizer="ParametrizeConstAccel")
    trajectory = instance.compute_trajectory(0.0, 0.0)
    t = np.linspace(0.0, trajectory.duration, max(2, int(trajectory.duration * 1000) + 1))
    return {"duration": float(trajectory.duration),
            "velocity": float(np.max(np.abs(trajectory(t, 1)) / v)),
            "acceleration": float(np.max(np.abs(trajectory(t, 2)) / acc))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, default=50)
    parser.add_argument("--gridpoints", type=int, default=200, help="TOPP-RA's discretisation of the path")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    import toppra as ta

    ta.setup_logging("WARNING")
    rng = np.random.default_rng(args.seed)
    rows, ratios, ours_ratio, theirs_ratio, timings = [], [], [], [], {"pliant": 0.0, "toppra": 0.0}
    for k in range(args.segments):
        a, b = rng.uniform(-2.0, 2.0, (2, 7))
        v, acc = rng.uniform(1.0, 3.0, 7), rng.uniform(2.0, 10.0, 7)
        t0 = time.perf_counter()
        ours = time_parameterize(np.stack([a, b]), v, acc)
        timings["pliant"] += time.perf_counter() - t0
        limits = ours.limit_ratio(1000)
        t0 = time.perf_counter()
        theirs = toppra_segment(a, b, v, acc, args.gridpoints)
        timings["toppra"] += time.perf_counter() - t0
        ratios.append(ours.duration / theirs["duration"])
        ours_ratio.append(max(limits.values()))
        theirs_ratio.append(max(theirs["velocity"], theirs["acceleration"]))
        if k < 5:
            rows.append((k, f"{ours.duration:.4f}", f"{theirs['duration']:.4f}", f"{ratios[-1]:.4f}",
                         f"{ours_ratio[-1]:.6f}", f"{theirs_ratio[-1]:.6f}"))
    print_table(f"first 5 of {args.segments} random 7-joint straight segments: duration (s), pliant / TOPP-RA, "
                "largest |v|/limit or |a|/limit at 1 kHz",
                ("segment", "pliant", "TOPP-RA", "ratio", "pliant peak", "TOPP-RA peak"), rows)
    summary = {"segments": args.segments, "gridpoints": args.gridpoints,
               "ratio": {"min": float(np.min(ratios)), "median": float(np.median(ratios)),
                         "max": float(np.max(ratios))},
               "pliant_peak": float(np.max(ours_ratio)), "toppra_peak": float(np.max(theirs_ratio)),
               "seconds": timings}
    print(f"\npliant / TOPP-RA duration over {args.segments} segments: min {summary['ratio']['min']:.4f}, "
          f"median {summary['ratio']['median']:.4f}, max {summary['ratio']['max']:.4f}")
    print(f"largest limit ratio at 1 kHz: pliant {summary['pliant_peak']:.6f}, TOPP-RA {summary['toppra_peak']:.6f}")
    print(f"time: pliant {timings['pliant']:.3f} s, TOPP-RA {timings['toppra']:.3f} s")
    print(f"wrote {write_json('trajectory', summary)}")


if __name__ == "__main__":
    main()
