"""Entry point of the ch. 4 learners: PIIRL sensitivity recovery and its active-learning loop."""

from pliant.api import Alias, Command, hookimpl

_MODULE = "pliant_piirl.learner"
_COMMANDS = "pliant_piirl.commands"


@hookimpl
def pliant_register(registrar):
    """Register the ``piirl``, ``active-piirl`` and ``press-deformability`` learners."""
    registrar.add("learner", "piirl", f"{_MODULE}:PiirlLearner",
                  description="object sensitivities from demonstrations by PIIRL (thesis 4.3.3; a ranking, or eq. 4.1)")
    registrar.add("learner", "active-piirl", f"{_MODULE}:ActivePiirlLearner",
                  description="Alg. 2-3 choose demonstrations, a simulated expert shows them, PIIRL learns (ch. 4)")
    registrar.add("learner", "press-deformability", "pliant_piirl.deformability:PressDeformabilityLearner",
                  description="deformability from volume changes under a press, against a known object (app. A)")


@hookimpl
def pliant_commands():
    """``pliant experiment active-learning``, ``pliant learn capture`` and ``pliant learn import``; the thesis
    tables 4.1, 4.2 and 8.1 are reproductions (``pliant experiment table-4.1``, :func:`pliant_reproductions`)."""
    return [
        Command("experiment", "active-learning",
                "thesis 4.4: learn the hollow cube's sensitivities in seeded trials (active or all pairs)",
                run=f"{_COMMANDS}:active_command", arguments=f"{_COMMANDS}:active_arguments",
                description="Each trial: Algorithm 2 asks for demonstrations (or --all-pairs: every adjacent pair), "
                            "the simulated expert shows them, PIIRL recovers the sensitivities.  Trials are written "
                            "as they finish and resumed on a second call; report.md and summary.json are written "
                            "beside them."),
        Command("learn", "capture",
                "record a demonstration: drive the probe with the keyboard in a browser page (loopback)",
                run=f"{_COMMANDS}:capture_command", arguments=f"{_COMMANDS}:capture_arguments",
                description="Generate a task for an object pair (Algorithm 3), read one, or (neither given) take the "
                            "scene's start and goal; serve the capture page on loopback and add the demonstration "
                            "to --output when Enter is pressed at the target (or goal).  --keys plays a key "
                            "sequence instead (headless)."),
        Command("learn", "import", "add a demonstration recorded in a ROS bag to a demonstrations file",
                run=f"{_COMMANDS}:import_command", arguments=f"{_COMMANDS}:import_arguments",
                description="Read a pose (PoseStamped, Pose, TransformStamped) or joint_states topic of a ROS 1 or "
                            "ROS 2 bag as a path, make it a demonstration of the task given by --target (and "
                            "--plane), and add it to --output (created if missing; it must be of the same scene)."),
        Alias("learn-active", "experiment active-learning"),
        Alias("learn-table", "experiment table-4.1"),
        Alias("learn-planar", "experiment table-4.2"),
        Alias("learn-deformability", "experiment table-8.1"),
        Alias("capture", "learn capture"),
        Alias("import-demonstration", "learn import"),
    ]


@hookimpl
def pliant_reproductions():
    """The thesis's Tables 4.1, 4.2 and 8.1 (``pliant experiment table-4.1`` / ``table-4.2`` / ``table-8.1``)."""
    from pliant_piirl.reproduce import declarations

    return declarations()
