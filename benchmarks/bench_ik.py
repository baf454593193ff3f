"""Inverse kinematics of the URDF robots' arms (pliant_pinocchio.ik) on random reachable poses.

For each robot (the iiwa of iiwa-shelf, Baxter's right arm of baxter-reach, the PR2's right arm of pr2-reach) and
``--poses`` random configurations of its arm drawn within the joint limits, the pose (position and orientation) of
its tool frame there is the target; ``solve_ik`` is asked for ``--solutions`` configurations within 1 mm and 0.01 rad
from uniform starts (no collision check: the poses are reachable, not necessarily collision-free).  Reported: poses
with at least one solution, every solution's errors within the tolerances and its joints within the limits, the
solutions per pose, and the median and 95th-percentile time per pose (single core).

    pliant bench ik [-- --poses 200 --solutions 1]
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
import pinocchio as pin  # noqa: E402
from pliant.testing.conformance import build_context  # noqa: E402
from pliant_pinocchio.ik import solve_ik  # noqa: E402

ROBOTS = {"iiwa": ("iiwa-shelf", "lbr_iiwa_link_7"), "baxter": ("baxter-reach", "right_gripper"),
          "pr2": ("pr2-reach", "r_gripper_tool_frame")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=200)
    parser.add_argument("--solutions", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rows, out = [], {}
    for name, (scene, frame) in ROBOTS.items():
        robot = build_context(scene).robot
        rng = np.random.default_rng(args.seed)
        solved, within, counts, times = 0, True, [], []
        for _ in range(args.poses):
            q = robot.space.sample(rng, 1)[0]
            placement = robot.frame_placements(q, frame)[0]
            quat = pin.Quaternion(placement[:3, :3])
            t = time.perf_counter()
            result = solve_ik(robot, frame, placement[:3, 3], [quat.x, quat.y, quat.z, quat.w], rng=rng,
                              solutions=args.solutions, valid=lambda x: np.ones(len(x), dtype=bool))
            times.append(time.perf_counter() - t)
            counts.append(len(result.solutions))
            solved += len(result.solutions) > 0
            if len(result.solutions):
                s = result.solutions
                within &= bool(np.all(result.position_errors <= 1e-3) and np.all(result.orientation_errors <= 1e-2)
                               and np.all(s >= robot.space.lower) and np.all(s <= robot.space.upper))
        out[name] = {"solved": solved, "poses": args.poses, "within": within, "median_s": float(np.median(times)),
                     "p95_s": float(np.percentile(times, 95)), "mean_solutions": float(np.mean(counts))}
        rows.append((name, frame, f"{solved}/{args.poses}", "yes" if within else "NO", f"{np.mean(counts):.2f}",
                     f"{np.median(times) * 1000:.1f}", f"{np.percentile(times, 95) * 1000:.1f}"))
        print(name, out[name], flush=True)
    print_table(f"IK on {args.poses} random reachable poses (1 mm, 0.01 rad), {args.solutions} solution(s) asked",
                ("robot", "frame", "solved", "errors and limits ok", "solutions", "median ms", "p95 ms"), rows)
    print(f"wrote {write_json('ik', {'args': vars(args), 'robots': out})}")


if __name__ == "__main__":
    main()
