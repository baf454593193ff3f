"""The experiments of thesis 5.4 as commands: plan many policies, execute each many times, tabulate.

``pliant belief-experiment NAME`` runs one experiment.  A *task* plans one policy (a pipeline file, a
variant's overrides, a seed) and executes it ``--executions`` times in each execution world of the
experiment (e.g. the maze with and without the block added during execution, thesis 5.4.3).  Tasks run
in parallel over ``--jobs`` processes (one core each), every finished task is appended to
``out/experiments/NAME/runs.jsonl`` at once (each planned policy to ``policies/``, to replay it), and a
second invocation resumes: tasks already on file are skipped (``--fresh`` forgets those of the variants
being run; ``--replay`` plans nothing and executes the saved policies again, replacing their executions).
The table (P_plan, P_exec as mean [std] over plans, actions, planning statistics) is printed
and written with the runs to ``summary.json``.

Experiments (pipelines in ``scenes/pipelines``):

- ``maze``: se2-maze (``maze-policy``), executions unblocked and blocked (thesis: 97% / 73%), in pymunk
  with the pipeline's friction (0.1); the pipeline's planner (solutions retire the root's subtree they
  start with, ``planner.retire = "root"``: more diverse routes) and the thesis's (back to the nearest split).
- ``maze-frictionless``: the same policies' executions in a frictionless pymunk, as the planner's
  kinematic model (app. B) is.
- ``table-5.1``: se3-peg-in-hole (``peg-policy``), gamma = 1/8, clustering PC, AC and WCR at
  D_WCR in {0.125, 0.25, 0.5, 0.75, 0.99} (the pipeline samples target orientations within 0.5 rad of
  upright, ``planner.rotation_spread``), and WCR 0.75 with the thesis's uniform rotations.
- ``table-5.2``: se3-peg-in-hole, Simple RRT, Contact RRT, 24 and 48 particles, gamma in
  {0, 1/16, 1/8, 1/4}.
- ``table-5.1-tight``, ``table-5.2-tight``: the same rows on se3-peg-tight (``peg-tight-policy``: a hole 8% wider
  than the peg instead of 30%, the scene at one tenth of the size, so the linear noise is ``gamma / 10`` m/s), where
  on se3-peg-in-hole every row planned and executed every time.
- ``baxter-reach``: thesis 5.4.2, Baxter's right arm reaching into a hole (``baxter-policy``, noise
  proportional to joint velocity, gamma = 0.1, executed in pybullet): the belief planner (24 particles)
  against Contact RRT (one particle, planning without noise, executed with the same noise); thesis: P_exec
  0.79 against 0.70, first solution after 65 s against 8.4 s.
"""

from __future__ import annotations

import itertools
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pliant.api import ConfigError, LocalExecutor, check_settings, current_executor, open_log, rewrite_jsonl, run_tasks


@dataclass(frozen=True)
class Variant:
    """One row of an experiment: a label, the pipeline and its overrides for planning, the execution worlds
    (label -> overrides of the ``[execution]`` table, e.g. ``execution.variant=blocked``)."""

    label: str
    pipeline: str
    overrides: tuple[str, ...] = ()
    worlds: dict[str, tuple[str, ...]] = field(default_factory=lambda: {"": ()})


#: an execution world whose overrides are computed per planned policy: the maze blocked in the passage the
#: policy's first route takes (thesis 5.4.3)
FIRST_ROUTE = "@block-first-route"


def first_route_passage(policy, scene) -> str | None:
    """Which of the scene's vertical passages (regions named ``passage-<name>``) the policy's first route -- the
    one it follows if every action succeeds -- goes through between the corridors: the passage holding most of the
    route's expected configurations outside the corridors (``corridor-*`` regions); None if it uses none."""
    route = np.array([policy.nodes[i].expected for i in policy.route(policy.start_node)])
    if len(route) < 2:
        return None
    t = np.linspace(0.0, 1.0, 20)[:, None]
    points = np.concatenate([a + t * (b - a) for a, b in itertools.pairwise(route)])
    xy = points[:, :2]
    regions = {r.name: r for r in scene.regions}

    def inside(region):
        return np.all((xy >= region.lower[:2]) & (xy <= region.upper[:2]), axis=1)

    in_corridor = np.zeros(len(xy), dtype=bool)
    for name, region in regions.items():
        if name.startswith("corridor"):
            in_corridor |= inside(region)
    counts = {name.removeprefix("passage-"): int(np.sum(inside(region) & ~in_corridor))
              for name, region in regions.items() if name.startswith("passage-")}
    best = max(counts, key=counts.get, default=None)
    return best if best is not None and counts[best] > 0 else None


def _gamma(g: float, scale: float = 1.0) -> tuple[str, ...]:
    """Planning and execution noise ``gamma`` (linear, m/s, times ``scale`` for a scene scaled by it) and
    ``gamma / 4`` (angular, rad/s), thesis 5.4.1."""
    noise = "none" if g == 0 else "bounded"
    return (f'simulator.noise="{noise}"', f"simulator.noise_linear={g * scale}", f"simulator.noise_angular={g / 4}",
            f'execution.world.noise="{noise}"', f"execution.world.noise_linear={g * scale}",
            f"execution.world.noise_angular={g / 4}")


def _tables_5(pipeline: str, scale: float = 1.0, worlds_for=None) -> tuple[list[Variant], list[Variant]]:
    """Tables 5.1 (clustering) and 5.2 (planner modes, particles, noise) on a peg-in-hole ``pipeline`` whose
    lengths are ``scale`` times the thesis's; ``worlds_for(gamma)``: the execution worlds for noise ``gamma``
    (default the pipeline's world only)."""
    worlds_for = worlds_for or (lambda g: {"": ()})
    worlds = worlds_for(1 / 8)
    table_51 = [Variant("PC", pipeline, ('planner.clustering="pc"',), worlds),
                Variant("AC", pipeline, ('planner.clustering="ac"',), worlds)]
    table_51 += [Variant(f"WCR {t}", pipeline, ('planner.clustering="wcr"', f"planner.wcr_threshold={t}"), worlds)
                 for t in (0.125, 0.25, 0.5, 0.75, 0.99)]
    table_51 += [Variant("WCR 0.75, uniform rotations", pipeline,
                         ('planner.clustering="wcr"', "planner.wcr_threshold=0.75", "planner.rotation_spread=null"),
                         worlds)]
    table_52 = []
    for g in (0.0, 1 / 16, 1 / 8, 1 / 4):
        w = worlds_for(g)
        table_52 += [Variant(f"simple, gamma {g:g}", pipeline, ('planner.mode="simple"', *_gamma(g, scale)), w),
                     Variant(f"contact, gamma {g:g}", pipeline,
                             ('planner.mode="contact"', 'simulator.noise="none"', *_gamma(g, scale)[3:]), w),
                     Variant(f"24 particles, gamma {g:g}", pipeline, ("planner.particles=24", *_gamma(g, scale)),
                             w),
                     Variant(f"48 particles, gamma {g:g}", pipeline, ("planner.particles=48", *_gamma(g, scale)),
                             w)]
    return table_51, table_52


def experiments() -> dict[str, list[Variant]]:
    """The experiments by name (see the module docstring)."""
    # thesis 5.4.3 blocks the passage each policy's first route takes; the fixed block (the right passage) is kept
    # beside it for comparison with earlier runs
    maze_worlds = {"unblocked": (), "blocked (first route)": (FIRST_ROUTE,),
                   "blocked (right)": ('execution.variant="blocked"',)}
    frictionless = {"unblocked, friction 0": ("execution.world.friction=0.0",),
                    "blocked, friction 0": ('execution.variant="blocked"', "execution.world.friction=0.0")}
    table_51, table_52 = _tables_5("peg-policy")
    # the tight hole of thesis 6.5.1 (8% clearance; the scene at 1/10 scale), where the rows can differ
    # pybullet's contact at 2 mm clearance is not the planner's model: executions there are also run in the kinematic
    # simulator (with the planning noise), which separates planning from execution fidelity
    def tight_worlds(g: float) -> dict[str, tuple[str, ...]]:
        kinematic = ("execution.world=kinematic", "execution.world.kp=1.0", "execution.world.frequency=10.0",
                     "execution.world.velocity_limit=0.1", "execution.world.angular_velocity_limit=0.25",
                     *_gamma(g, 0.1)[3:])
        return {"pybullet": (), "kinematic": kinematic}

    tight_51, tight_52 = _tables_5("peg-tight-policy", scale=0.1, worlds_for=tight_worlds)
    baxter = [Variant("belief", "baxter-policy"),
              Variant("contact RRT", "baxter-policy", ('planner.mode="contact"', 'simulator.noise="none"'))]
    return {"maze": [Variant("belief, WCR 0.75", "maze-policy", (), maze_worlds),
                     Variant("belief, WCR 0.75, thesis retire", "maze-policy", ('planner.retire="split"',),
                             maze_worlds)],
            "maze-frictionless": [Variant("belief, WCR 0.75", "maze-policy", (), frictionless)],
            "table-5.1": table_51, "table-5.2": table_52, "table-5.1-tight": tight_51, "table-5.2-tight": tight_52,
            "baxter-reach": baxter}


def run_task(variant: Variant, seed: int, plan_time: float, executions: int, exec_time: float,
             policy_file: Path | None = None, plan_iterations: int | None = None) -> dict:
    """Plan one policy and execute it ``executions`` times in every world; a JSON-ready record.

    ``policy_file``: where to save the planned policy (JSON, :meth:`PartialPolicy.to_dict`), to replay it.
    ``plan_iterations``: an iteration budget for the planner; ``plan_time`` is then only a safety cap.  With it the
    record depends on the seed alone, not on the machine's speed or load (nor on the first call's JIT compilation,
    which a time budget pays for).
    """
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    from pliant import api
    from pliant.api import PlanningProblem

    # the request's budget ([planning]): a work budget when plan_iterations is given, plan_time then only a cap
    base = [*variant.overrides, f"planning.max_time={plan_time}", "planner.progress=false", f"seed={seed}"]
    if plan_iterations is not None:
        base.append(f"planning.max_iterations={plan_iterations}")
    pipeline = api.Pipeline.from_file(variant.pipeline, overrides=base)
    context = pipeline.build()
    problem = PlanningProblem.from_context(context, budget=pipeline.budget)
    t0 = time.perf_counter()
    # task (variant, seed) is the run of that seed: its planning stream (pliant.seeds), as `pliant run` draws it
    result = context.extras["planner"].plan(problem, api.stream(seed, "planning"))
    stats = {k: v for k, v in result.statistics.items() if isinstance(v, (int, float, str, bool)) or v is None}
    # what stopped the planner: "iterations" (a work budget: the same on any machine) or "time" (the wall clock)
    stats["budget_binding"] = result.statistics.get("budget", {}).get("binding")
    record = {"variant": variant.label, "seed": seed, "planned": result.status.value == "solved",
              "plan_seconds": time.perf_counter() - t0, "statistics": stats, "executions": {}}
    if result.policy is None:
        return record
    if policy_file is not None:
        result.policy.save(policy_file)
        record["policy_file"] = str(policy_file)
    record["executions"] = _execute(variant, seed, base, context, result.policy, executions, exec_time)
    return record


def _execute(variant: Variant, seed: int, base: list[str], context, planned, executions: int,
             exec_time: float) -> dict:
    """Execute the policy ``planned`` ``executions`` times in every world of ``variant`` (execution ``k`` draws from
    the run's execution stream ``k``: ``pliant.seeds.stream(seed, "execution", k)``); the runs by world."""
    from pliant import api

    from pliant_belief.execute import follow_policy
    from pliant_belief.policy import PartialPolicy

    saved = planned.to_dict()
    out = {}
    for world, world_overrides in variant.worlds.items():
        runs = []
        if FIRST_ROUTE in world_overrides:
            passage = first_route_passage(planned, context.scene)
            if passage is None:                   # no passage on the route: nothing to block, nothing measured
                out[world or "default"] = []
                continue
            world_overrides = tuple(o for o in world_overrides if o != FIRST_ROUTE) + (
                f'execution.variant="blocked-{passage}"',)
        world_pipeline = api.Pipeline.from_file(variant.pipeline, overrides=[*base, *world_overrides])
        simulator = world_pipeline.execution_world(context)
        for k in range(executions):
            policy = PartialPolicy.from_dict(saved)      # every execution starts from the planned policy
            policy.matcher = planned.matcher
            strategy = follow_policy(policy, context, {"action_limit": world_pipeline.execution["action_limit"]})
            execution = api.follow(simulator, context.controller, strategy,
                                   api.stream(seed, "execution", k), time_limit=exec_time)
            runs.append({"outcome": execution.outcome.value, "actions": len(execution.details.actions),
                         "seconds": float(execution.times[-1])})
        out[world or "default"] = runs
    return out


def replay_task(variant: Variant, record: dict, executions: int, exec_time: float) -> dict:
    """Execute the saved policy of a planned task again (no planning): ``record`` with new executions.

    The policy matches observations with the thresholds saved with it, else the pipeline planner's (files
    written before the thresholds were saved), so a replay after a change to the controller or the execution
    simulator measures the same policies again.
    """
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    from pliant import api

    from pliant_belief.policy import PartialPolicy

    seed = int(record["seed"])
    base = [*variant.overrides, "planner.progress=false", f"seed={seed}"]
    context = api.Pipeline.from_file(variant.pipeline, overrides=base).build()
    policy = PartialPolicy.load(Path(record["policy_file"]))
    o = context.extras["planner"].options
    if not policy.match_thresholds and o.mode != "simple":
        policy.use_clustering(context, wcr_threshold=o.wcr_threshold, distance_threshold=o.distance_threshold)
    else:
        policy.use_clustering(context)
    return {**record, "executions": _execute(variant, seed, base, context, policy, executions, exec_time),
            "replayed": True}


def summarise(records: list[dict], variants: list[Variant]) -> list[dict]:
    """Per variant and world: P_plan, P_exec mean [std] over planned policies, actions per success."""
    rows = []
    for v in variants:
        mine = [r for r in records if r["variant"] == v.label]
        planned = [r for r in mine if r["planned"]]
        for world in v.worlds:
            key = world or "default"
            rates = [np.mean([e["outcome"] == "success" for e in r["executions"].get(key, [])])
                     for r in planned if r["executions"].get(key)]
            actions = [e["actions"] for r in planned for e in r["executions"].get(key, []) if e["outcome"] == "success"]
            firsts = [r["statistics"].get("time_to_first") for r in planned if r["statistics"].get("time_to_first")]
            rows.append({"variant": v.label, "world": key, "plans": len(mine),
                         "p_plan": len(planned) / len(mine) if mine else float("nan"),
                         "p_exec": float(np.mean(rates)) if rates else float("nan"),
                         "p_exec_std": float(np.std(rates)) if rates else float("nan"),
                         "p_plan_ci95": wilson(len(planned), len(mine)),
                         "p_exec_ci95": bootstrap_mean(rates),
                         "actions": float(np.mean(actions)) if actions else float("nan"),
                         "actions_std": float(np.std(actions)) if actions else float("nan"),
                         "time_to_first": float(np.mean(firsts)) if firsts else float("nan"),
                         "particles_simulated": float(np.mean([r["statistics"].get("particles_simulated", 0)
                                                               for r in planned])) if planned else float("nan"),
                         "particles_stored": float(np.mean([r["statistics"].get("particles_stored", 0)
                                                            for r in planned])) if planned else float("nan"),
                         "solutions": float(np.mean([r["statistics"].get("solutions", 0)
                                                     for r in planned])) if planned else float("nan")})
    return rows


def wilson(successes: int, trials: int, z: float = 1.959964) -> list[float]:
    """The 95% Wilson score interval of a proportion (``[nan, nan]`` without trials)."""
    if trials == 0:
        return [float("nan"), float("nan")]
    p = successes / trials
    centre = (p + z * z / (2 * trials)) / (1 + z * z / trials)
    half = z * np.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / (1 + z * z / trials)
    return [float(max(0.0, centre - half)), float(min(1.0, centre + half))]


def bootstrap_mean(values, other=None, resamples: int = 4000, seed: int = 0) -> list[float]:
    """The 95% percentile bootstrap interval of the mean of ``values`` (the plans' success rates: resampling plans,
    the unit the thesis averages over), or of ``mean(values) - mean(other)``; seeded, so the same records give the
    same interval.  ``[nan, nan]`` when empty."""
    values = np.asarray(values, dtype=np.float64)
    if values.size == 0 or (other is not None and len(other) == 0):
        return [float("nan"), float("nan")]
    rng = np.random.default_rng(seed)
    means = values[rng.integers(0, values.size, (resamples, values.size))].mean(axis=1)
    if other is not None:
        other = np.asarray(other, dtype=np.float64)
        means = means - other[rng.integers(0, other.size, (resamples, other.size))].mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return [float(low), float(high)]


def _slug(label: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in label.lower()).strip("-")


#: settings that give a record its meaning: a resume with other values would mix incomparable tasks
RESUME_SETTINGS = ("plan_time", "plan_iterations", "executions", "exec_time")


def run_experiment(name: str, *, plans: int, executions: int, plan_time: float, exec_time: float, jobs: int,
                   fresh: bool, output: Path, only: list[str] | None = None, echo=print,
                   replay: bool = False, plan_iterations: int | None = None) -> list[dict]:
    """Run (or resume) experiment ``name``; returns the summary rows.

    Every finished task is appended to ``runs.jsonl`` at once (fsynced).  Ctrl-C cancels the queued tasks, ends
    the workers within seconds, writes the summary of the finished tasks and raises :class:`KeyboardInterrupt`;
    workers also end when this process is killed.  A torn last line (a crash while writing it) is dropped on
    resume; a resume whose planning time, executions or execution time differ from the run's ``settings.json`` is
    refused.  ``replay``: plan nothing; execute the saved policies of the selected variants' planned tasks on file
    again (``executions`` times per world) and replace their executions, rewriting the file after each task.
    ``plan_iterations``: plan each policy to this iteration budget (``plan_time`` is then a safety cap only), so
    that the records depend on the seeds alone -- what a check of the results on another machine needs.
    """
    table = experiments()
    if name not in table:
        raise ConfigError(f"unknown experiment (experiments: {', '.join(table)})", field="NAME", value=name)
    # fields named as the command line spells them (``pliant experiment ... --plans``)
    for key, value in (("--plans", plans), ("--executions", executions), ("--jobs", jobs)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ConfigError("must be a positive integer", field=key, value=value)
    for key, value in (("--plan-time", plan_time), ("--exec-time", exec_time)):
        if not (isinstance(value, (int, float)) and value > 0):
            raise ConfigError("must be a positive number of seconds", field=key, value=value)
    if plan_iterations is not None and (isinstance(plan_iterations, bool) or not isinstance(plan_iterations, int)
                                        or plan_iterations < 1):
        raise ConfigError("must be a positive integer", field="--plan-iterations", value=plan_iterations)
    if replay and fresh:
        raise ConfigError("replay executes the policies on file; fresh would forget them", field="replay/fresh",
                          value=[replay, fresh])
    if only:
        unknown = sorted(set(only) - {v.label for v in table[name]})
        if unknown:
            raise ConfigError(f"no such variant in {name} (variants: {', '.join(v.label for v in table[name])})",
                              field="--only", value=unknown[0])
    variants = [v for v in table[name] if not only or v.label in only]
    directory = output / name
    log, records = open_log(directory, "--output", echo)
    settings = check_settings(directory, {"experiment": name, "plan_time": plan_time,
                                          "plan_iterations": plan_iterations, "executions": executions,
                                          "exec_time": exec_time, "pliant": _version()}, RESUME_SETTINGS,
                              replace=fresh or replay or not records)
    if fresh:                                    # forget the selected variants' tasks, keep the others'
        selected = {v.label for v in variants}
        records = [r for r in records if r["variant"] not in selected]
        rewrite_jsonl(log, records)
    if replay:
        _replay(records, variants, executions, exec_time, jobs, log, echo)
        return _summary(name, records, variants, settings, directory)
    done = {(r["variant"], r["seed"]) for r in records}
    todo = [(v, s) for v in variants for s in range(plans) if (v.label, s) not in done]
    echo(f"{name}: {len(records)} tasks on file, {len(todo)} to go, {jobs} at a time")

    def describe(record: dict) -> str:
        outcome = {w: f"{sum(e['outcome'] == 'success' for e in runs)}/{len(runs)}"
                   for w, runs in record["executions"].items()}
        return (f"{record['variant']} seed {record['seed']}: {'planned' if record['planned'] else 'no policy'}, "
                f"executions {outcome}")

    tasks = [(v, s, plan_time, executions, exec_time, directory / "policies" / f"{_slug(v.label)}-seed{s}.json",
              plan_iterations) for v, s in todo]
    run_tasks(run_task, tasks, jobs=jobs, log=log, records=records, describe=describe, echo=echo,
              label=lambda task: f"{task[0].label} seed {task[1]}",
              on_interrupt=lambda: _summary(name, records, variants, settings, directory))
    return _summary(name, records, variants, settings, directory)


def _version() -> str:
    from pliant import api
    return api.__version__


def _replay(records: list[dict], variants: list[Variant], executions: int, exec_time: float, jobs: int, log: Path,
            echo) -> None:
    """Re-execute the saved policies of ``records`` (in place), rewriting ``log`` after each task."""

    by_label = {v.label: v for v in variants}
    todo = [k for k, r in enumerate(records) if r["variant"] in by_label and r["planned"] and r.get("policy_file")]
    for k in todo:                               # a relative path written from another working directory
        path = Path(records[k]["policy_file"])
        if not path.is_file() and (log.parent / "policies" / path.name).is_file():
            records[k] = {**records[k], "policy_file": str(log.parent / "policies" / path.name)}
    echo(f"replaying {len(todo)} saved policies, {jobs} at a time")
    own = current_executor() is None
    executor = current_executor() or LocalExecutor(jobs)       # `--executor ray`: on the cluster
    try:
        tasks = [(by_label[records[k]["variant"]], records[k], executions, exec_time) for k in todo]
        for n, result in enumerate(executor.run(replay_task, tasks), start=1):
            k = todo[result.index]
            records[k] = result.record
            rewrite_jsonl(log, records)
            outcome = {w: f"{sum(e['outcome'] == 'success' for e in runs)}/{len(runs)}"
                       for w, runs in records[k]["executions"].items()}
            echo(f"[{n}/{len(todo)}] {records[k]['variant']} seed {records[k]['seed']}: executions {outcome}")
    except KeyboardInterrupt:
        echo("interrupted: the tasks replayed so far are on file")
        raise
    finally:
        if own:
            executor.close()


def _summary(name: str, records: list[dict], variants: list[Variant], settings: dict,
             directory: Path) -> list[dict]:
    """Summarise the records and write ``summary.json`` (atomically, strict JSON) with the run's settings."""
    from pliant.api import write_json

    rows = summarise(records, variants)
    write_json(directory / "summary.json", {"experiment": name, "settings": settings, "tasks": len(records),
                                            "rows": rows})
    return rows
