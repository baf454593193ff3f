"""Entry point of the ch. 4 learners: PIIRL sensitivity recovery and its active-learning loop."""

from pliant.api import add_executor_arguments, hookimpl

_MODULE = "pliant_piirl.learner"


@hookimpl
def pliant_register(registrar):
    registrar.add("learner", "piirl", f"{_MODULE}:PiirlLearner",
                  description="object sensitivities from demonstrations by PIIRL (thesis 4.3.3; a ranking, or eq. 4.1)")
    registrar.add("learner", "active-piirl", f"{_MODULE}:ActivePiirlLearner",
                  description="Alg. 2-3 choose demonstrations, a simulated expert shows them, PIIRL learns (ch. 4)")
    registrar.add("learner", "press-deformability", "pliant_piirl.deformability:PressDeformabilityLearner",
                  description="deformability from volume changes under a press, against a known object (app. A)")


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
    add_executor_arguments(parser)
    parser.set_defaults(handler=_active_command)


def _active_command(args) -> int:
    from pathlib import Path

    from pliant.api import parse_override

    from pliant_piirl.experiments import QUICK, render, run_trials

    options = dict(parse_override(item, "--set") for item in args.set)
    trials = QUICK["trials"] if args.quick and args.trials == 15 else args.trials
    summary = run_trials(trials=trials, jobs=args.jobs, output=Path(args.output), all_pairs=args.all_pairs,
                         quick=args.quick, fresh=args.fresh, options=options)
    print(render(summary))
    return 0


@hookimpl(specname="pliant_add_commands")
def add_table_command(subparsers):
    import os

    parser = subparsers.add_parser(
        "learn-table", help="thesis Table 4.1: plan every demonstration task with the recovered sensitivities",
        description="Learn from all 12 adjacent pairs of the hollow cube, then plan each task --plans times with "
                    "the recovered sensitivities: RRT* (puncture check on, the task's funnel) for --max-iterations "
                    "iterations (or --max-time s), a shortcut, then --refine rounds of local search in the recovered "
                    "cost from the cheaper of that path and the best straight insertion.  Compares planned and "
                    "demonstrated deformation in the true sensitivities.  Resumable.")
    parser.add_argument("--plans", type=int, default=None, help="RRT* runs per task (default 3, --quick 1; thesis 30 "
                        "and 15)")
    budget = parser.add_mutually_exclusive_group()
    budget.add_argument("--max-time", type=float, default=None, help="seconds of RRT* per plan instead of iterations "
                        "(thesis 30 and 60 minutes): the plans then depend on the machine's speed")
    budget.add_argument("--max-iterations", type=int, default=None,
                        help="RRT* iterations per plan (default 10,000, --quick 3,000): the plans depend on their "
                             "seeds only")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="plans at a time (default: cores)")
    parser.add_argument("--refine", type=int, default=None, metavar="ROUNDS",
                        help="rounds of local search in the recovered cost after RRT* and shortcutting (default 60; "
                             "0: RRT* alone, the thesis's procedure)")
    parser.add_argument("--no-straight", dest="straight", action="store_false",
                        help="start the local search from the RRT* path only (by default from the cheaper, in the "
                             "recovered cost, of it and the best straight insertion)")
    parser.add_argument("--quick", action="store_true",
                        help="CI-sized: 3 tasks, 1 plan of 3000 iterations, a coarser expert")
    parser.add_argument("--fresh", action="store_true", help="learn again and forget the plans on file")
    parser.add_argument("--output", default="out", help="directory (default out)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="an active-piirl option")
    add_executor_arguments(parser)
    parser.set_defaults(handler=_table_command)


def _table_command(args) -> int:
    from pathlib import Path

    from pliant.api import parse_override

    from pliant_piirl.experiments import TABLE_FULL, TABLE_QUICK, render_table41, run_table41

    options = dict(parse_override(item, "--set") for item in args.set)
    defaults = TABLE_QUICK if args.quick else TABLE_FULL
    plans = defaults["plans"] if args.plans is None else args.plans
    refine = defaults["refine"] if args.refine is None else args.refine
    max_time, max_iterations = args.max_time, args.max_iterations
    if max_time is None and max_iterations is None:
        max_iterations = defaults["max_iterations"]
    summary = run_table41(plans=plans, max_time=max_time, max_iterations=max_iterations, jobs=args.jobs,
                          output=Path(args.output), quick=args.quick, fresh=args.fresh, options=options,
                          refine=refine, straight=args.straight)
    print(render_table41(summary))
    return 0


@hookimpl(specname="pliant_add_commands")
def add_import_command(subparsers):
    parser = subparsers.add_parser(
        "import-demonstration", help="add a demonstration recorded in a ROS bag to a demonstrations file",
        description="Read a pose (PoseStamped, Pose, TransformStamped) or joint_states topic of a ROS 1 or ROS 2 bag "
                    "as a path, make it a demonstration of the task given by --target (and --plane), and add it "
                    "to --output (created if missing; it must be of the same scene).")
    parser.add_argument("bag", help="a ROS 1 .bag file or a ROS 2 bag folder")
    parser.add_argument("--topic", required=True, help="the topic holding the motion")
    parser.add_argument("--scene", required=True, help="the scene the demonstration was shown in")
    parser.add_argument("--target", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                        help="the point the tip had to touch (m)")
    parser.add_argument("--plane", type=float, nargs=4, action="append", default=[],
                        metavar=("NX", "NY", "NZ", "OFFSET"), help="a collision plane n . x <= offset (unit n, m)")
    parser.add_argument("--joints", nargs="*", help="joint names in configuration order (JointState topics)")
    parser.add_argument("--min-step", type=float, default=0.0, help="drop configurations closer than this to the "
                        "last kept one (default 0: keep all)")
    parser.add_argument("--output", required=True, help="the demonstrations file (JSON)")
    parser.set_defaults(handler=_import_command)


def _import_command(args) -> int:
    from pathlib import Path

    import numpy as np
    from pliant import api
    from pliant.api import DEFAULT_ROBOT, ConfigError, Context

    from pliant_piirl.demonstration import (
        DemonstrationTask,
        check_demonstrations,
        load_demonstrations,
        save_demonstrations,
    )
    from pliant_piirl.rosbag import import_demonstration

    planes = np.array(args.plane, dtype=np.float64).reshape(-1, 4)
    DemonstrationTask.from_dict({"start": [0.0], "target": list(args.target), "planes": planes.tolist()},
                                field_name="--plane")          # unit normals, finite numbers: checked now
    output = Path(args.output)
    existing = []
    if output.exists():
        scene, existing = load_demonstrations(output)
        if scene != args.scene:
            raise ConfigError(f"holds demonstrations of scene {scene!r}, not {args.scene!r}", field="--output",
                              value=str(output))
    scene_model = api.load_scene(args.scene)
    context = Context(scene=scene_model)
    context.robot = api.registry.create("robot", DEFAULT_ROBOT[scene_model.robot.kind], context)
    demonstration = import_demonstration(args.bag, args.topic, args.target, planes=planes, joints=args.joints,
                                         min_step=args.min_step)
    # the recording against the scene's workspace (and the robot's dimension) before anything is written
    check_demonstrations([demonstration], scene_model, context.space, source=f"{args.bag}:{args.topic}",
                         field_name="recording")
    save_demonstrations(output, [*existing, demonstration], args.scene)
    print(f"{output}: {len(existing) + 1} demonstration(s); added {len(demonstration.path)} configurations from "
          f"{args.bag} {args.topic}")
    return 0


@hookimpl(specname="pliant_add_commands")
def add_capture_command(subparsers):
    parser = subparsers.add_parser(
        "capture", help="record a demonstration: drive the probe with the keyboard in a browser page (loopback)",
        description="Generate a task for an object pair (Algorithm 3), read one, or (neither given) take the scene's "
                    "start and goal; serve the capture page on loopback and add the demonstration to --output when "
                    "Enter is pressed at the target (or goal).  --keys plays a key sequence instead (headless).")
    parser.add_argument("scene", help="the scene: a rigid probe with its tip at body (0, 0, -0.06) for --pair / "
                        "--task, or any rigid robot for the scene's own start and goal")
    parser.add_argument("--pair", nargs=2, metavar=("OBJECT", "OBJECT"), help="the adjacent objects to ask about")
    parser.add_argument("--task", help="a demonstrations file whose first task to demonstrate (instead of --pair)")
    parser.add_argument("--seed", type=int, default=0, help="the task generator's seed (default 0)")
    parser.add_argument("--output", required=True, help="the demonstrations file to add to")
    parser.add_argument("--keys", help="play these keys instead of serving the page, then save")
    parser.add_argument("--host", default="127.0.0.1", help="address to serve on (default loopback only)")
    parser.add_argument("--port", type=int, default=0, help="port (default: any free one)")
    parser.set_defaults(handler=_capture_command)


def _capture_command(args) -> int:
    import numpy as np
    from pliant import api
    from pliant.api import ConfigError

    from pliant_piirl.capture import CaptureSession
    from pliant_piirl.capture_server import CaptureServer
    from pliant_piirl.demonstration import load_demonstrations
    from pliant_piirl.features import DeformationFeatures
    from pliant_piirl.tasks import TaskSpace, rotation_onto

    if args.pair is not None and args.task is not None:
        raise ConfigError("give at most one of --pair and --task", field="--pair", value=args.pair)
    scene = api.load_scene(args.scene)
    tip = np.array([0.0, 0.0, -0.06])
    if args.pair is None and args.task is None:         # the scene's own task: from its start to its goal
        from pliant_piirl.demonstration import DemonstrationTask

        task = DemonstrationTask(scene.start, np.r_[scene.goal[:2], 0.0] if len(scene.goal) == 3 else
                                 np.asarray(scene.goal[:3], dtype=float), goal=scene.goal)
        tip = np.zeros(3)
    elif args.task:
        _, demonstrations = load_demonstrations(args.task, dim=len(scene.start))
        if not demonstrations:
            raise ConfigError("holds no task", field="--task", value=args.task)
        from pliant.api import DEFAULT_ROBOT, Context

        from pliant_piirl.demonstration import check_demonstrations

        context = Context(scene=scene)
        context.robot = api.registry.create("robot", DEFAULT_ROBOT[scene.robot.kind], context)
        check_demonstrations(demonstrations[:1], scene, context.space, source=args.task)
        task = demonstrations[0].task
    else:
        task = TaskSpace(scene).generate_task(*args.pair, np.random.default_rng(args.seed), tip, rotation_onto)
    tolerance = scene.goal_tolerance if task.goal is not None and scene.goal_tolerance > 0 else 0.004
    session = CaptureSession(DeformationFeatures(scene), task, tip, tolerance=tolerance)
    server = CaptureServer(session, args.output, scene.name, host=args.host, port=args.port)
    if args.keys is not None:
        state = session.play(args.keys)
        print(f"{state['steps']} steps ({state['refused']} refused); tip {state['distance'] * 1000:.1f} mm from the "
              "target")
        print(f"saved to {server.save()}")
        server.httpd.server_close()
        return 0
    print(f"capture page: {server.url}  (Ctrl-C to stop)")
    try:
        server.httpd.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.httpd.server_close()
    print(f"saved to {server.saved}" if server.saved else "nothing saved")
    return 0


@hookimpl(specname="pliant_add_commands")
def add_planar_command(subparsers):
    parser = subparsers.add_parser(
        "learn-planar", help="thesis Table 4.2: uniform vs demonstrated vs recovered sensitivities in the plane",
        description="On planar-objects: RRT* with the true sensitivities plays the expert; PIIRL recovers the "
                    "sensitivities from its demonstration (bounds 1-200); RRT* plans with uniform and with the "
                    "recovered sensitivities; the deformation of every object is reported for the three paths.")
    budget = parser.add_mutually_exclusive_group()
    budget.add_argument("--max-time", type=float, default=None,
                        help="seconds per plan (default 60; thesis 5 min)")
    budget.add_argument("--max-iterations", type=int, default=None,
                        help="RRT* iterations per plan instead of seconds: the table then depends on the seed only, "
                             "not on the machine's speed")
    parser.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    parser.add_argument("--output", default="out", help="directory (default out)")
    parser.set_defaults(handler=_planar_command)


def _planar_command(args) -> int:
    from pathlib import Path

    from pliant_piirl.experiments import render_table42, run_table42

    max_time = 60.0 if args.max_time is None and args.max_iterations is None else args.max_time
    print(render_table42(run_table42(max_time=max_time, max_iterations=args.max_iterations, seed=args.seed,
                                     output=Path(args.output))))
    return 0


@hookimpl(specname="pliant_add_commands")
def add_deformability_command(subparsers):
    parser = subparsers.add_parser(
        "learn-deformability", help="thesis Table 8.1: deformability from presses against a known object",
        description="Press a known soft object (deformability 0.5) and five unknown ones (the thesis's ground truth "
                    "0.75-0.25) in pybullet with a force-capped indenter; each estimate is the ratio of volume "
                    "changes times 0.5 (thesis appendix A).")
    parser.add_argument("--repetitions", type=int, default=30, help="presses per object (default 30, as the thesis)")
    parser.add_argument("--force", type=float, default=1.0, help="the indenter's force (N, default 1)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the indenter's offsets (default 0)")
    parser.add_argument("--output", default="out", help="directory (default out)")
    parser.set_defaults(handler=_deformability_command)


def _deformability_command(args) -> int:
    from pathlib import Path

    from pliant_piirl.experiments import render_table81, run_table81

    print(render_table81(run_table81(repetitions=args.repetitions, force=args.force, seed=args.seed,
                                     output=Path(args.output))))
    return 0


@hookimpl
def pliant_reproductions():
    from pliant_piirl.reproduce import declarations

    return declarations()
