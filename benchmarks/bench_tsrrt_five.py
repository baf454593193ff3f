"""TS-RRT with five objects against the reference optimum: how the improvement phase's ``refine_optimum`` (targets
from the multi-start free-placement optimisation and its mirror images) and ``refine_optimum_orders`` (the orders of
the objects connecting to them) change the plans (docs/plugins/tsrrt.md,
"Why 5-object plans stop short").

Five of ``tsrrt-setting``'s eight objects, the default task cost, hand-made push models (4.5 cm pushes, 0.2 rad
turns: only the planner varies), a random collision-free start per seed (2 cm clearance), ``--iterations`` tree
extensions.  Development set: the first five objects, seeds 2000-2007 (where ``refine_optimum`` was chosen);
held-out set: the other objects (cup-1, plate-2, fork-2, knife-2, cup-2), seeds 3000-3007; held-out B, drawn after
the defaults were fixed: the forks, the knives and cup-2 (four boxes), seeds 4000-4007; held-out C, drawn after the
identical objects' assignment was chosen on B: plate-1, cup-1, plate-2, fork-2, cup-2, seeds 5000-5007; held-out D,
drawn in session 28 for the strokes experiment: plate-1, knife-1, plate-2, fork-2, knife-2, seeds 6000-6007; held-out
E (fork-1, knife-1, cup-1, fork-2, knife-2; seeds 7000-7007) and F (plate-1, fork-1, plate-2, knife-2, cup-2; seeds
8000-8007), drawn in session 35; held-out G (plate-1, knife-1, cup-1, knife-2, cup-2; seeds 9000-9007) and H (plate-1,
fork-1, knife-1, fork-2, knife-2; seeds 10000-10007), drawn in session 36 before plans with fractions of a stroke
were run anywhere; held-out I and J (session 36, for turning first); held-out K (plate-1, fork-1, cup-1, plate-2,
knife-2; seeds 13000-) and L (plate-1, knife-1, fork-2, knife-2, cup-2; 14000-), drawn in session 37 before a larger
optimiser population was run anywhere, and M (plate-1, fork-1, knife-1, plate-2, cup-2; 15000-) and N (fork-1,
cup-1, plate-2, knife-2, cup-2; 16000-), drawn before its three basins were; O (plate-1, fork-1, cup-1, fork-2,
cup-2; 17000-) and P (knife-1, cup-1, plate-2, fork-2, cup-2; 18000-), drawn in session 38 before a second
improvement run under a work budget ran anywhere, and Q (plate-1, knife-1, cup-1, plate-2, knife-2; 19000-) and R
(fork-1, knife-1, cup-1, fork-2, cup-2; 20000-), drawn after that run was chosen on L.  Plans use the option's
``planning.strokes`` (``--strokes 1``: whole pushes only).  Each ratio is the plan's final cost over the best
reference found for those objects (:func:`reference_optimum` with 3000 rounds and 512 members per pool from seed 0,
and 1500 rounds from each plan's final arrangement).  Every budget is a count (``--time``: a time budget instead,
and the plans then depend on the machine and its load); CPU seconds are reported.

    pliant bench tsrrt_five [-- --settings 0,3000 --seeds 8]
    pliant bench tsrrt_five -- --settings 3000:120 --sets "held-out G,held-out H" --strokes 1
    pliant bench tsrrt_five -- --settings 3000:120 --sets "held-out E" --seeds 8 --skip 4   # starts 4-7 only
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

#: the hand-made push models: +-x, +-y pushes of 4.5 cm, turns of +-0.2 rad (with 2 mm of drift)
MEANS = np.array([[0.045, 0, 0], [-0.045, 0, 0], [0, 0.045, 0], [0, -0.045, 0], [0, 0.002, 0.2], [0, -0.002, -0.2]])
#: development: where refine_optimum and its orders were chosen; held-out: run after refine_optimum's rounds were
#: chosen (and looked at again when the orders were added); held-out B: drawn after both were fixed (and where the
#: assignment of identical objects to the optimum's places was tried); held-out C: drawn after that (two plates, two
#: cups and a fork: three pairs of identical objects); held-out D: drawn in session 28 (two plates, two knives and a
#: fork); held-out E and F: drawn in session 35 before refine_optimum_turns was measured anywhere but B and D (E:
#: both forks, both knives and cup-1; F: both plates, fork-1, knife-2 and cup-2); held-out G and H: drawn in session 36
#: before planning.strokes was measured anywhere (G: plate-1, knife-1, both cups, knife-2; H: plate-1, both forks and
#: both knives, with cup-1 fixed in the middle); I and J: drawn in session 36 for turning first; K and L: drawn in
#: session 37 before refine_optimum_population 512 was run; M and N: before refine_optimum_basins 3 was; O and P:
#: session 38, before a second improvement run under a work budget (refine_restarts 2) was run anywhere; Q and R:
#: session 38, after that run was chosen on L and before it ran on them
SETS = {"development": ((0, 1, 2, 3, 4), 2000), "held-out": ((3, 4, 5, 6, 7), 3000),
        "held-out B": ((1, 2, 5, 6, 7), 4000),
        "held-out C": ((0, 3, 4, 5, 7), 5000),
        "held-out D": ((0, 2, 4, 5, 6), 6000),
        "held-out E": ((1, 2, 3, 5, 6), 7000),
        "held-out F": ((0, 1, 4, 6, 7), 8000),
        "held-out G": ((0, 2, 3, 6, 7), 9000),
        "held-out H": ((0, 1, 2, 5, 6), 10000),
        "held-out I": ((1, 2, 4, 5, 6), 11000),
        "held-out J": ((1, 2, 4, 6, 7), 12000),
        "held-out K": ((0, 1, 3, 4, 6), 13000),
        "held-out L": ((0, 2, 5, 6, 7), 14000),
        "held-out M": ((0, 1, 2, 4, 7), 15000),
        "held-out N": ((1, 3, 4, 6, 7), 16000),
        "held-out O": ((0, 1, 3, 5, 7), 17000),
        "held-out P": ((2, 3, 4, 5, 7), 18000),
        "held-out Q": ((0, 2, 3, 4, 6), 19000),
        "held-out R": ((1, 2, 3, 5, 7), 20000)}


class _Models:
    """The hand-made models (whole strokes; ``planning.strokes`` adds their fractions)."""

    def means(self, classes):
        return np.repeat(MEANS[None], len(classes), 0)


def run_set(label: str, indices, base: int, seeds: int, settings: list[str], iterations: int,
            overrides: dict | None = None, seconds: float | None = None, on_plan=None, skip: int = 0) -> list[dict]:
    """Plan starts ``skip`` to ``seeds - 1`` of one set; ``on_plan(plans, reference)`` after each plan (to write
    results as they go)."""
    from pliant import api
    from pliant.api import Termination, build_options
    from pliant_tsrrt.planner import TSRRTOptions, build_space
    from pliant_tsrrt.reference import random_arrangements, reference_optimum
    from pliant_tsrrt.search import grow

    scene = api.load_scene("tsrrt-setting")
    movable = [o.name for o in scene.objects if o.movable]
    names = [movable[i] for i in indices]
    space, ref, plans = None, np.inf, []
    for seed in range(base + skip, base + seeds):
        for setting in settings:
            rounds, _, orders = setting.partition(":")
            options = build_options(TSRRTOptions, {"objects": tuple(names), "improvement.refine_optimum": int(rounds),
                                                   "improvement.refine_optimum_orders": int(orders or 0),
                                                   **(overrides or {})})
            if space is None:
                space = build_space(scene, options, _Models(), names)
                space.warm_up()
                ref = reference_optimum(space, np.random.default_rng(0), rounds=3000, population=512)[1]
            rng = np.random.default_rng(seed)
            start = random_arrangements(space, rng, 1, clearance=0.02)[0]
            t = time.process_time()
            budget = Termination(max_iterations=iterations) if seconds is None else Termination(max_time=seconds)
            found = grow(space, start, rng, options, budget)
            cpu = time.process_time() - t
            ref = min(ref, reference_optimum(space, np.random.default_rng(seed), rounds=1500,
                                             starts=found.states[-1][None])[1])
            plans.append({"set": label, "objects": names, "seed": seed, "refine_optimum": setting,
                          "cost": float(found.cost), "cpu_s": cpu, "pushes": len(found.actions),
                          "iterations": int(found.statistics["iterations"]),
                          "refine_runs": int(found.statistics.get("refine_runs", 0)),
                          "refine_run_gains": [float(g) for g in found.statistics.get("refine_run_gains", [])]})
            print(f"{label} seed {seed} refine_optimum {setting}: cost {found.cost:.4f}, {len(found.actions)} pushes, "
                  f"{cpu:.1f} s CPU, {plans[-1]['iterations']} tree extensions, {plans[-1]['refine_runs']} "
                  f"improvement runs", flush=True)
            if on_plan is not None:
                on_plan(plans, ref)
    for plan in plans:
        plan["reference"] = float(ref)
        plan["ratio"] = plan["cost"] / ref
    return plans


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--settings", default="0,3000,3000:120", help="settings to compare (comma-separated): "
                        "refine_optimum rounds, with ':N' refine_optimum_orders N (without: 0)")
    parser.add_argument("--seeds", type=int, default=8, help="starts per set")
    parser.add_argument("--iterations", type=int, default=600, help="tree extensions per plan")
    parser.add_argument("--time", type=float, default=None, metavar="SECONDS",
                        help="a time budget per plan instead of --iterations: the plans then depend on the machine "
                             "and its load")
    parser.add_argument("--skip", type=int, default=0, metavar="N",
                        help="leave out each set's first N starts (to split a set over processes; then take each "
                             "ratio against the lower of their references)")
    parser.add_argument("--sets", default="development,held-out,held-out B")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="another TS-RRT option for every plan (e.g. improvement.refine_width=128)")
    parser.add_argument("--strokes", default=None, help="fractions of a stroke the plans may push with, "
                        "comma-separated, the whole stroke first (1: whole pushes only): planning.strokes, default "
                        "the option's")
    args = parser.parse_args()
    from pliant.api import PliantError, build_options, parse_override
    from pliant_tsrrt.options import TSRRTOptions

    overrides = {}
    for item in args.set:
        try:
            key, value = parse_override(item, "<command line>")
        except PliantError as exc:
            parser.error(str(exc))
        overrides[key] = value
    if args.strokes is not None:
        try:
            overrides["planning.strokes"] = tuple(float(f) for f in args.strokes.split(","))
        except ValueError:
            parser.error(f"--strokes {args.strokes!r}: expected comma-separated numbers")
    try:
        strokes = build_options(TSRRTOptions, overrides, source="<command line>").planning.strokes
    except PliantError as exc:
        parser.error(str(exc))
    if args.time is not None and not args.time > 0:
        parser.error(f"--time {args.time}: must be a positive number of seconds")
    if not 0 <= args.skip < args.seeds:
        parser.error(f"--skip {args.skip}: must be at least 0 and below --seeds ({args.seeds})")
    settings = args.settings.split(",")
    unknown = [label for label in args.sets.split(",") if label not in SETS]
    if unknown:
        parser.error(f"--sets: unknown set {unknown[0]!r} (known: {', '.join(SETS)})")
    plans = []

    def write(partial: list[dict], reference: float | None = None) -> None:
        # after every plan: a run stopped early keeps what it planned (the ratios against the reference so far)
        done = [dict(p, reference=float(reference), ratio=p["cost"] / reference) for p in partial] \
            if reference is not None else []
        write_json("tsrrt_five", {"settings": settings, "iterations": args.iterations, "time": args.time,
                                  "skip": args.skip,
                                  "strokes": list(strokes), "complete": reference is None, "plans": plans + done})

    for label in args.sets.split(","):
        indices, base = SETS[label]
        plans += run_set(label, indices, base, args.seeds, settings, args.iterations, overrides, args.time,
                         on_plan=write, skip=args.skip)
    rows = []
    for label in args.sets.split(","):
        for setting in settings:
            mine = [p for p in plans if p["set"] == label and p["refine_optimum"] == setting]
            ratios = [p["ratio"] for p in mine]
            rows.append((label, setting, f"{np.median(ratios):.3f}", f"{sum(r <= 1.1 for r in ratios)}/{len(ratios)}",
                         " ".join(f"{r:.3f}" for r in ratios), f"{np.median([p['cpu_s'] for p in mine]):.1f}",
                         f"{mine[0]['reference']:.4f}"))
    print_table("TS-RRT, 5 objects: plan / reference optimum (target: median <= 1.1)",
                ("set", "refine_optimum", "median", "within 10%", "ratios", "CPU s (median)", "reference"), rows)
    write(plans)


if __name__ == "__main__":
    main()
