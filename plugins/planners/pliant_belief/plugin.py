"""Entry point of the belief-space planner plugin (thesis ch. 5); heavy modules load when a planner is created."""

from pliant.api import Alias, Command, add_common_arguments, hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``belief`` planner (its ``mode`` option also gives the Contact RRT and Simple RRT baselines)."""
    registrar.add("planner", "belief", "pliant_belief.planner:BeliefPlanner",
                  description="belief-space RRT over particles with partial policies (thesis 5.3); "
                              "mode=contact / simple: the Contact RRT and Simple RRT baselines")


@hookimpl
def pliant_report(run, directory):
    """``policy.png``: the partial policy over the scene's obstacles, for a run whose result is a partial policy; None
    for any other run."""
    if run.result is None or run.result.policy is None or getattr(run.result.policy, "kind", "") != "partial-policy":
        return None
    from pliant_belief.figures import draw_policy

    return draw_policy(run, directory)


@hookimpl
def pliant_commands():
    """``pliant experiment belief NAME``: the thesis 5.4 experiments other than the tables (those are
    ``pliant experiment table-5.1`` / ``table-5.2``, with the same options)."""
    return [Command("experiment", "belief",
                    "thesis 5.4 experiments (maze, the tight tables, baxter-reach): plan policies, execute them, "
                    "tabulate success", run=_experiment_command, arguments=_experiment_arguments,
                    description="Plan --plans policies per variant of an experiment and execute each --executions "
                                "times in each execution world; runs are written as they finish and resumed on a "
                                "second call.  Tables 5.1 and 5.2 are pliant experiment table-5.1 / table-5.2."),
            Alias("belief-experiment", "experiment belief"),
            Alias("belief-experiment table-5.1", "experiment table-5.1"),
            Alias("belief-experiment table-5.2", "experiment table-5.2")]


#: the experiments of ``pliant experiment belief`` (tables 5.1 and 5.2 are reproductions)
EXPERIMENTS = ("maze", "maze-frictionless", "table-5.1-tight", "table-5.2-tight", "baxter-reach")


def _experiment_arguments(parser):
    parser.add_argument("name", choices=EXPERIMENTS, help=", ".join(EXPERIMENTS))
    run_arguments(parser, plans=30, executions=8, plan_time=120.0, exec_time=600.0)
    add_common_arguments(parser, fresh="the tasks", output="out/experiments", executor=True)


def run_arguments(parser, *, plans=None, executions=None, plan_time=None, exec_time=None):
    """The options of a belief experiment (``pliant experiment belief`` and the own options of ``table-5.1`` /
    ``table-5.2``, whose defaults are None: the mode's setting)."""
    def default(value, unit=""):
        return "the mode's" if value is None else f"{value:g}{unit}"

    parser.add_argument("--plans", type=int, default=plans, help=f"policies per variant (default {default(plans)})")
    parser.add_argument("--executions", type=int, default=executions,
                        help=f"executions per policy and world (default {default(executions)})")
    parser.add_argument("--plan-time", type=float, default=plan_time,
                        help=f"planning time per policy (s, default {default(plan_time)})")
    parser.add_argument("--plan-iterations", type=int, default=None,
                        help="plan each policy to this many iterations instead (--plan-time is then a safety cap): "
                             "the results then depend on the seeds only, not on the machine's speed")
    parser.add_argument("--exec-time", type=float, default=exec_time,
                        help=f"execution time limit (s, default {default(exec_time)})")
    parser.add_argument("--only", nargs="+", metavar="LABEL", help="variant labels to run (default all)")
    parser.add_argument("--replay", action="store_true", default=None,
                        help="plan nothing: execute the saved policies on file again and replace their executions")
    add_common_arguments(parser, jobs="tasks")


def _experiment_command(args) -> int:
    from pathlib import Path

    from pliant_belief.experiments import run_experiment

    rows = run_experiment(args.name, plans=args.plans, executions=args.executions, plan_time=args.plan_time,
                          exec_time=args.exec_time, jobs=args.jobs, fresh=args.fresh, output=Path(args.output),
                          only=args.only, replay=bool(args.replay), plan_iterations=args.plan_iterations)
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


def table_arguments(group):
    """The own options of ``pliant experiment table-5.1`` / ``table-5.2`` (over the mode's settings)."""
    run_arguments(group)


@hookimpl
def pliant_reproductions():
    """The thesis's Tables 5.1 and 5.2 (``pliant experiment table-5.1`` / ``table-5.2``)."""
    from pliant_belief.reproduce import declarations

    return declarations()
