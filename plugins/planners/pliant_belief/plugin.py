"""Entry point of the belief-space planner plugin (thesis ch. 5); heavy modules load when a planner is created."""

import os

from pliant.api import add_executor_arguments, hookimpl


@hookimpl
def pliant_register(registrar):
    registrar.add("planner", "belief", "pliant_belief.planner:BeliefPlanner",
                  description="belief-space RRT over particles with partial policies (thesis 5.3); "
                              "mode=contact / simple: the Contact RRT and Simple RRT baselines")


@hookimpl
def pliant_report(run, directory):
    if run.result is None or run.result.policy is None or getattr(run.result.policy, "kind", "") != "partial-policy":
        return None
    from pliant_belief.figures import draw_policy

    return draw_policy(run, directory)


@hookimpl
def pliant_add_commands(subparsers):
    parser = subparsers.add_parser(
        "belief-experiment", help="thesis 5.4 experiments: plan policies, execute them, tabulate success",
        description="Plan --plans policies per variant of an experiment and execute each --executions times in "
                    "each execution world; runs are written as they finish and resumed on a second call.")
    parser.add_argument("name", help="maze, maze-frictionless, table-5.1, table-5.2, table-5.1-tight, table-5.2-tight "
                        "or baxter-reach")
    parser.add_argument("--plans", type=int, default=30, help="policies per variant (default 30)")
    parser.add_argument("--executions", type=int, default=8, help="executions per policy and world (default 8)")
    parser.add_argument("--plan-time", type=float, default=120.0, help="planning time per policy (s, default 120)")
    parser.add_argument("--plan-iterations", type=int, default=None,
                        help="plan each policy to this many iterations instead (--plan-time is then a safety cap): "
                             "the results then depend on the seeds only, not on the machine's speed")
    parser.add_argument("--exec-time", type=float, default=600.0, help="execution time limit (s, default 600)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="tasks at a time (default: cores)")
    parser.add_argument("--only", nargs="*", help="variant labels to run (default all)")
    parser.add_argument("--fresh", action="store_true", help="forget the tasks already on file")
    parser.add_argument("--output", default="out/experiments", help="directory (default out/experiments)")
    parser.add_argument("--replay", action="store_true",
                        help="plan nothing: execute the saved policies on file again and replace their executions")
    add_executor_arguments(parser)
    parser.set_defaults(handler=_experiment_command)


def _experiment_command(args) -> int:
    from pathlib import Path

    from pliant_belief.experiments import run_experiment

    rows = run_experiment(args.name, plans=args.plans, executions=args.executions, plan_time=args.plan_time,
                          exec_time=args.exec_time, jobs=args.jobs, fresh=args.fresh, output=Path(args.output),
                          only=args.only, replay=args.replay, plan_iterations=args.plan_iterations)
    header = ("variant", "world", "plans", "P_plan", "P_exec", "actions", "t first (s)", "simulated", "stored",
              "solutions")
    lines = [header] + [(r["variant"], r["world"], str(r["plans"]), f"{r['p_plan']:.2f}",
                         f"{r['p_exec']:.2f} [{r['p_exec_std']:.2f}]", f"{r['actions']:.1f} [{r['actions_std']:.1f}]",
                         f"{r['time_to_first']:.1f}", f"{r['particles_simulated']:.0f}", f"{r['particles_stored']:.0f}",
                         f"{r['solutions']:.1f}") for r in rows]
    widths = [max(len(row[i]) for row in lines) for i in range(len(header))]
    for row in lines:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths)))
    print(f"\nwritten: {Path(args.output) / args.name}/runs.jsonl, summary.json")
    return 0


@hookimpl
def pliant_reproductions():
    from pliant_belief.reproduce import declarations

    return declarations()
