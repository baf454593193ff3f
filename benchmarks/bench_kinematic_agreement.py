"""Agreement of the kinematic simulator with the dynamic one (pymunk) on se2-maze, per contact solver.

The belief-space planner plans with ``kinematic`` and executes in ``pymunk``, so the two should end a
motion in about the same place.  For PAIRS random (start, target) pairs — starts sampled collision-free
(the L-block's points at least a voxel from every wall), targets anywhere in the space, as a planner's
samples are — both simulators run 8 s of the same P control (kp 0.5, 1 m/s, 0.125 rad/s) without noise.
Reported per kinematic contact solver (``least-squares``: thesis eq. 8.5 as written; ``effort``: the
effort-limited correction, the default): the median / mean / 90th percentile of the final-configuration
distance (SE(2) metric of the space) to pymunk's, the median absolute final rotation difference, and the
largest rotation *away from the command* (how much farther from the target heading than the start the
body ends up), which a rotation speed limit makes impossible without contact forces.

    python benchmarks/bench_kinematic_agreement.py [--pairs 50] [--friction MU] [--effort-length L]

``--friction`` sets pymunk's Coulomb coefficient (default: pymunk's 0.5; the maze pipelines execute at 0.1)
and ``--effort-length`` the kinematic effort solver's lever arm (default: the body's radius of gyration;
the maze pipelines use 1.0 m, pymunk's torque over force limit).
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
import pliant  # noqa: E402
from pliant.geometry.rotations import wrap_angle  # noqa: E402
from pliant.geometry.voxelgrid import VoxelGrid  # noqa: E402
from pliant.interfaces import Context  # noqa: E402

CONTROL = {"kp": 0.5, "velocity_limit": 1.0, "angular_velocity_limit": 0.125}
DURATION = 8.0
SOLVERS = ("least-squares", "effort")


def sample_pairs(ctx: Context, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``n`` collision-free starts (every body point a voxel clear of the walls) and ``n`` targets anywhere."""
    space, grid = ctx.robot.space, VoxelGrid.from_scene(ctx.scene)
    starts = []
    while len(starts) < n:
        q = space.sample(rng, 4 * n)
        clear = np.array([grid.sdf_at(ctx.robot.body_points(c[None])[0]).min() for c in q]) > grid.resolution
        starts.extend(q[clear][: n - len(starts)])
    return np.array(starts), space.sample(rng, n)


def heading_drift(starts: np.ndarray, finals: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """How much farther (rad) from the target heading each final configuration is than its start (>= 0)."""
    before = np.abs(wrap_angle(targets[:, 2] - starts[:, 2]))
    after = np.abs(wrap_angle(targets[:, 2] - finals[:, 2]))
    return np.maximum(after - before, 0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--friction", type=float, default=None, help="pymunk's friction (default its own, 0.5)")
    parser.add_argument("--effort-length", type=float, default=None, help="the effort solver's lever arm (m)")
    args = parser.parse_args()
    ctx = Context(scene=pliant.load_scene("se2-maze"))
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    space = ctx.robot.space
    starts, targets = sample_pairs(ctx, args.pairs, np.random.default_rng(args.seed))

    dynamic = {} if args.friction is None else {"friction": args.friction}
    pymunk = pliant.registry.create("simulator", "pymunk", ctx, **CONTROL, **dynamic)
    t = time.perf_counter()
    reference = np.array([pymunk.simulate(s[None], g, np.random.default_rng(0), DURATION).final[0]
                          for s, g in zip(starts, targets)])
    pymunk_time = time.perf_counter() - t

    rows, results = [], {}
    for solver in SOLVERS:
        lever = {} if args.effort_length is None or solver != "effort" else {"effort_length": args.effort_length}
        sim = pliant.registry.create("simulator", "kinematic", ctx, solver=solver, **CONTROL, **lever)
        sim.simulate(starts[:2], targets[:2], np.random.default_rng(0), 0.2)          # compile the kernels
        t = time.perf_counter()
        out = sim.simulate(starts, targets, np.random.default_rng(0), DURATION)
        elapsed = time.perf_counter() - t
        gap = space.distance(out.final, reference)
        rotation = np.abs(wrap_angle(out.final[:, 2] - reference[:, 2]))
        drift = heading_drift(starts, out.final, targets)
        results[solver] = {"median": float(np.median(gap)), "mean": float(gap.mean()),
                           "p90": float(np.percentile(gap, 90)), "median_rotation_gap": float(np.median(rotation)),
                           "max_heading_drift": float(drift.max()), "in_contact": int(out.in_contact.sum()),
                           "seconds": elapsed, "final": out.final.tolist()}
        rows.append((solver, f"{np.median(gap):.3f}", f"{gap.mean():.3f}", f"{np.percentile(gap, 90):.3f}",
                     f"{np.median(rotation):.3f}", f"{drift.max():.3f}", int(out.in_contact.sum()),
                     f"{elapsed:.2f}"))
    drift = heading_drift(starts, reference, targets)
    rows.append(("(pymunk itself)", "-", "-", "-", "-", f"{drift.max():.3f}", "-", f"{pymunk_time:.2f}"))
    print_table(f"se2-maze, {args.pairs} random (start, target) pairs, {DURATION:g} s without noise: "
                f"final-configuration distance kinematic vs pymunk (friction {pymunk.options.friction:g})",
                ("kinematic solver", "median", "mean", "p90", "median |dtheta|", "max heading drift (rad)",
                 "in contact", "seconds"), rows)
    write_json("kinematic_agreement", {"pairs": args.pairs, "seed": args.seed, "duration": DURATION,
                                       "control": CONTROL, "friction": pymunk.options.friction,
                                       "effort_length": args.effort_length, "starts": starts.tolist(),
                                       "targets": targets.tolist(),
                                       "pymunk_final": reference.tolist(), "pymunk_seconds": pymunk_time,
                                       "kinematic": results})


if __name__ == "__main__":
    main()
