"""The ch. 4 learners' commands: ``pliant learn capture`` / ``learn import``, ``pliant experiment active-learning``
and the options of ``pliant experiment table-4.1`` / ``table-4.2`` / ``table-8.1`` (argparse only; the learners
load when a command runs)."""

from __future__ import annotations

from pliant.api import add_common_arguments


def active_arguments(parser) -> None:
    """``pliant experiment active-learning``."""
    parser.add_argument("--trials", type=int, default=15, help="trials (default 15, as the thesis)")
    parser.add_argument("--all-pairs", action="store_true", help="every adjacent pair (12), not Algorithm 2")
    add_common_arguments(parser, jobs="trials", quick="2 trials, 30 samples, a coarser expert", fresh="the trials",
                         output="out", overrides="an active-piirl option", executor=True)


def active_command(args) -> int:
    """Run ``pliant experiment active-learning``: the trials not yet on file, then print the report."""
    from pathlib import Path

    from pliant.api import parse_override

    from pliant_piirl.experiments import QUICK, render, run_trials

    options = dict(parse_override(item, "--set") for item in args.set)
    trials = QUICK["trials"] if args.quick and args.trials == 15 else args.trials
    summary = run_trials(trials=trials, jobs=args.jobs, output=Path(args.output), all_pairs=args.all_pairs,
                         quick=args.quick, fresh=args.fresh, options=options)
    print(render(summary))
    return 0


def table41_arguments(group) -> None:
    """The own options of ``pliant experiment table-4.1`` (None: the mode's setting)."""
    group.add_argument("--plans", type=int, default=None, help="RRT* runs per task (full 3, quick 1; thesis 30 "
                       "and 15)")
    budget = group.add_mutually_exclusive_group()
    budget.add_argument("--max-time", type=float, default=None, help="seconds of RRT* per plan instead of "
                        "iterations (thesis 30 and 60 minutes): the plans then depend on the machine's speed")
    budget.add_argument("--max-iterations", type=int, default=None,
                        help="RRT* iterations per plan (full 10,000, quick 3,000): the plans depend on their seeds "
                             "only")
    group.add_argument("--refine", type=int, default=None, metavar="ROUNDS",
                       help="rounds of local search in the recovered cost after RRT* and shortcutting (default 60; "
                            "0: RRT* alone, the thesis's procedure)")
    group.add_argument("--no-straight", dest="straight", action="store_false", default=None,
                       help="start the local search from the RRT* path only (by default from the cheaper, in the "
                            "recovered cost, of it and the best straight insertion)")
    add_common_arguments(group, jobs="plans", overrides="an active-piirl option")


def table42_arguments(group) -> None:
    """The own options of ``pliant experiment table-4.2``."""
    budget = group.add_mutually_exclusive_group()
    budget.add_argument("--max-time", type=float, default=None, help="seconds per plan (full 300; thesis 5 min)")
    budget.add_argument("--max-iterations", type=int, default=None,
                        help="RRT* iterations per plan instead of seconds (quick 25,000, ci 12,000): the table then "
                             "depends on the seed only, not on the machine's speed")
    add_common_arguments(group, seed=0)


def table81_arguments(group) -> None:
    """The own options of ``pliant experiment table-8.1``."""
    group.add_argument("--repetitions", type=int, default=None,
                       help="presses per object (full 30, as the thesis; quick 5, ci 3)")
    group.add_argument("--force", type=float, default=None,
                       help="the indenter's force (N; default: chosen by the learner from the reference object)")
    add_common_arguments(group, seed=0)


def import_arguments(parser) -> None:
    """``pliant learn import``."""
    parser.add_argument("bag", help="a ROS 1 .bag file, a ROS 2 bag folder (sqlite3 or MCAP) or a ROS 2 .db3 / "
                        ".mcap file")
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


def import_command(args) -> int:
    """Run ``pliant learn import``: read the bag's ``--topic`` as a demonstration of the task given by ``--target`` (and
    ``--plane``), check it against the scene and add it to the ``--output`` file."""
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


def capture_arguments(parser) -> None:
    """``pliant learn capture``."""
    parser.add_argument("scene", help="the scene: a rigid probe with its tip at body (0, 0, -0.06) for --pair / "
                        "--task, or any rigid robot for the scene's own start and goal")
    parser.add_argument("--pair", nargs=2, metavar=("OBJECT", "OBJECT"), help="the adjacent objects to ask about")
    parser.add_argument("--task", help="a demonstrations file whose first task to demonstrate (instead of --pair)")
    parser.add_argument("--seed", type=int, default=0, help="the task generator's seed (default 0)")
    parser.add_argument("--output", required=True, help="the demonstrations file to add to")
    parser.add_argument("--keys", help="play these keys instead of serving the page, then save")
    parser.add_argument("--host", default="127.0.0.1", help="address to serve on (default loopback only)")
    parser.add_argument("--port", type=int, default=0, help="port (default: any free one)")


def capture_command(args) -> int:
    """Run ``pliant learn capture``: for the task of ``--pair``, ``--task`` or the scene's own start and goal, serve the
    capture page until Ctrl-C (Enter at the target adds the demonstration to ``--output``), or play ``--keys`` and
    save."""
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
