"""Voxel cost of deformation against a pybullet soft body, side by side (thesis 3.3.5).

The cube-wall cube: the voxel model assesses a configuration by summing eq. 3.1 over its 1,000
points; pybullet assesses it by simulating a tetrahedral soft cube (0.2 m, 320 tetrahedra; the thesis
used 400) pressed into the wall, one physics step (1/240 s) at a time.  Both are measured in this run,
against a rigid wall and against a soft wall.

Reference (thesis): 84 us (voxels) vs 4 ms (rigid obstacle) and 16 ms (soft obstacle).  Figure to
reach (issue #5): the voxel assessment >= 500x faster in the same run.

    pliant bench softbody
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of, print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402
import pliant  # noqa: E402
from pliant.interfaces import Context  # noqa: E402

STEPS = 240


def soft_step_seconds(soft_obstacle: bool) -> tuple[float, float, int]:
    import pybullet
    from pliant_pybullet.softbody import SoftBox
    from pybullet_utils.bullet_client import BulletClient

    client = BulletClient(connection_mode=pybullet.DIRECT)
    client.resetSimulation(client.RESET_USE_DEFORMABLE_WORLD)
    client.setGravity(0, 0, 0)
    client.setTimeStep(1 / 240)
    if soft_obstacle:
        SoftBox(client, (0.6, 0.05, 0.6), 6, [0, 0.15, 0.5], mass=5.0)
    else:
        shape = client.createCollisionShape(client.GEOM_BOX, halfExtents=[0.5, 0.025, 0.5])
        client.createMultiBody(0, shape, basePosition=[0, 0.15, 0.5])
    cube = SoftBox(client, 0.2, 4, [0, 0.06, 0.5])     # overlaps the wall by 0.035 m: in contact
    client.stepSimulation()
    t = time.perf_counter()
    for _ in range(STEPS):
        client.stepSimulation()
    seconds = (time.perf_counter() - t) / STEPS
    contacts = len(client.getContactPoints())
    deformation = cube.deformation()
    client.disconnect()
    return seconds, deformation, contacts


def main() -> None:
    scene = pliant.load_scene("cube-wall")
    ctx = Context(scene=scene)
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    cost = pliant.registry.create("cost", "voxel", ctx)
    rng = np.random.default_rng(0)
    batch = ctx.robot.space.sample(rng, 1000)
    batch[:, :3] = rng.uniform([0.15, 0.3, 0.15], [0.85, 0.7, 0.85], (1000, 3))
    batched = best_of(lambda: cost.cost(batch), repeats=15)["median"] / len(batch)
    single = best_of(lambda: [cost.cost(q) for q in batch[:200]], repeats=7)["median"] / 200
    rigid, rigid_def, rigid_contacts = soft_step_seconds(False)
    soft, soft_def, soft_contacts = soft_step_seconds(True)
    rows = []
    cases = (("soft cube on a rigid wall", rigid, 4e-3), ("soft cube on a soft wall", soft, 16e-3))
    for name, seconds, thesis in cases:
        ratio_b, ratio_s = seconds / batched, seconds / single
        rows.append((name, f"{seconds * 1e3:.2f} ms", f"{batched * 1e6:.2f} us", f"{ratio_b:.0f}x",
                     f"{single * 1e6:.1f} us", f"{ratio_s:.0f}x", f"{thesis / 84e-6:.0f}x", ">= 500x",
                     "yes" if ratio_b >= 500 else "NO"))
    print(f"pybullet: {rigid_contacts} / {soft_contacts} contact points; deformation after {STEPS} steps "
          f"{rigid_def:.3g} / {soft_def:.3g} m^3 (sum of |dV| over tetrahedra)")
    print_table("One deformation assessment: pybullet soft body step vs voxel cost (one core)",
                ("case", "pybullet", "voxel batched", "ratio", "voxel single", "ratio", "thesis ratio",
                 "target", "met (batched)"), rows)
    write_json("softbody", {"voxel_batched_s": batched, "voxel_single_s": single, "pybullet_rigid_s": rigid,
                            "pybullet_soft_s": soft, "steps": STEPS})


if __name__ == "__main__":
    main()
