"""Cost of deformation of the cube-wall's 1,000-point cube: single call and batched (thesis 3.3.5).

Reference: 84 us per assessment (thesis).  Figures to reach (BENCHMARKS.md): batched <= 8 us per
configuration, a single call <= 40 us.  Also times the lattice translation costs of triple-wall.

    pliant bench cost            (or: python benchmarks/bench_cost.py)
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of, print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402
import pliant  # noqa: E402
from pliant.interfaces import Context  # noqa: E402


def main() -> None:
    scene = pliant.load_scene("cube-wall")
    ctx = Context(scene=scene)
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    cost = pliant.registry.create("cost", "voxel", ctx)
    points = len(ctx.robot.point_materials())
    rng = np.random.default_rng(0)
    batch = ctx.robot.space.sample(rng, 1000)
    batch[:, :3] = rng.uniform([0.15, 0.3, 0.15], [0.85, 0.7, 0.85], (1000, 3))   # near and through the wall
    values = cost.cost(batch)
    in_contact = int(np.sum(np.nan_to_num(values, nan=1.0) > 0))

    batched = best_of(lambda: cost.cost(batch), repeats=15)
    singles = best_of(lambda: [cost.cost(q) for q in batch[:200]], repeats=7)
    single_us = singles["median"] / 200 * 1e6
    batched_us = batched["median"] / len(batch) * 1e6
    grad = best_of(lambda: cost.gradient(batch[:100]), repeats=5)

    tw = pliant.load_scene("triple-wall")
    tctx = Context(scene=tw)
    tctx.robot = pliant.registry.create("robot", "rigid", tctx)
    tcost = pliant.registry.create("cost", "voxel", tctx)
    field = best_of(lambda: tcost.translation_costs(tw.lower + tw.resolution / 2, tw.resolution, tw.shape))

    rows = [
        ("cube-wall cost, batched (1,000 configs)", f"{batched_us:.2f} us/config", "84 us (thesis)", "<= 8 us",
         "yes" if batched_us <= 8 else "NO"),
        ("cube-wall cost, single call", f"{single_us:.2f} us", "84 us (thesis)", "<= 40 us",
         "yes" if single_us <= 40 else "NO"),
        ("cube-wall gradient, batched (100)", f"{grad['median'] / 100 * 1e6:.1f} us/config", "-", "-", "-"),
        ("triple-wall translation costs, all 59,400 cells", f"{field['median'] * 1e3:.2f} ms", "-", "-", "-"),
    ]
    print(f"cube: {points} body points; {in_contact} of {len(batch)} sampled configurations touch the wall")
    print_table("Cost of deformation (one core)", ("measurement", "pliant", "reference", "target", "met"), rows)
    write_json("cost", {"points": points, "batched_us_per_config": batched_us, "single_call_us": single_us,
                        "gradient_us_per_config": grad["median"] / 100 * 1e6,
                        "triple_wall_field_ms": field["median"] * 1e3, "thesis_us": 84.0,
                        "targets": {"batched_us": 8.0, "single_us": 40.0}})


if __name__ == "__main__":
    main()
