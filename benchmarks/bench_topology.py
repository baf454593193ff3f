"""Puncture and cut detection per tree extension (thesis 4.3.4): cost of one check.

The cube-wall grid (50 x 50 x 50 voxels at 0.02 m) with its wall made deformable (so it is watched;
it starts with two holes, which are legal) and a hollow deformable box (17^3 voxels, one void)
added beside it; the robot is the cube-wall's 1,000-point soft cube.  An edge is 10 interpolated
configurations (the planner's collision-check step).  No thesis figure is given for the cost of a
check; the target is that it stays small next to a planner's per-extension cost (about 1 ms).

    pliant bench topology            (or: python benchmarks/bench_topology.py)
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of, print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402
import pliant  # noqa: E402
from pliant.geometry.topology import PunctureChecker, surface_topology, topology  # noqa: E402
from pliant.geometry.voxelgrid import VoxelGrid  # noqa: E402
from pliant.interfaces import Context  # noqa: E402


def _grid(scene) -> VoxelGrid:
    grid = VoxelGrid.from_scene(scene)
    grid.deformability[grid.object_id == 0] = 0.5                   # the wall, now enterable
    shell = np.zeros(grid.shape, dtype=bool)
    shell[31:48, 4:21, 4:21] = True
    shell[32:47, 5:20, 5:20] = False
    grid.object_id[shell] = len(grid.object_names)
    grid.deformability[shell] = 0.5
    grid.sensitivity[shell] = 1.0
    grid.object_names.append("shell")
    return grid


def _edge(a, b, n: int = 10) -> np.ndarray:
    q = np.zeros((n, 7))
    q[:, :3] = np.asarray(a) + np.linspace(0, 1, n)[:, None] * (np.asarray(b) - np.asarray(a))
    q[:, 6] = 1.0
    return q


def main() -> None:
    scene = pliant.load_scene("cube-wall")
    ctx = Context(scene=scene)
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    grid = _grid(scene)
    checker = PunctureChecker(grid, ctx.robot.body_points)
    root = checker.initial_state()
    # positions off the voxel boundaries (the cube's points are voxel centres) and clear of the holes
    start = [0.51, 0.2, 0.25]
    edges = {
        "free space (nothing swept)": (root, _edge(start, [0.51, 0.25, 0.21])),
        "dent into the wall": (root, _edge(start, [0.51, 0.39, 0.25])),
        "through the wall (puncture)": (root, _edge(start, [0.51, 0.8, 0.25], 31)),
        "into the shell (void opened)": (root, _edge(start, [0.69, 0.2, 0.25])),
    }
    dent_state, ok, _ = checker.extend(root, edges["dent into the wall"][1])
    assert ok
    edges["deeper, from a dented node"] = (dent_state, _edge([0.51, 0.39, 0.25], [0.51, 0.41, 0.25]))

    rows, data = [], {"grid": list(grid.shape), "objects": checker.names,
                      "initial": {n: t.__dict__ for n, t in zip(checker.names, checker.initial)},
                      "body_points": ctx.robot.point_count(), "checks": {}}
    for name, (state, q) in edges.items():
        new, ok, reason = checker.extend(state, q)
        timing = best_of(lambda s=state, q=q: checker.extend(s, q), repeats=50, warmup=3)
        pts = best_of(lambda q=q: ctx.robot.body_points(q), repeats=50, warmup=3)
        us = timing["median"] * 1e6
        rows.append((name, len(q), new.removed_count, "ok" if ok else reason.split(":")[0], f"{us:.0f} us",
                     f"{pts['median'] * 1e6:.0f} us"))
        data["checks"][name] = {"configurations": len(q), "removed_voxels": new.removed_count, "ok": ok,
                                "reason": reason, "us_per_check": us, "body_points_us": pts["median"] * 1e6}
    print(f"grid {grid.shape}, watched {checker.names}, initial "
          + ", ".join(f"{n}: {t.components} piece(s), {t.cavities} void(s), {t.tunnels} hole(s)"
                      for n, t in zip(checker.names, checker.initial)))
    print_table("PunctureChecker.extend per edge (one core)",
                ("edge", "configs", "voxels swept", "verdict", "per check", "of which body points"), rows)

    crop_rows = []
    for slot, name in enumerate(checker.names):
        crop = checker._masks[slot]
        t_euler = best_of(lambda c=crop: topology(c), repeats=50, warmup=3)["median"] * 1e6
        t_surface = best_of(lambda c=crop: surface_topology(c), repeats=20, warmup=2)["median"] * 1e6
        crop_rows.append((name, "x".join(map(str, crop.shape)), f"{t_euler:.0f} us", f"{t_surface:.0f} us"))
        data.setdefault("counting", {})[name] = {"crop": list(crop.shape), "euler_method_us": t_euler,
                                                 "surface_method_us": t_surface}
    full = best_of(lambda: topology(grid.occupied), repeats=20, warmup=2)["median"] * 1e6
    crop_rows.append(("whole 50^3 grid", "x".join(map(str, grid.shape)), f"{full:.0f} us", "-"))
    data["counting"]["whole_grid_euler_method_us"] = full
    print_table("Counting one object (Euler method vs the thesis's surface-vertex method)",
                ("object", "crop (voxels)", "topology()", "surface_topology()"), crop_rows)
    write_json("topology", data)


if __name__ == "__main__":
    main()
