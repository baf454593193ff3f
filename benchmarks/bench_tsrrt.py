"""TS-RRT (Scholz & Stilman, poster ICHR 2010; issue 18): model learning, plan quality, execution with noise and
replanning, and how planning grows with the number of objects.  Every push is simulated by pymunk (through the core's
Simulator interface); planning uses the learned models.

1. **Model learning** (``tsrrt-table``, three classes): pushes per class and primitive until the standard error of
   the model's mean is below ``sigma_ref`` (LEARN_MODEL), with execution noise (the paddle's placement error and
   pymunk's bounded actuation noise), and the models' prediction error on ``--holdout`` further pushes each.
2. **Plan quality** (``tsrrt-table``, 3 objects at random collision-free poses, one per seed): TS-RRT with a
   ``--budget`` s budget; the final arrangement's cost against the best arrangement found by a long free-placement
   optimisation of the same cost (``pliant_tsrrt.reference.reference_optimum``, multi-start: random arrangements,
   yaws snapped to 90 degrees, packed patterns, and the plan's final one), its collisions (none allowed) and its
   redundant actions (actions that could be dropped alone without raising the final cost).
3. **Execution** of each plan in pymunk with noise, monitoring and replanning: the final cost against the
   reference (within 10 %) and against the plan (within 10 %), collisions, replans.
4. **Scaling** (``tsrrt-setting``, table-setting relations, 2 .. 8 objects): tree growth to ``--nodes`` nodes;
   time, nodes, time to the best node, cost.

    python benchmarks/bench_tsrrt.py --quick        (3 seeds, short reference optimisation)
    python benchmarks/bench_tsrrt.py                (10 seeds, 2 executions per plan)
    python benchmarks/bench_tsrrt.py --plan-only    (parts 1-2: planning alone, for the planning time)
    python benchmarks/bench_tsrrt.py --iterations 3000 --plan-only   (an iteration budget: machine-independent)
    python benchmarks/bench_tsrrt.py --reach        (how close each object gets to the free optimum's pose)
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, write_json
from pliant.options import build_options
from pliant.termination import Termination
from pliant_tsrrt.execution import execute_plan
from pliant_tsrrt.learning import learn_models
from pliant_tsrrt.planner import (
    PushPlan,
    TSRRTOptions,
    arena,
    build_space,
)
from pliant_tsrrt.pushing import PRIMITIVES
from pliant_tsrrt.reference import optimise, random_arrangements, reference_optimum
from pliant_tsrrt.reproduce import world
from pliant_tsrrt.search import grow, redundant_actions

SETTING_ORDER = ["plate-1", "fork-1", "knife-1", "cup-1", "plate-2", "fork-2", "knife-2", "cup-2"]
SETTING_RELATIONS = {"plate-1": "table 0.3 0.25", "fork-1": "plate-1 -0.15 0.0", "knife-1": "plate-1 0.15 0.0",
                     "cup-1": "plate-1 0.14 0.16", "plate-2": "table 0.7 0.25", "fork-2": "plate-2 -0.15 0.0",
                     "knife-2": "plate-2 0.15 0.0", "cup-2": "plate-2 0.14 0.16"}


def world_for(scene_name: str, noise: bool):
    """The pymunk world on a scene (bounded actuation noise of 0.01 m/s with ``noise``), as the poster
    reproduction builds it."""
    return world(scene_name, noise)


def relations_for(names: list[str]) -> tuple[str, ...]:
    out = []
    for n in names:
        ref = SETTING_RELATIONS[n].split()[0]
        if ref == "table" or ref in names:
            out.append(f"{n} {SETTING_RELATIONS[n]}")
        else:                                   # the reference is not planned: the object's absolute target
            plate = np.array([float(v) for v in SETTING_RELATIONS[ref].split()[1:]])
            off = np.array([float(v) for v in SETTING_RELATIONS[n].split()[1:]])
            out.append(f"{n} table {plate[0] + off[0]:.3f} {plate[1] + off[1]:.3f}")
    return tuple(out)


def adaptation_log(record) -> list[dict]:
    """An execution's repairs and replannings, compact: after which push, why (for a deviation: the push's object and
    primitive and its error from the plan, mm and degrees), a repair or a replanning, the cost before and as
    planned, the plan's length and the pushes a repair added."""
    log = []
    for a in record.details.adaptations:
        entry = {"after": a["after_action"], "reason": a["reason"], "repair": bool(a.get("repair")),
                 "cost_before": round(a["cost_before"], 4), "planned_cost": round(a["planned_cost"], 4),
                 "actions": a["actions"], "added": a.get("repair_pushes")}
        i = a["after_action"] - 1
        push = record.details.actions[i] if 0 <= i < len(record.details.actions) else {}
        if a["reason"] == "deviation" and "plan_error" in push:
            entry["push"] = f"{push['object']} {push['primitive']}"
            entry["error"] = [round(1000 * push["plan_error"], 1),
                              round(float(np.degrees(push["plan_angle_error"])), 1)]
        log.append(entry)
    return log


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval (95 %) of a proportion."""
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return float(centre - half), float(centre + half)


def reach_pose(space, o: int, pose: np.ndarray, target: np.ndarray, depth: int, width: int = 3000) -> list[float]:
    """The least pose error (m; yaw as the circumscribed radius times the angle, modulo the footprint's symmetry)
    to ``target`` that object ``o`` reaches from ``pose`` with 1 .. ``depth`` of its pushes (mean displacements; a
    beam of ``width`` poses closest to the target, duplicates within 0.5 mm / 0.1 degree merged; no collision
    checks)."""
    from pliant_tsrrt.models import compose

    def err(p):
        d = p - target
        dth = (d[..., 2] + space.period[o] / 2) % space.period[o] - space.period[o] / 2
        return np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2 + (space.scale[o] * dth) ** 2)

    frontier, best, out = pose[None], float(err(pose)), []
    for _ in range(depth):
        after = compose(np.repeat(frontier, 6, axis=0), np.tile(space.means[o], (len(frontier), 1)))
        e = err(after)
        key = np.round(np.stack([after[:, 0] / 5e-4, after[:, 1] / 5e-4, ((after[:, 2] + np.pi) % (2 * np.pi)) / 2e-3],
                                axis=-1)).astype(np.int64)
        _, first = np.unique(key, axis=0, return_index=True)
        keep = first[np.argsort(e[first])][:width]
        frontier, best = after[keep], min(best, float(e[keep[0]]))
        out.append(best)
    return out


def reachability(options, seeds: int, rounds: int) -> None:
    """Whether the free-placement optimum can be reached with the six primitives' quantised steps."""
    scene, sim = world_for("tsrrt-table", noise=True)
    models, _ = learn_models(arena(sim, scene, options), options.learning, np.random.default_rng(0))
    names = [o.name for o in scene.objects if o.movable]
    space = build_space(scene, options, models, names)
    ref, ref_cost = optimise(space, np.random.default_rng(0), rounds=rounds)
    depths = (4, 8, 12, 16, 20, 24)
    rows, out = [], []
    for seed in range(seeds):
        rng = np.random.default_rng(1000 + seed)
        s0 = random_arrangements(space, rng, 1, clearance=options.start_clearance)[0]
        errs = [reach_pose(space, o, s0[o], ref[o], max(depths)) for o in range(space.k)]
        for o, name in enumerate(names):
            rows.append((seed, name, *(f"{1000 * errs[o][d - 1]:.1f}" for d in depths)))
        out.append({"seed": seed, "errors": errs})
    print_table(f"reachability: least pose error (mm) to the free-placement optimum (cost {ref_cost:.4f}) with n "
                "pushes of the object alone (mean displacements, no collision checks)",
                ("seed", "object", *(f"n={d}" for d in depths)), rows)
    # what a pose error costs: the optimum with each object moved by e along the worst direction for its edge term
    for e in (0.002, 0.005, 0.01):
        worst = []
        for _ in range(200):
            t = ref.copy()
            ang = np.random.default_rng(len(worst)).uniform(-np.pi, np.pi, space.k)
            t[:, 0] += e * np.cos(ang)
            t[:, 1] += e * np.sin(ang)
            worst.append(float(space.cost.cost(t[None])[0]))
        print(f"every object {1000 * e:.0f} mm off in a random direction: cost / optimum median "
              f"{np.median(worst) / ref_cost:.3f}, worst {max(worst) / ref_cost:.3f}")
    write_json("tsrrt-reach", {"reference": ref.tolist(), "reference_cost": ref_cost, "depths": list(depths),
                               "runs": out})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="3 seeds, 1 execution each, short reference search")
    parser.add_argument("--seeds", type=int, default=None)
    parser.add_argument("--budget", type=float, default=5.0, help="TS-RRT time budget (s): tree, improvement and "
                        "shortcut together")
    parser.add_argument("--iterations", type=int, default=None, help="instead of the time budget: this many tree "
                        "iterations, the improvement phase without a deadline (results independent of the machine)")
    parser.add_argument("--plan-only", action="store_true", help="parts 1-2 only: no executions, no scaling (the "
                        "quietest run for the planning time)")
    parser.add_argument("--executions", type=int, default=None, help="noisy executions per plan")
    parser.add_argument("--rounds", type=int, default=None, help="rounds of the free-placement optimisation")
    parser.add_argument("--nodes", type=int, default=1500, help="tree size for the scaling runs")
    parser.add_argument("--holdout", type=int, default=5)
    parser.add_argument("--noise", type=float, default=0.004, help="paddle placement noise (m, std)")
    parser.add_argument("--action-limit", type=int, default=300, help="most pushes per execution (the pipelines' "
                        "[execution] action_limit)")
    parser.add_argument("--action-limit-per-push", type=float, default=0.0, help="a limit relative to the plan's "
                        "length: each execution may take max(--action-limit, this x the plan's pushes) pushes (a "
                        "longer plan needs proportionally more pushes under noise; 0: the fixed limit alone)")
    parser.add_argument("--reach", action="store_true", help="only the reachability check: how close each object "
                        "gets to its pose in the best free-placement arrangement with its own pushes (beam search "
                        "through the models, the other objects ignored), from each seed's start")
    parser.add_argument("--skip-scaling", action="store_true")
    parser.add_argument("--only-scaling", action="store_true")
    parser.add_argument("--set", action="append", default=[],
                        help="a TS-RRT option, NAME=VALUE (TOML value; a group's option as group.NAME)")
    args = parser.parse_args()
    seeds = args.seeds or (3 if args.quick else 10)
    executions = 0 if args.plan_only else (args.executions or (1 if args.quick else 2))
    if args.plan_only:
        args.skip_scaling = True
    rounds = args.rounds or (1500 if args.quick else 6000)
    import tomllib

    extra = {k: tomllib.loads(f"v = {v}")["v"] for k, v in (s.split("=", 1) for s in args.set)}
    options = build_options(TSRRTOptions, {"push.placement_noise": args.noise, **extra}, source="--set")
    out: dict = {"budget": args.budget, "iterations": args.iterations, "seeds": seeds, "noise": args.noise,
                 "action_limit": args.action_limit, "action_limit_per_push": args.action_limit_per_push,
                 "options": extra}
    load0 = f"{os.getloadavg()[0]:.2f}"
    name = "tsrrt" + ("-quick" if args.quick else "") + ("-plan" if args.plan_only else "") + \
        (f"-it{args.iterations}" if args.iterations else "") + ("-scaling" if args.only_scaling else "")
    out["load_average_start"] = os.getloadavg()

    if args.reach:
        reachability(options, seeds, rounds)
        return
    if not args.only_scaling:
        # 1. model learning, with noise
        scene, sim = world_for("tsrrt-table", noise=True)
        rng = np.random.default_rng(0)
        t0 = time.perf_counter()
        models, report = learn_models(arena(sim, scene, options), options.learning, rng, holdout=args.holdout)
        learn_time = time.perf_counter() - t0
        rows = []
        for cls, per in models.models.items():
            for p, d in zip(PRIMITIVES, per):
                h = report["holdout"][cls][p]
                rows.append((cls, p, d.n, f"{1000 * d.mean[0]:.1f}", f"{1000 * d.mean[1]:.1f}",
                             f"{np.degrees(d.mean[2]):.1f}", f"{1000 * np.hypot(*d.std[:2]):.1f}",
                             f"{np.degrees(d.std[2]):.2f}", f"{1000 * h['translation_error']:.1f}",
                             f"{np.degrees(h['rotation_error']):.2f}", f"{h['coverage95']:.2f}"))
        lo = options.learning
        print_table(f"1. LEARN_MODEL on tsrrt-table with noise ({learn_time:.1f} s; sigma_ref "
                    f"{lo.sigma_ref * 1000:.0f} mm / {np.degrees(lo.sigma_ref_angle):.2f} deg)",
                    ("class", "primitive", "pushes", "dx mm", "dy mm", "dth deg", "sd mm", "sd deg", "held-out err mm",
                     "held-out err deg", "in 95%"), rows)
        out["learning"] = {"time": learn_time, "pushes": report["pushes"], "holdout": report["holdout"],
                           "models": models.to_dict()}

        # 2-3. plan quality and execution
        names = [o.name for o in scene.objects if o.movable]
        space = build_space(scene, options, models, names)
        space.warm_up()                     # compiled kernels: not charged to the first seed's budget
        rows, runs = [], []
        for seed in range(seeds):
            rng = np.random.default_rng(1000 + seed)
            s0 = random_arrangements(space, rng, 1, clearance=options.start_clearance)[0]
            term = Termination(max_iterations=args.iterations) if args.iterations else \
                Termination(max_time=args.budget)
            cpu0 = time.process_time()
            found = grow(space, s0, rng, options, term)
            cpu = time.process_time() - cpu0                 # CPU time: what the plan costs on an idle core
            st = found.statistics
            best_at = st["cost_history"][-1][0]
            # the multi-start reference (orientations, packed patterns; issue 33), not the single-start optimise
            _, ref_cost = reference_optimum(space, np.random.default_rng(seed), rounds=rounds,
                                            starts=found.states[-1][None])
            _, ref_random_cost = reference_optimum(space, np.random.default_rng(seed), rounds=rounds)
            ratio = found.cost / ref_cost
            collided = bool(space.checker.in_collision(found.states).any())
            redundant = redundant_actions(space, s0, found.actions)
            plan = PushPlan(names, s0, found.actions, found.states, found.cost, asdict(options), models)
            ex = []
            limit = max(args.action_limit, int(np.ceil(args.action_limit_per_push * len(found.actions))))
            for e in range(executions):
                _, world = world_for("tsrrt-table", noise=True)
                record = execute_plan(plan, world, scene, np.random.default_rng(50_000 + 100 * seed + e),
                                      action_limit=limit)
                done = record.details
                ex.append({"final_cost": done.final_cost, "ratio_reference": done.final_cost / ref_cost,
                           "ratio_plan": done.final_cost / found.cost, "collided": done.collided,
                           "replans": sum(not a.get("repair") for a in done.adaptations),
                           "repairs": sum(bool(a.get("repair")) for a in done.adaptations),
                           "pushes": len(done.actions), "action_limit": limit,
                           "outcome": record.outcome.value, "adaptations": adaptation_log(record)})
            runs.append({"seed": seed, "start_cost": float(space.cost.cost(s0[None])[0]), "cost": found.cost,
                         "reference_cost": ref_cost, "reference_random_starts_cost": ref_random_cost,
                         "ratio": ratio, "collision": collided, "redundant": redundant, "actions": len(found.actions),
                         "actions_before_shortcut": st["actions_before_shortcut"], "nodes": st["nodes"],
                         "iterations": st["iterations"], "tree_time": st["tree_time"], "time": st["time"],
                         "refine_time": st["refine_time"], "cpu_time": cpu, "tree_best_cost": st["tree_best_cost"],
                         "refine_branch": st["refine_branch"], "refine_pushes": st["refine_pushes"],
                         "refine_targets": st["refine_targets"], "time_to_best": best_at, "executions": ex,
                         "plan": {"start": s0.tolist(), "actions": [int(a) for a in found.actions]}})
            rows.append((seed, f"{runs[-1]['start_cost']:.3f}", f"{st['tree_best_cost']:.3f}", f"{found.cost:.3f}",
                         f"{ref_cost:.3f}", f"{ratio:.3f}", "yes" if collided else "no", redundant,
                         f"{st['refine_branch']}/{st['actions_before_shortcut']}+{st['refine_pushes']}",
                         len(found.actions), st["nodes"], f"{st['tree_time']:.2f}", f"{st['time']:.2f}", f"{cpu:.2f}",
                         " ".join(f"{x['ratio_reference']:.3f}/{x['ratio_plan']:.3f}/{x['replans']}/{x['repairs']}"
                                  for x in ex)))
            print(f"seed {seed}: cost {found.cost:.4f} ref {ref_cost:.4f} ratio {ratio:.3f}", flush=True)
        budget = f"{args.iterations} iterations" if args.iterations else f"budget {args.budget:g} s"
        print_table(f"2-3. TS-RRT on tsrrt-table, 3 objects at random poses, {budget}; executed in pymunk "
                    f"with noise (placement {args.noise * 1000:.0f} mm, actuation 0.01 m/s) and replanning",
                    ("seed", "start", "tree", "TS-RRT", "free opt", "ratio", "collision", "redundant",
                     "kept+added", "pushes", "nodes", "t tree s", "t total s", "cpu s",
                     "exec: /ref /plan replans/repairs"),
                    rows)
        # every seed arranges the same objects under the same cost: the best free placement over all seeds is the
        # reference
        best_ref = min(min(r["reference_cost"], r["reference_random_starts_cost"]) for r in runs)
        for r in runs:
            r["ratio"] = r["cost"] / best_ref
            for x in r["executions"]:
                x["ratio_reference"] = x["final_cost"] / best_ref
        print(f"\nbest free-placement cost over all seeds: {best_ref:.4f}; ratios: "
              + " ".join(f"{r['ratio']:.3f}" for r in runs))
        ratios = np.array([r["ratio"] for r in runs])
        exr = [x for r in runs for x in r["executions"]]
        within_ref = np.mean([x["ratio_reference"] <= 1.1 and not x["collided"] for x in exr]) if exr else float("nan")
        within_plan = np.mean([x["ratio_plan"] <= 1.1 and not x["collided"] for x in exr]) if exr else float("nan")
        n_ok = sum(x["ratio_plan"] <= 1.1 and not x["collided"] for x in exr)
        lo, hi = wilson(n_ok, len(exr)) if exr else (float("nan"), float("nan"))
        summary = {"reference_cost": best_ref, "ratio_median": float(np.median(ratios)),
                   "ratio_max": float(ratios.max()),
                   "plans_within_10pct": float(np.mean(ratios <= 1.1)),
                   "collisions": int(sum(r["collision"] for r in runs)),
                   "redundant_actions": int(sum(r["redundant"] for r in runs)),
                   "executions": len(exr), "executions_within_10pct_of_reference": float(within_ref),
                   "executions_within_10pct_of_plan": float(within_plan),
                   "executions_within_10pct_of_plan_wilson95": [lo, hi],
                   "execution_collisions": int(sum(x["collided"] for x in exr)),
                   "replans_mean": float(np.mean([x["replans"] for x in exr])) if exr else float("nan"),
                   "repairs_mean": float(np.mean([x["repairs"] for x in exr])) if exr else float("nan"),
                   "execution_pushes_median": float(np.median([x["pushes"] for x in exr])) if exr else float("nan"),
                   "executions_at_action_limit": int(sum(x["outcome"] == "action limit" for x in exr)),
                   "execution_pushes_max": int(max(x["pushes"] for x in exr)) if exr else 0,
                   "execution_pushes_per_plan_push_median": float(np.median(
                       [x["pushes"] / max(1, r["actions"]) for r in runs for x in r["executions"]])) if exr
                   else float("nan"),
                   "executions_above_base_limit": int(sum(x["pushes"] > args.action_limit for x in exr)),
                   "tree_best_median": float(np.median([r["tree_best_cost"] for r in runs])) / best_ref,
                   "time_tree_median": float(np.median([r["tree_time"] for r in runs])),
                   "time_total_median": float(np.median([r["time"] for r in runs])),
                   "time_total_max": float(np.max([r["time"] for r in runs])),
                   "cpu_time_median": float(np.median([r["cpu_time"] for r in runs])),
                   "cpu_time_max": float(np.max([r["cpu_time"] for r in runs])),
                   "nodes_median": float(np.median([r["nodes"] for r in runs])),
                   "pushes_median": float(np.median([r["actions"] for r in runs]))}
        out["runs"], out["summary"] = runs, summary
        write_json(name, out)          # again below with the scaling
        print(f"load average before / after: {load0} / {os.getloadavg()[0]:.2f}")
        print("\nsummary: " + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else
                                        f"{k} {v[0]:.2f}-{v[1]:.2f}" if isinstance(v, list) else f"{k} {v}"
                                        for k, v in summary.items()))
        out["runs"], out["summary"] = runs, summary

    # 4. scaling with the number of objects (table setting)
    if not args.skip_scaling:
        scene, sim = world_for("tsrrt-setting", noise=False)
        o = build_options(TSRRTOptions, {"cost.w_setting": 1.0, "cost.relations": relations_for(SETTING_ORDER)})
        models, _ = learn_models(arena(sim, scene, o), o.learning, np.random.default_rng(0))
        rows, scaling = [], []
        for k in range(2, 9):
            sub = SETTING_ORDER[:k]
            ok = build_options(TSRRTOptions, {"cost.w_setting": 1.0, "cost.relations": relations_for(sub),
                                              "objects": tuple(sub), "max_nodes": args.nodes, **extra}, source="--set")
            sp = build_space(scene, ok, models, sub)
            times, nodes, costs, starts, best_t, its, tree_t, cpus = [], [], [], [], [], [], [], []
            for seed in range(min(seeds, 3)):
                rng = np.random.default_rng(2000 + seed)
                s0 = random_arrangements(sp, rng, 1, clearance=0.02)[0]      # 8 objects do not fit 6 cm apart
                cpu0 = time.process_time()
                found = grow(sp, s0, rng, ok, Termination(max_time=120.0))
                cpus.append(time.process_time() - cpu0)
                times.append(found.statistics["time"])
                tree_t.append(found.statistics["tree_time"])
                best_t.append(found.statistics["cost_history"][-1][0])
                nodes.append(found.statistics["nodes"])
                its.append(found.statistics["iterations"])
                costs.append(found.cost)
                starts.append(float(sp.cost.cost(s0[None])[0]))
            scaling.append({"objects": k, "time": times, "tree_time": tree_t, "cpu_time": cpus, "nodes": nodes,
                            "iterations": its,
                            "cost": costs,
                            "start_cost": starts, "time_to_best": best_t})
            rows.append((k, f"{np.median(times):.2f}", f"{np.median(tree_t):.2f}", f"{np.median(cpus):.2f}",
                         f"{np.median(best_t):.2f}", int(np.median(nodes)), int(np.median(its)),
                         f"{1000 * np.median(tree_t) / np.median(its):.2f}",
                         f"{1000 * np.median(cpus) / np.median(its):.2f}",
                         f"{np.median(starts):.2f}", f"{np.median(costs):.2f}"))
            print(f"{k} objects: {np.median(times):.2f} s", flush=True)
        print_table(f"4. scaling on tsrrt-setting (table-setting cost), tree of {args.nodes} nodes, median of "
                    f"{min(seeds, 3)} random starts"
                    f"{'' if ok.improvement.refine else ' (no improvement phase)'}; load average "
                    f"{os.getloadavg()[0]:.2f}", ("objects", "time s", "tree s", "cpu s", "t best s", "nodes",
                                                  "iterations", "ms/iteration", "cpu ms/iteration", "start cost",
                                                  "final cost"), rows)
        out["scaling"] = scaling
    write_json(name, out)


if __name__ == "__main__":
    main()
