"""TS-RRT on held-out tasks (issue 33 item 4): the figures TS-RRT's defaults were tuned on (the development set: the
bundled ``tsrrt-table``, a book, a block and a can on a 1.0 x 0.8 m table at the origin, random starts) beside the
same figures on tasks that tuning never saw, made by a different generator: new object classes (a tray, a crate, a
slab, a puck, a mug; sizes, masses and frictions drawn per task), new table sizes (0.8-1.3 x 0.6-1.0 m) and
offsets (up to 0.3 m from the origin), 2-5 objects, every class learned from scratch (LEARN_MODEL in pymunk, with
noise) in each task.

For every task: the models are learned, TS-RRT plans from a random collision-free start with a work budget
(``--iterations`` tree extensions), the plan is compared with the reference optimum of the same cost
(:func:`pliant_tsrrt.reference.reference_optimum`, multi-start; the plan's final arrangement is one start, so the
ratio is >= 1), and executed ``--executions`` times in pymunk with noise (placement 4 mm, actuation 0.01 m/s),
monitoring, repairs and replanning, at most ``--action-limit`` pushes.  An execution counts as *within 10 %* when it
ends collision-free at no more than 1.1 times the plan's cost.  Every budget is a count (iterations, rounds, pushes),
so the figures are the same on any machine under a seed; the times are only reported.

    python benchmarks/bench_tsrrt_heldout.py --quick      (1 development task, 2 held-out; about a minute)
    nice -n 10 python benchmarks/bench_tsrrt_heldout.py   (6 development tasks, 16 held-out, 3 executions each)
    ... --dev 0 --heldout 8 --executions 3 --iterations 300 --rounds 2000 --generator 36000   (docs' held-out figure)

``--generator`` seeds the held-out generator.  Sets once held out become development data when a default is chosen
by looking at them: 33000 (the first set), 34000 and 35000 are development data now; 36000 and 37000 were drawn
after the execution defaults of 2026-11-29 were fixed (docs/plugins/tsrrt.md, *Held-out tasks*).

Writes out/bench/tsrrt-heldout[-quick].json (or ``--name``; every task, plan and execution), after every task.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import tomllib
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, write_json
from bench_tsrrt import adaptation_log
from pliant.options import build_options
from pliant.termination import Termination
from pliant_tsrrt.execution import execute_plan
from pliant_tsrrt.learning import learn_models
from pliant_tsrrt.planner import PushPlan, TSRRTOptions, arena, build_space
from pliant_tsrrt.reference import random_arrangements, reference_optimum
from pliant_tsrrt.reproduce import world
from pliant_tsrrt.search import redundant_actions

#: the held-out generator's object classes: shape, size ranges (m), mass (kg), friction
CLASSES = {
    "tray": ("box", (0.20, 0.30), (0.13, 0.20), (0.3, 0.8), (0.2, 0.5)),
    "crate": ("box", (0.09, 0.14), None, (1.0, 3.0), (0.5, 0.9)),        # square
    "slab": ("box", (0.16, 0.26), (0.05, 0.08), (0.5, 1.5), (0.3, 0.7)),
    "puck": ("cylinder", (0.03, 0.045), None, (0.1, 0.4), (0.2, 0.5)),
    "mug": ("cylinder", (0.04, 0.06), None, (0.2, 0.6), (0.3, 0.6)),
}


def heldout_scene(rng: np.random.Generator, k: int, directory: Path, index: int) -> Path:
    """A held-out scene file: a table of a new size and offset, ``k`` objects of distinct new classes (sizes,
    masses and frictions drawn here), at provisional poses (the start is drawn once the scene exists)."""
    w, h = 0.02 * round(rng.uniform(0.8, 1.3) / 0.02), 0.02 * round(rng.uniform(0.6, 1.0) / 0.02)  # whole voxels
    x0, y0 = 0.01 * np.round(rng.uniform(-0.3, 0.3, 2) / 0.01)
    x1, y1 = x0 + w, y0 + h
    lines = [f'name = "heldout-{index}"', f'description = "held-out TS-RRT task {index}"', "planar = true",
             f"start = [{x1 + 0.1:.4f}, {y0 - 0.1:.4f}, 0.0]", f"goal = [{x1 + 0.1:.4f}, {y0 - 0.1:.4f}, 0.0]", "",
             "[bounds]", f"lower = [{x0 - 0.2:.4f}, {y0 - 0.2:.4f}, -0.01]",
             f"upper = [{x1 + 0.2:.4f}, {y1 + 0.2:.4f}, 0.01]", "resolution = 0.02", "",
             "[[regions]]", 'name = "table"', f"lower = [{x0:.4f}, {y0:.4f}]", f"upper = [{x1:.4f}, {y1:.4f}]", "",
             "[robot]", 'kind = "rigid"', 'name = "paddle"', 'space = "se2"', "deformability = 0.0",
             "sensitivity = 1.0", 'parts = [ { shape = "box", size = [0.03, 0.08, 0.02] } ]', ""]
    objects = []
    for cls in rng.choice(list(CLASSES), size=k, replace=False):
        shape, a, b, mass, friction = CLASSES[cls]
        entry = ["[[objects]]", f'name = "{cls}-1"', f'shape = "{shape}"']
        if shape == "box":
            sx = rng.uniform(*a)
            sy = rng.uniform(*b) if b else sx * rng.uniform(0.9, 1.0)
            entry.append(f"size = [{sx:.4f}, {sy:.4f}, 0.04]")
            half = (0.5 * sx, 0.5 * sy)
        else:
            radius = rng.uniform(*a)
            entry += [f"radius = {radius:.4f}", "length = 0.04"]
            half = (radius, radius)
        objects.append((entry, half, f"mass = {rng.uniform(*mass):.3f}", f"friction = {rng.uniform(*friction):.3f}"))
    for (entry, _, mass, friction), (px, py) in zip(objects, _provisional([o[1] for o in objects], x0, y0, w, h)):
        lines += [*entry, f"position = [{px:.4f}, {py:.4f}, 0.0]", mass, friction, "deformability = 0.0",
                  "sensitivity = 1.0", ""]
    path = directory / f"heldout-{index}.toml"
    path.write_text("\n".join(lines))
    return path


def _provisional(halves: list, x0: float, y0: float, w: float, h: float) -> list[tuple[float, float]]:
    """Provisional positions (yaw 0) of objects of half extents ``halves`` ``[(hx, hy), ...]`` (m): evenly spaced
    along the table's middle line, or -- when neighbours would overlap there -- packed left to right 1 cm apart, in
    rows from the bottom (pymunk refuses to place overlapping objects; the start is drawn later anyway)."""
    k = len(halves)
    spaced = [(x0 + (j + 0.5) * w / k, y0 + h / 2) for j in range(k)]
    if all(halves[j][0] + halves[j + 1][0] <= w / k for j in range(k - 1)):
        return spaced
    poses, x, y, row = [], x0 + 0.01, y0 + 0.01, 0.0
    for hx, hy in halves:
        if x + 2 * hx > x0 + w - 0.01:
            x, y, row = x0 + 0.01, y + row + 0.01, 0.0
        poses.append((x + hx, y + hy))
        x, row = x + 2 * hx + 0.01, max(row, 2 * hy)
    return poses


def run_task(label: str, scene_name: str, seed: int, options: TSRRTOptions, args) -> dict:
    """Learn, plan, compare with the reference and execute one task (a scene name or file, a start seed)."""
    scene, sim = world(scene_name, noise=True)
    names = [o.name for o in scene.objects if o.movable]
    t0 = time.perf_counter()
    models, _ = learn_models(arena(sim, scene, options), options.learning, np.random.default_rng(10 + seed))
    learn_time = time.perf_counter() - t0
    space = build_space(scene, options, models, names)
    space.warm_up()
    rng = np.random.default_rng(1000 + seed)
    s0 = random_arrangements(space, rng, 1, clearance=options.start_clearance)[0]
    cpu0 = time.process_time()
    from pliant_tsrrt.search import grow

    found = grow(space, s0, rng, options, Termination(max_iterations=args.iterations))
    cpu = time.process_time() - cpu0
    _, ref_cost = reference_optimum(space, np.random.default_rng(seed), rounds=args.rounds,
                                    starts=found.states[-1][None])
    plan = PushPlan(names, s0, found.actions, found.states, found.cost,
                    {**asdict(options), "replan_iterations": args.iterations}, models)
    executions = []
    for e in range(args.executions):
        _, sim_e = world(scene_name, noise=True)
        record = execute_plan(plan, sim_e, scene, np.random.default_rng(50_000 + 100 * seed + e),
                              action_limit=args.action_limit)
        d = record.details
        executions.append({"outcome": record.outcome.value, "final_cost": d.final_cost,
                           "ratio_plan": d.final_cost / found.cost, "collided": d.collided,
                           "pushes": len(d.actions), "plan_pushes": len(found.actions),
                           "replans": sum(not a.get("repair") for a in d.adaptations),
                           "repairs": sum(bool(a.get("repair")) for a in d.adaptations),
                           "adaptations": adaptation_log(record)})
    return {"set": label, "scene": str(scene_name), "seed": seed, "objects": len(names), "names": names,
            "learn_time": learn_time, "start_cost": float(space.cost.cost(s0[None])[0]), "cost": found.cost,
            "reference_cost": ref_cost, "ratio": found.cost / ref_cost, "pushes": len(found.actions),
            "redundant": redundant_actions(space, s0, found.actions),
            "collision": bool(space.checker.in_collision(found.states).any()), "cpu_time": cpu,
            "iterations": found.statistics["iterations"], "executions": executions}


def summary(runs: list[dict]) -> dict:
    ex = [x for r in runs for x in r["executions"]]
    ok = [x["ratio_plan"] <= 1.1 and not x["collided"] for x in ex]
    ratios = np.array([r["ratio"] for r in runs])
    out = {"tasks": len(runs), "plan_ratio_median": float(np.median(ratios)) if len(ratios) else float("nan"),
           "plans_within_10pct": int(np.sum(ratios <= 1.1)), "plan_collisions": sum(r["collision"] for r in runs),
           "executions": len(ex), "executions_within_10pct": int(sum(ok)),
           "execution_ratio_median": float(np.median([x["ratio_plan"] for x in ex])) if ex else float("nan"),
           "execution_ratio_max": float(max(x["ratio_plan"] for x in ex)) if ex else float("nan"),
           "pushes_per_plan_push_median": float(np.median([x["pushes"] / max(1, x["plan_pushes"]) for x in ex]))
           if ex else float("nan"),
           "at_action_limit": sum(x["outcome"] == "action limit" for x in ex),
           "outcomes": {v: sum(x["outcome"] == v for x in ex) for v in sorted({x["outcome"] for x in ex})}}
    for k in sorted({r["objects"] for r in runs}):
        sub = [r["ratio"] for r in runs if r["objects"] == k]
        out[f"plan_ratio_median_{k}_objects"] = float(np.median(sub))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="1 development task, 2 held-out (2 and 3 objects), "
                        "1 execution each, short budgets")
    parser.add_argument("--dev", type=int, default=None, help="development tasks (tsrrt-table, random starts)")
    parser.add_argument("--heldout", type=int, default=None, help="held-out tasks (2-5 objects, in turn)")
    parser.add_argument("--objects", type=int, nargs="*", default=None, help="object counts of the held-out tasks, "
                        "cycled (default 2 3 4 5)")
    parser.add_argument("--iterations", type=int, default=None, help="tree extensions per plan and replanning")
    parser.add_argument("--executions", type=int, default=None, help="noisy executions per plan")
    parser.add_argument("--rounds", type=int, default=None, help="rounds of the reference optimiser's descents")
    parser.add_argument("--action-limit", type=int, default=300)
    parser.add_argument("--only", type=int, nargs="*", default=None, help="run only these held-out tasks (indices; "
                        "the generator still draws every task before them, so each is the same task as in a full run)")
    parser.add_argument("--generator", type=int, default=33_000, help="the held-out generator's seed (33000: the "
                        "tasks looked at while tuning, now development data; 34000: held-out B, drawn after "
                        "execution.finish_steps was chosen)")
    parser.add_argument("--name", default=None, help="the JSON file's name (default tsrrt-heldout[-quick])")
    parser.add_argument("--set", action="append", default=[],
                        help="a TS-RRT option, NAME=VALUE (TOML value; a group's option as group.NAME)")
    args = parser.parse_args()
    args.dev = args.dev if args.dev is not None else (1 if args.quick else 6)
    args.heldout = args.heldout if args.heldout is not None else (2 if args.quick else 16)
    counts = args.objects or ([2, 3] if args.quick else [2, 3, 4, 5])
    args.iterations = args.iterations or (150 if args.quick else 600)
    args.executions = args.executions if args.executions is not None else (1 if args.quick else 3)
    args.rounds = args.rounds or (600 if args.quick else 3000)
    extra = {k: tomllib.loads(f"v = {v}")["v"] for k, v in (s.split("=", 1) for s in args.set)}
    options = build_options(TSRRTOptions, {"push.placement_noise": 0.004, **extra}, source="--set")
    options = replace(options, replan_time=600.0)          # only a cap: replanning runs to its work budget
    out: dict = {"generator": args.generator, "iterations": args.iterations, "executions": args.executions,
                 "rounds": args.rounds,
                 "action_limit": args.action_limit, "options": extra, "runs": []}
    name = args.name or ("tsrrt-heldout" + ("-quick" if args.quick else ""))
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tasks = [("development", "tsrrt-table", seed) for seed in range(args.dev)]
        gen = np.random.default_rng(args.generator)          # the held-out generator's own stream
        for i in range(args.heldout):
            scene_file = heldout_scene(gen, counts[i % len(counts)], Path(tmp), i)
            if args.only is None or i in args.only:
                tasks.append(("held-out", scene_file, 500 + i))
        for label, scene_name, seed in tasks:
            r = run_task(label, scene_name, seed, options, args)
            out["runs"].append(r)
            print(f"{label:<11} {Path(str(scene_name)).stem:<12} k={r['objects']} plan {r['cost']:.4f} ref "
                  f"{r['reference_cost']:.4f} ratio {r['ratio']:.3f} pushes {r['pushes']} cpu {r['cpu_time']:.1f}s "
                  "exec " + " ".join(f"{x['ratio_plan']:.3f}/{x['pushes']}/{x['outcome']}" for x in r["executions"]),
                  flush=True)
            write_json(name, out)                            # as it goes: a crash keeps the tasks done
    dev = summary([r for r in out["runs"] if r["set"] == "development"])
    held = summary([r for r in out["runs"] if r["set"] == "held-out"])
    out["summary"] = {"development": dev, "held-out": held, "wall_time": time.perf_counter() - t0}
    keys = [k for k in held if k != "outcomes"] + [k for k in dev if k not in held]
    rows = [(k, _fmt(dev.get(k)), _fmt(held.get(k))) for k in keys]
    rows += [("outcomes", _fmt(dev["outcomes"]), _fmt(held["outcomes"]))]
    print_table(f"TS-RRT, development (tsrrt-table) vs held-out (new classes and tables); {args.iterations} "
                f"iterations, {args.executions} noisy executions per plan, {args.action_limit}-push limit",
                ("figure", "development", "held-out"), rows)
    write_json(name, out)


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.3f}"
    if isinstance(v, dict):
        return ", ".join(f"{k} {n}" for k, n in v.items())
    return str(v)


if __name__ == "__main__":
    main()
