"""Entry point of the ch. 4 learners: PIIRL sensitivity recovery and its active-learning loop."""

from pliant.hookspecs import hookimpl

_MODULE = "pliant_piirl.learner"


@hookimpl
def pliant_register(registrar):
    registrar.add("learner", "piirl", f"{_MODULE}:PiirlLearner",
                  description="object sensitivities from demonstrations by PIIRL (thesis 4.3.3, eq. 4.1)")
    registrar.add("learner", "active-piirl", f"{_MODULE}:ActivePiirlLearner",
                  description="Alg. 2-3 choose demonstrations, a simulated expert shows them, PIIRL learns (ch. 4)")


@hookimpl
def pliant_add_commands(subparsers):
    import os

    parser = subparsers.add_parser(
        "learn-active", help="thesis 4.4: learn the hollow cube's sensitivities in seeded trials (active or all pairs)",
        description="Each trial: Algorithm 2 asks for demonstrations (or --all-pairs: every adjacent pair), the "
                    "simulated expert shows them, PIIRL recovers the sensitivities.  Trials are written as they "
                    "finish and resumed on a second call; report.md and summary.json are written beside them.")
    parser.add_argument("--trials", type=int, default=15, help="trials (default 15, as the thesis)")
    parser.add_argument("--all-pairs", action="store_true", help="every adjacent pair (12), not Algorithm 2")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="trials at a time (default: cores)")
    parser.add_argument("--quick", action="store_true", help="CI-sized: 2 trials, 30 samples, a coarser expert")
    parser.add_argument("--fresh", action="store_true", help="forget the trials on file")
    parser.add_argument("--output", default="out", help="directory (default out)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="an active-piirl option")
    parser.set_defaults(handler=_active_command)


def _active_command(args) -> int:
    from pathlib import Path

    from pliant.pipeline import parse_override

    from pliant_piirl.experiments import QUICK, render, run_trials

    options = dict(parse_override(item, "--set") for item in args.set)
    trials = QUICK["trials"] if args.quick and args.trials == 15 else args.trials
    summary = run_trials(trials=trials, jobs=args.jobs, output=Path(args.output), all_pairs=args.all_pairs,
                         quick=args.quick, fresh=args.fresh, options=options)
    print(render(summary))
    return 0
