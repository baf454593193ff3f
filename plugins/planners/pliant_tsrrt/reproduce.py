"""``pliant reproduce poster``: the claims of the TS-RRT poster (Scholz & Stilman, ICHR 2010) on ``tsrrt-table``.

The poster gives no numbers; it claims that after planning and executing on three unfamiliar objects

- "all objects pushed to orthonormal orientations in the center of the workspace",
- "all paths free of collisions and redundant actions",
- "robot monitored error and replanned as necessary",

and shows the learned models (mean and 95 % interval of the displacement per workspace dimension, per primitive,
per class).  The reproduction measures each claim: LEARN_MODEL with noise on the scene's three classes (book, block,
can), then TS-RRT from random collision-free arrangements with an iteration budget (so plans depend on the seed
only), each plan's final cost against the cheapest free placement of the same cost found over every start
(:func:`pliant_tsrrt.reference.optimise`), its collisions, its redundant actions, how far the final arrangement is
from the table axes and from the table's centre, and noisy executions in pymunk with monitoring and replanning.

Checked headlines are the seeded planning results.  Executions replan with a time budget (``replan_time``), so
their figures depend on the machine and are reported, never checked.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict

import numpy as np
from pliant.api import Headline, ReproductionRun, Row
from pliant.api import ReproductionOutcome as Outcome

MODES = {"full": "10 random starts, 3,000 tree iterations each, 5 noisy executions per plan, a 6,000-round "
                 "free-placement optimisation per start",
         "quick": "5 random starts, 3,000 tree iterations each, 2 noisy executions per plan, 3,000 rounds",
         "ci": "3 random starts, 3,000 tree iterations each, 1 noisy execution per plan, 1,500 rounds"}
MINUTES = {"full": 12, "quick": 5, "ci": 3}
SETTINGS = {"full": {"starts": 10, "executions": 5, "rounds": 6000},
            "quick": {"starts": 5, "executions": 2, "rounds": 3000},
            "ci": {"starts": 3, "executions": 1, "rounds": 1500}}
ITERATIONS = 3000
SCENE = "tsrrt-table"
#: the execution noise of the benchmark and the docs: paddle placement 4 mm (std), pymunk's bounded actuation
#: noise 0.01 m/s and 0.01 rad/s
PLACEMENT_NOISE = 0.004
ACTUATION_NOISE = 0.01
#: an execution ends "within the cost tolerance" (issue 18, docs/plugins/tsrrt.md) at most 10 % above the plan's cost
EXECUTION_TOLERANCE = 0.10
#: pushes an execution may take, replans included (the pipelines' limit)
ACTION_LIMIT = 300


def declarations() -> list:
    """The poster's reproduction, for the ``pliant_reproductions`` hook."""
    from pliant.api import Reproduction

    return [Reproduction("poster", "The TS-RRT poster (ICHR 2010): object-space planning on three unfamiliar objects",
                         "pliant_tsrrt.reproduce:poster", MODES, MINUTES)]


def world(scene_name: str = SCENE, noise: bool = True):
    """The scene ``scene_name`` and a pymunk world on it, with the docs' bounded actuation noise when ``noise``
    (through the registry: this plugin does not import the simulator's).  The benchmark uses it too."""
    from pliant import api
    from pliant.api import Context, registry

    scene = api.load_scene(scene_name)
    ctx = Context(scene=scene)
    ctx.robot = registry.create("robot", "rigid", ctx)
    extra = {"noise": "bounded", "noise_linear": ACTUATION_NOISE, "noise_angular": ACTUATION_NOISE} if noise else {}
    return scene, registry.create("simulator", "pymunk", ctx, max_force=50.0, **extra)


def axis_deviation(poses: np.ndarray, circular: np.ndarray) -> float:
    """Largest angle (rad) between an object's axes and the table's, over the objects that have axes (not
    ``circular``): 0 when every box is at a multiple of 90 degrees, at most 45 degrees."""
    yaw = np.asarray(poses, dtype=np.float64)[~np.asarray(circular, dtype=bool), 2]
    if not len(yaw):
        return 0.0
    quarter = np.pi / 2
    return float(np.max(np.abs((yaw + quarter / 2) % quarter - quarter / 2)))


def centre_offset(poses: np.ndarray, fp, table: tuple[float, float, float, float]) -> float:
    """Distance (m) between the centre of the arrangement's bounding box (object centres widened by their
    circumscribed radii) and the table's centre."""
    p = np.asarray(poses, dtype=np.float64)
    lo = (p[:, :2] - fp.radius[:, None]).min(axis=0)
    hi = (p[:, :2] + fp.radius[:, None]).max(axis=0)
    x0, y0, x1, y1 = table
    return float(np.hypot(*((lo + hi) / 2 - np.array([(x0 + x1) / 2, (y0 + y1) / 2]))))


def poster(run: ReproductionRun) -> Outcome:
    """Run the poster's demo: learn the push models, plan from random starts, execute with noise and replanning."""
    from pliant.api import Termination, stream

    from pliant_tsrrt import domain
    from pliant_tsrrt.execution import execute_plan
    from pliant_tsrrt.figures import draw_models, draw_plan
    from pliant_tsrrt.learning import learn_models
    from pliant_tsrrt.options import PushingOptions
    from pliant_tsrrt.planner import (
        PushPlan,
        TSRRTOptions,
        arena,
        build_space,
    )
    from pliant_tsrrt.pushing import PRIMITIVES
    from pliant_tsrrt.reference import optimise, random_arrangements
    from pliant_tsrrt.search import grow, redundant_actions

    settings = {**SETTINGS[run.mode], "iterations": ITERATIONS, "scene": SCENE, "placement_noise": PLACEMENT_NOISE,
                "actuation_noise": ACTUATION_NOISE, "action_limit": ACTION_LIMIT}
    run.output.mkdir(parents=True, exist_ok=True)
    options = TSRRTOptions(push=PushingOptions(placement_noise=PLACEMENT_NOISE))

    run.echo("LEARN_MODEL on the three classes, with noise")
    scene, sim = world()
    t0 = time.perf_counter()
    # one run seeded 0 learns the models; start s draws its arrangement and plan from run s's planning stream, its
    # reference optimum from task stream "reference" and execution e from execution stream e (pliant.seeds)
    models, report = learn_models(arena(sim, scene, options), options.learning, stream(0, "learning"),
                                  holdout=5)
    learn_seconds = time.perf_counter() - t0
    names = [o.name for o in scene.objects if o.movable]
    space = build_space(scene, options, models, names)
    table = domain.table_rect(scene, options.table)
    circular = space.scale == 0.0

    plans = []
    for seed in range(settings["starts"]):
        rng = stream(seed, "planning")
        s0 = random_arrangements(space, rng, 1, clearance=options.start_clearance)[0]
        found = grow(space, s0, rng, options, Termination(max_iterations=ITERATIONS))
        _, from_plan = optimise(space, stream(seed, "task", "reference"), rounds=settings["rounds"],
                                starts=found.states[-1][None])
        _, from_random = optimise(space, stream(seed, "task", "reference"), rounds=settings["rounds"])
        plan = PushPlan(names, s0, found.actions, found.states, found.cost, asdict(options), models)
        record = {"seed": seed, "start_cost": float(space.cost.cost(s0[None])[0]), "cost": found.cost,
                  "reference": min(from_plan, from_random), "pushes": len(found.actions),
                  "collision": bool(space.checker.in_collision(found.states).any()),
                  "redundant": int(redundant_actions(space, s0, found.actions)),
                  "axis_deviation_deg": float(np.degrees(axis_deviation(found.states[-1], circular))),
                  "start_axis_deviation_deg": float(np.degrees(axis_deviation(s0, circular))),
                  "centre_offset": centre_offset(found.states[-1], space.fp, table),
                  "start_centre_offset": centre_offset(s0, space.fp, table), "executions": []}
        for e in range(settings["executions"]):
            _, noisy = world()
            done = execute_plan(plan, noisy, scene, stream(seed, "execution", e),
                                action_limit=ACTION_LIMIT)
            pushes = done.details                      # PushPlanDetails
            record["executions"].append({"final_cost": pushes.final_cost, "collided": bool(pushes.collided),
                                         "replans": sum(not a.get("repair") for a in pushes.adaptations),
                                         "repairs": sum(bool(a.get("repair")) for a in pushes.adaptations),
                                         "pushes": len(pushes.actions),
                                         "outcome": done.outcome.value})
        plans.append(record)
        run.echo(f"start {seed}: cost {record['start_cost']:.3f} -> {found.cost:.3f} in {len(found.actions)} pushes; "
                 f"{len(record['executions'])} executions")
        if seed == 0:
            figure_plan = draw_plan(run.output / "plan-seed0.png", scene, plan,
                                    start_cost=record["start_cost"])

    best = min(p["reference"] for p in plans)          # same objects, same cost: the cheapest over every start
    for p in plans:
        p["ratio"] = p["cost"] / best
        for x in p["executions"]:
            x["ratio_plan"] = x["final_cost"] / p["cost"]
    records = run.output / "plans.jsonl"
    records.write_text("".join(json.dumps(p) + "\n" for p in plans))
    (run.output / "models.json").write_text(json.dumps({"models": models.to_dict(), "report": report}))
    figure_models = draw_models(run.output / "models.png", models)

    rows = []
    for cls, per in models.models.items():
        for p, d in zip(PRIMITIVES, per):
            held = report["holdout"][cls][p]
            rows.append(Row(f"{cls} / {p}: pushes to sigma_ref", None, int(d.n)))
            rows.append(Row(f"{cls} / {p}: held-out translation error", None, 1000 * held["translation_error"],
                            unit="mm"))
    most = options.learning.max_pushes
    capped = sum(d.n >= most for per in models.models.values() for d in per)
    rows.append(Row(f"models stopped at max_pushes ({most}) before reaching sigma_ref", None, capped))
    ratios = np.array([p["ratio"] for p in plans])
    executions = [x for p in plans for x in p["executions"]]
    within = [x["ratio_plan"] <= 1 + EXECUTION_TOLERANCE and not x["collided"] for x in executions]
    for p in plans:
        rows.append(Row(f"start {p['seed']}: final cost / cheapest free placement", None, p["ratio"]))
        rows.append(Row(f"start {p['seed']}: largest angle off the table axes, deg (start "
                        f"{p['start_axis_deviation_deg']:.0f})", "orthonormal", p["axis_deviation_deg"]))
        rows.append(Row(f"start {p['seed']}: arrangement centre from the table centre, cm (start "
                        f"{100 * p['start_centre_offset']:.0f})", "in the center", 100 * p["centre_offset"]))
    rows += [Row("plans with a collision", "none", sum(p["collision"] for p in plans)),
             Row("redundant actions", "none", sum(p["redundant"] for p in plans)),
             Row(f"executions (noise, monitoring, replanning): final cost within {EXECUTION_TOLERANCE:.0%} of the "
                 "plan's",
                 "replanned as necessary", float(np.mean(within)) if within else None),
             Row("executions: replans per execution (mean)", None,
                 float(np.mean([x["replans"] for x in executions])) if executions else None),
             Row("executions: repairs per execution (mean)", None,
                 float(np.mean([x["repairs"] for x in executions])) if executions else None),
             Row("LEARN_MODEL wall time (not checked)", None, learn_seconds, unit="s")]
    worst_axes = max(p["axis_deviation_deg"] for p in plans)
    headlines = [
        Headline("plans with a collision", float(sum(p["collision"] for p in plans)), 0.0, 0.0, None,
                 "the poster: all paths free of collisions"),
        Headline("redundant actions over all plans", float(sum(p["redundant"] for p in plans)), 0.0, 0.0, None,
                 "the poster: all paths free of redundant actions (no single push can be dropped without raising "
                 "the final cost)"),
        Headline("median final cost / cheapest free placement", float(np.median(ratios)), 0.95, 1.10, None,
                 "issue 18's figure: within 10 % (ci mode measured 1.04 on 2026-11-26)"),
        Headline("largest angle of a box off the table axes in a final arrangement (deg)", worst_axes, 0.0, 10.0,
                 None, "the poster: all objects pushed to orthonormal orientations"),
    ]
    return Outcome(rows, headlines, settings, records=[records, run.output / "models.json"],
                   figures=[figure_models, figure_plan],
                   notes="The poster reports no numbers: its column holds its claims. Costs are the task cost of "
                         "docs/plugins/tsrrt.md (orthogonality, circumscribed area, distance from the edge). "
                         "Executions replan under a time budget, so their rows depend on the machine.")
