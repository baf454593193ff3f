"""RRT* on cube-wall against OMPL's RRT* (the PyPI ``ompl`` package) and pliant's T-RRT at equal time budgets.

Issue 6, part 6: the same scene (``cube-wall``), space (SE(3), the scene's bounds), cost (pliant's voxel
deformation cost, thesis eq. 3.1) and objective for all three planners — the path integral of the state
cost discretised at the scene resolution (``PlanningProblem.path_cost``, thesis Table 3.1; no length
term) — and the best cost each has reached after each time budget, over a few seeds.

OMPL is set up as close to pliant as its API allows (see docs/plugins/rrtstar.md, "The OMPL peer"):

* space: ``SE3StateSpace`` with the scene's position bounds; the SO(3) subspace weight is 2 because
  OMPL's SO(3) distance is ``acos |<q1, q2>|`` (half the rotation angle) while pliant's is the angle.
  OMPL's compound distance is the weighted *sum* ``|dp| + angle`` where pliant's is
  ``sqrt(|dp|^2 + angle^2)``: the same for pure translations and pure rotations, up to sqrt(2) larger
  for mixed motions (so OMPL's steps of ``range`` are shorter there);
* validity: the state's voxel cost is finite, checked along motions every ``check_step`` (OMPL's
  resolution is a fraction of the space's extent: ``check_step / getMaximumExtent()``);
* objective: a Python ``OptimizationObjective`` whose ``motionCost(s1, s2)`` is pliant's
  ``problem.path_cost([q1, q2], check_step)`` (the very same integral) and ``stateCost`` the voxel cost;
* planner: ``og.RRTstar`` with ``range = max_step``, goal bias 0.05, the radius (not k-nearest) variant
  and rewire factor 1.1, as pliant's RRT*; goal: the scene's goal state with its tolerance.

OMPL calls the cost and the validity test once per state or motion through Python (it cannot batch),
pliant's planners once per iteration on a batch: that is part of what is measured.  Every reported cost
is recomputed with ``PlanningProblem.path_cost`` on the returned path.  Anytime runs: each planner runs
once to the largest budget per seed; the best cost at a smaller budget is read from its cost history
(pliant) or by continuing ``solve()`` budget by budget (OMPL keeps its tree between calls).

pliant's RRT* runs twice: as the textbook algorithm (uniform samples, as OMPL's) and with its
``path_bias`` option (after the first solution, 30% of the samples near the best path); its puncture
check is off (OMPL has none; cube-wall's wall is rigid, so nothing is watched there anyway).

``--scene triple-wall --length-weight 20`` compares on the R^3 puck through three soft walls, where both
solve: the objective is the cost integral plus 20 per metre of path (the straight line costs 9.6 + 9.1,
detours through the openings trade cost for length); T-RRT is left out there (its cost history has no
length term).

    pliant bench rrtstar [-- --budgets 10,30,60 --seeds 3]     (or: python benchmarks/bench_rrtstar.py)
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402
import pliant  # noqa: E402
from pliant.interfaces import Context, PlanningProblem  # noqa: E402
from pliant.termination import Termination  # noqa: E402

SCENE = "cube-wall"
GOAL_BIAS = 0.05
#: per scene: the extension length (space metric units); cube-wall is SE(3), triple-wall R^3
SCENES = {"cube-wall": 0.1, "triple-wall": 0.03}


def make_problem() -> PlanningProblem:
    ctx = Context(scene=pliant.load_scene(SCENE))
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    ctx.cost = pliant.registry.create("cost", "voxel", ctx)
    return PlanningProblem.from_context(ctx)


def goal_tolerance(problem: PlanningProblem) -> float:
    """The scene's goal tolerance, else one voxel (what pliant's planners use then)."""
    return float(problem.goal_tolerance) if problem.goal_tolerance else float(problem.scene.resolution)


#: cost per metre of path length added to the objective (``--length-weight``)
LENGTH_WEIGHT = 0.0


def check_path(problem: PlanningProblem, path: np.ndarray, step: float) -> tuple[float, bool]:
    """The path's objective recomputed by pliant, and whether every state along it (at ``step``) is valid."""
    dense = np.vstack([problem.space.discretize(a, b, step) for a, b in itertools.pairwise(path)])
    objective = problem.path_cost(path, step) + LENGTH_WEIGHT * problem.space.path_length(path)
    return objective, bool(problem.is_valid(dense).all())


def best_at(history: list, budgets: list[float]) -> list[float]:
    """Best cost reached by each budget from a ``[[t, cost], ...]`` history (inf before the first solution)."""
    return [min([c for t, c in history if t <= b], default=math.inf) for b in budgets]


def parse_planner(spec: str) -> tuple[str, dict]:
    """``name`` or ``name:option=value;option=value`` (values as Python literals) -> (name, options)."""
    import ast

    name, _, rest = spec.partition(":")
    options = {}
    for item in filter(None, rest.split(";")):
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--planners: expected option=value in {spec!r}, got {item!r}")
        options[key.strip()] = ast.literal_eval(value.strip())
    return name, options


def run_pliant(problem: PlanningProblem, spec: str, seed: int, budgets: list[float], step: float) -> dict:
    planner_name, extra = parse_planner(spec)
    options = {"max_step": SCENES[SCENE], "goal_bias": GOAL_BIAS, "stop_on_first": False, "progress": False,
               **extra}
    if planner_name == "rrtstar":
        options.setdefault("puncture_check", False)      # OMPL cannot check punctures: the same problem for both
        if LENGTH_WEIGHT:
            options["length_weight"] = LENGTH_WEIGHT
    if planner_name == "trrt":
        options["check_step"] = step
    planner = pliant.registry.create("planner", planner_name, **options)
    result = planner.plan(problem, np.random.default_rng(seed), Termination(max_time=max(budgets)))
    stats = result.statistics
    out = {"best": best_at(stats["cost_history"], budgets), "iterations": stats["iterations"],
           "nodes": stats["nodes"], "time_to_first": stats["time_to_first"]}
    if result.path is not None:
        out["recomputed"], out["valid"] = check_path(problem, result.path.configurations, step)
    return out


def run_ompl(problem: PlanningProblem, seed: int, budgets: list[float], step: float) -> dict:
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_WARN)
    ou.RNG.setSeed(seed + 1)                      # OMPL's seed must be positive
    se3 = problem.space.kind == "se3"
    space = ob.SE3StateSpace() if se3 else ob.RealVectorStateSpace(3)
    bounds = ob.RealVectorBounds(3)
    for i in range(3):
        bounds.setLow(i, float(problem.space.lower[i]))
        bounds.setHigh(i, float(problem.space.upper[i]))
    space.setBounds(bounds)
    if se3:
        space.setSubspaceWeight(0, problem.space.translation_weight)
        space.setSubspaceWeight(1, 2.0 * problem.space.rotation_weight)   # acos|<q1,q2>| is half the angle
    si = ob.SpaceInformation(space)
    cost = problem.cost.cost

    def q_of(s) -> np.ndarray:
        if not se3:
            return np.array([s[0], s[1], s[2]])
        r = s.rotation()
        return np.array([s.getX(), s.getY(), s.getZ(), r.x, r.y, r.z, r.w])

    si.setStateValidityChecker(lambda s: bool(np.isfinite(cost(q_of(s)[None])[0])))
    si.setStateValidityCheckingResolution(step / space.getMaximumExtent())
    si.setup()

    class VoxelCostIntegral(ob.OptimizationObjective):
        """pliant's path objective: sum_j c(q_j) d(q_{j-1}, q_j) over the motion discretised at ``step``."""

        def stateCost(self, s):
            c = float(cost(q_of(s)[None])[0])
            return ob.Cost(c if math.isfinite(c) else math.inf)

        def motionCost(self, s1, s2):
            a, b = q_of(s1), q_of(s2)
            c = problem.path_cost(np.stack([a, b]), step) + LENGTH_WEIGHT * float(problem.space.distance(a, b))
            return ob.Cost(c if math.isfinite(c) else math.inf)

    def state(q):
        s = space.allocState()
        if not se3:
            for i in range(3):
                s[i] = float(q[i])
            return s
        s.setXYZ(*map(float, q[:3]))
        r = s.rotation()
        r.x, r.y, r.z, r.w = map(float, q[3:])
        return s

    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(state(problem.start), state(problem.goal), goal_tolerance(problem))
    objective = VoxelCostIntegral(si)
    pdef.setOptimizationObjective(objective)
    planner = og.RRTstar(si)
    planner.setProblemDefinition(pdef)
    planner.setRange(SCENES[SCENE])
    planner.setGoalBias(GOAL_BIAS)
    planner.setKNearest(False)
    planner.setRewireFactor(1.1)
    planner.setup()
    best, first, elapsed, path = [], None, 0.0, None
    for budget in budgets:
        t = time.perf_counter()
        planner.solve(budget - elapsed)
        elapsed += time.perf_counter() - t
        exact = pdef.hasExactSolution()
        if exact:
            solution = pdef.getSolutionPath()
            path = np.array([q_of(solution.getState(i)) for i in range(solution.getStateCount())])
            c = planner.bestCost().value()
            best.append(float(c))
            first = first if first is not None else budget
        else:
            best.append(math.inf)
    out = {"best": best, "iterations": int(planner.numIterations()), "first_within": first}
    if path is not None:
        out["recomputed"], out["valid"] = check_path(problem, path, step)
    return out


def run_ompl_isolated(seed: int, budgets: list[float]) -> dict:
    """:func:`run_ompl` in a fresh process: OMPL's random seed can only be set before its first sample."""
    command = [sys.executable, __file__, "--ompl-worker", str(seed), "--budgets", ",".join(map(str, budgets)),
               "--scene", SCENE, "--length-weight", str(LENGTH_WEIGHT), "--planners", "ompl-rrtstar"]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"the OMPL run failed: {done.stderr[-2000:]}")
    return json.loads(lines[-1])


def summary(values: list[float]) -> str:
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return f"none (0/{len(values)})"
    text = f"{np.mean(finite):.1f} ({np.std(finite):.1f})"
    return text if len(finite) == len(values) else f"{text} [{len(finite)}/{len(values)} solved]"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budgets", default="10,30,60", help="time budgets in seconds, comma-separated")
    parser.add_argument("--seeds", type=int, default=3, help="runs per planner")
    parser.add_argument("--planners", default="ompl-rrtstar,rrtstar,rrtstar:path_bias=0.3,trrt",
                        help="comma-separated; pliant planners take options as name:option=value;option=value")
    parser.add_argument("--scene", default="cube-wall", choices=sorted(SCENES),
                        help="cube-wall (SE(3), max_step 0.1) or triple-wall (R^3, max_step 0.03)")
    parser.add_argument("--ompl-worker", type=int, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--length-weight", type=float, default=0.0,
                        help="cost per metre of path length added to the objective of RRT* and OMPL's RRT* "
                             "(T-RRT's history has no length term: leave it out of such runs)")
    args = parser.parse_args()
    if args.length_weight and "trrt" in args.planners.split(","):
        parser.error("--length-weight: T-RRT's cost history has no length term; drop trrt from --planners")
    global SCENE, LENGTH_WEIGHT
    SCENE, LENGTH_WEIGHT = args.scene, args.length_weight
    budgets = sorted(float(b) for b in args.budgets.split(","))
    problem = make_problem()
    step = problem.scene.resolution
    problem.cost.cost(problem.start[None])                     # compile the cost kernel before timing
    if args.ompl_worker is not None:
        print(json.dumps(run_ompl(problem, args.ompl_worker, budgets, step)), flush=True)
        return
    runs: dict[str, list[dict]] = {}
    for name in args.planners.split(","):
        for seed in range(args.seeds):
            r = run_ompl_isolated(seed, budgets) if name == "ompl-rrtstar" else \
                run_pliant(problem, name, seed, budgets, step)
            runs.setdefault(name, []).append(r)
            print(f"{name} seed {seed}: best {[f'{b:.1f}' for b in r['best']]}, iterations {r['iterations']}, "
                  f"recomputed {r.get('recomputed', float('nan')):.1f}, valid {r.get('valid')}", flush=True)
    rows = []
    for name, rs in runs.items():
        rows.append((name, *(summary([r["best"][k] for r in rs]) for k in range(len(budgets))),
                     f"{np.mean([r['iterations'] for r in rs]):.0f}"))
    print_table(f"{SCENE}: best path cost, mean (std) over {args.seeds} seeds, single core",
                ("planner", *(f"{b:g} s" for b in budgets), "iterations"), rows)
    name = "rrtstar" if SCENE == "cube-wall" else f"rrtstar-{SCENE}"
    path = write_json(name, {"scene": SCENE, "budgets": budgets, "seeds": args.seeds, "max_step": SCENES[SCENE],
                             "length_weight": LENGTH_WEIGHT,
                             "goal_bias": GOAL_BIAS, "check_step": step, "runs": runs})
    write_ompl(path.with_suffix(".log"), runs, budgets)


def write_ompl(log: Path, runs: dict[str, list[dict]], budgets: list[float]) -> None:
    """The runs in OMPL's benchmark log and database (``.log``, ``.db`` beside the JSON): one planner
    configuration per planner spec, one run per seed, the best cost at each budget as the run's progress, so
    Planner Arena plots pliant's planners and OMPL's RRT* side by side."""
    from pliant.experiments.ompl import PlannerRuns, ompl_database, write_ompl_log

    planners = []
    for name, rs in runs.items():
        rows, progress = [], []
        for seed, r in enumerate(rs):
            best = r["best"][-1]
            rows.append({"time REAL": max(budgets), "solved BOOLEAN": int(math.isfinite(best)),
                         "status ENUM": 6 if math.isfinite(best) else 4,
                         "best cost REAL": best if math.isfinite(best) else None,
                         "iterations INTEGER": r["iterations"], "graph states INTEGER": r.get("nodes"),
                         "seed INTEGER": seed})
            progress.append([{"time REAL": b, "best cost REAL": c if math.isfinite(c) else None}
                             for b, c in zip(budgets, r["best"])])
        planners.append(PlannerRuns(name, {"scene": SCENE, "length_weight": LENGTH_WEIGHT}, rows, progress))
    write_ompl_log(log, f"{SCENE} rrtstar", planners, time_limit=max(budgets),
                   total_time=max(budgets) * sum(len(rs) for rs in runs.values()),
                   setup=f"pliant benchmarks/bench_rrtstar.py, scene {SCENE}")
    print(f"wrote {log} and {ompl_database(log.with_suffix('.db'), [log])} (OMPL's benchmark formats)")


if __name__ == "__main__":
    main()
