"""OMPL's planners through pliant's ``ompl`` plugin against the same OMPL planners used directly (issue 35).

The problem: ``triple-wall`` (the R^3 puck through three soft walls), pliant's voxel cost, the objective of
optimising planners the path integral of the cost plus ``--length-weight`` per metre (bench_rrtstar.py's triple-wall
mode), the goal state itself (tolerance 1e-9), the same work budget for both: ``--iterations`` OMPL
termination-condition checks (a counting ``PlannerTerminationCondition``), no time budget.

* **direct**: OMPL as a user would set it up by hand -- ``RealVectorStateSpace(3)``, a state validity checker that asks
  pliant (``PlanningProblem.is_valid``: bounds, collisions, cost feasibility), OMPL's own discrete motion validator at
  ``check_step`` (the scene's resolution, as a fraction of the extent), and a Python objective computing pliant's path
  cost; OMPL's seed ``ompl.util.RNG.setSeed(seed + 1)``.
* **pliant**: ``registry.create("planner", "ompl", algorithm=..., length_weight=...)`` with the same budget; its motion
  validator is pliant's (every state at ``check_step`` and the motion at voxel resolution).

Every path returned by either is judged by pliant (``PlanningProblem.path_verdict``: states and motions) and its cost
recomputed (``path_cost + length_weight * length``).  Reported per planner and side: solved runs, paths pliant's
check accepts, and the mean (std) cost of the solved runs.

    pliant bench ompl [-- --seeds 5 --iterations 200 --algorithms RRTConnect,KPIECE1,RRTstar,InformedRRTstar,BITstar]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402
import pliant  # noqa: E402
from pliant.interfaces import Context, PlanningProblem  # noqa: E402
from pliant.termination import Budget  # noqa: E402


def make_problem(iterations: int) -> PlanningProblem:
    ctx = Context(scene=pliant.load_scene("triple-wall"))
    ctx.robot = pliant.registry.create("robot", "rigid", ctx)
    ctx.cost = pliant.registry.create("cost", "voxel", ctx)
    return PlanningProblem.from_context(ctx, budget=Budget(max_iterations=iterations))


def judge(problem: PlanningProblem, path, step: float, length_weight: float) -> tuple[float, bool]:
    cost = problem.path_cost(path, step) + length_weight * float(problem.space.path_length(path))
    return cost, bool(problem.path_verdict(path).valid)


def run_direct(problem: PlanningProblem, algorithm: str, seed: int, iterations: int, length_weight: float) -> dict:
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    ou.RNG.setSeed(seed + 1)
    step = float(problem.scene.resolution)
    space = ob.RealVectorStateSpace(3)
    bounds = ob.RealVectorBounds(3)
    for i in range(3):
        bounds.setLow(i, float(problem.space.lower[i]))
        bounds.setHigh(i, float(problem.space.upper[i]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)

    def q_of(s) -> np.ndarray:
        return np.array([s[0], s[1], s[2]])

    si.setStateValidityChecker(lambda s: bool(problem.is_valid(q_of(s)[None])[0]))
    si.setStateValidityCheckingResolution(step / space.getMaximumExtent())
    si.setup()

    class Objective(ob.OptimizationObjective):
        def stateCost(self, s):
            return ob.Cost(float(problem.cost.cost(q_of(s)[None])[0]))

        def motionCost(self, s1, s2):
            a, b = q_of(s1), q_of(s2)
            c = problem.path_cost(np.stack([a, b]), step) + length_weight * float(problem.space.distance(a, b))
            return ob.Cost(c if math.isfinite(c) else math.inf)

    def state(q):
        s = space.allocState()
        for i in range(3):
            s[i] = float(q[i])
        return s

    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(state(problem.start), state(problem.goal), 1e-9)
    planner = getattr(og, algorithm)(si)
    objective = Objective(si)
    objective.setCostThreshold(ob.Cost(-math.inf))
    pdef.setOptimizationObjective(objective)
    planner.setProblemDefinition(pdef)
    planner.setup()
    calls = [0]

    def stop() -> bool:
        calls[0] += 1
        return calls[0] > iterations

    t = time.perf_counter()
    planner.solve(ob.PlannerTerminationCondition(stop))
    seconds = time.perf_counter() - t
    out = {"solved": bool(pdef.hasExactSolution()), "time": seconds, "iterations": calls[0]}
    if out["solved"]:
        solution = pdef.getSolutionPath()
        path = np.array([q_of(solution.getState(i)) for i in range(solution.getStateCount())])
        out["cost"], out["valid"] = judge(problem, path, step, length_weight)
    return out


def run_pliant(problem: PlanningProblem, algorithm: str, seed: int, length_weight: float) -> dict:
    planner = pliant.registry.create("planner", "ompl", algorithm=algorithm, length_weight=length_weight,
                                     goal_tolerance=0.0)
    t = time.perf_counter()
    result = planner.plan(problem, np.random.default_rng(seed))
    out = {"solved": result.status is pliant.Status.SOLVED, "time": time.perf_counter() - t,
           "iterations": result.statistics.get("iterations"), "status": result.status.value}
    if result.path is not None and out["solved"]:
        out["cost"], out["valid"] = judge(problem, result.path.configurations, problem.scene.resolution,
                                          length_weight)
    return out


def summary(runs: list[dict]) -> tuple[str, str, str, str]:
    solved = [r for r in runs if r["solved"]]
    costs = [r["cost"] for r in solved]
    cost = f"{np.mean(costs):.2f} ({np.std(costs):.2f})" if costs else "-"
    return (f"{len(solved)}/{len(runs)}", f"{sum(bool(r.get('valid')) for r in solved)}/{len(solved)}", cost,
            f"{np.mean([r['time'] for r in runs]):.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--iterations", type=int, default=200, help="work budget: termination-condition checks")
    parser.add_argument("--length-weight", type=float, default=20.0)
    parser.add_argument("--algorithms", default="RRTConnect,KPIECE1,RRTstar,InformedRRTstar,BITstar")
    args = parser.parse_args()
    problem = make_problem(args.iterations)
    problem.cost.cost(problem.start[None])                    # compile the cost kernel before timing
    runs: dict[str, dict[str, list[dict]]] = {}
    for algorithm in args.algorithms.split(","):
        for seed in range(args.seeds):
            direct = run_direct(problem, algorithm, seed, args.iterations, args.length_weight)
            through = run_pliant(problem, algorithm, seed, args.length_weight)
            runs.setdefault(algorithm, {"direct": [], "pliant": []})
            runs[algorithm]["direct"].append(direct)
            runs[algorithm]["pliant"].append(through)
            print(f"{algorithm} seed {seed}: direct {direct}, pliant {through}", flush=True)
    rows = [(a, side, *summary(r[side])) for a, r in runs.items() for side in ("direct", "pliant")]
    print_table(f"triple-wall, {args.iterations} termination checks, length weight {args.length_weight:g}, "
                f"{args.seeds} seeds, single core",
                ("algorithm", "through", "solved", "valid (pliant)", "cost mean (std)", "time s"), rows)
    print(f"wrote {write_json('ompl', {'args': vars(args), 'runs': runs})}")


if __name__ == "__main__":
    main()
