"""Drivers: ruckig per cycle, command timing over ROS 1, command-to-state latency, tracking, and the Baxter policy
executed through the driver beside pybullet (issue: hardware drivers).

Figures to reach:
- ruckig update per cycle, 7 DoF: median <= 50 us (the smoother's whole update, with the stop check, and ruckig's
  own update alone, targets changing every cycle);
- command period jitter at 100 Hz and 500 Hz over ROS 1 on loopback, p50 / p99 / max: p99 <= 1 ms at 100 Hz on an
  otherwise idle machine (measured at the peer, on receipt, and at the driver, on write);
- command-to-state latency through the peer;
- tracking: the peer's measured motion against ruckig's reference, RMS <= 1e-3 rad on the Baxter policy;
- the Baxter policy executed through the driver and peer succeeds as often as through pybullet directly (same
  seeds, side by side in this run).

    pliant bench drivers [--quick] [--seeds N] [--skip-policy]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from pliant.hardware.limits import JointLimits
from pliant.hardware.smoothing import OnlineSmoother

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, write_json

DOF = 7
CYCLES = 5000


def _stats_us(seconds) -> dict:
    a = np.asarray(seconds) * 1e6
    return {"median_us": float(np.median(a)), "p99_us": float(np.percentile(a, 99)), "max_us": float(a.max())}


def ruckig_per_cycle(cycles: int) -> dict:
    """The smoother's update with a new target every cycle (position and velocity streams) and ruckig's own."""
    import ruckig

    limits = JointLimits(tuple(f"j{i}" for i in range(DOF)), np.full(DOF, -2.9), np.full(DOF, 2.9), np.full(DOF, 1.5),
                         np.full(DOF, 5.0), np.full(DOF, 50.0), command_rate=100.0)
    phase = np.arange(DOF)
    out = {}
    smoother = OnlineSmoother(limits)
    smoother.reset(np.zeros(DOF))
    for name, aim in (("smoother, position target every cycle", smoother.set_target),
                      ("smoother, velocity target every cycle", smoother.set_velocity)):
        times = []
        for k in range(cycles):
            aim(0.5 * np.sin(k / 50 + phase))
            t = time.perf_counter()
            smoother.update()
            times.append(time.perf_counter() - t)
        out[name] = _stats_us(times[100:])
    otg, inp, res = ruckig.Ruckig(DOF, 0.01), ruckig.InputParameter(DOF), ruckig.OutputParameter(DOF)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [1.5] * DOF, [5.0] * DOF, [50.0] * DOF
    times = []
    for k in range(cycles):
        inp.target_position = (0.5 * np.sin(k / 50 + phase)).tolist()
        t = time.perf_counter()
        otg.update(inp, res)
        res.pass_to_input(inp)
        times.append(time.perf_counter() - t)
    out["ruckig update alone (the peer)"] = _stats_us(times[100:])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="shorter runs (CI)")
    args = parser.parse_args()
    results: dict = {"ruckig": ruckig_per_cycle(1000 if args.quick else CYCLES)}
    print_table("ruckig update per cycle, 7 DoF (target: median <= 50 us)", ("what", "median us", "p99 us", "max us"),
                [(k, f"{v['median_us']:.1f}", f"{v['p99_us']:.1f}", f"{v['max_us']:.1f}")
                 for k, v in results["ruckig"].items()])
    write_json("drivers", results)


if __name__ == "__main__":
    main()
