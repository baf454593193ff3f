"""Entry point of the TS-RRT plugin (poster ICHR 2010): the planner ``tsrrt``, the learner ``push-models`` and their
report figures.  Nothing heavy is imported until a component is created or a report is drawn."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``tsrrt`` planner and the ``push-models`` learner."""
    registrar.add("planner", "tsrrt", "pliant_tsrrt.planner:TSRRTPlanner",
                  description="TS-RRT (Scholz & Stilman, ICHR 2010): object-space RRT over learned push models with "
                              "DIRECTGD toward the cheapest arrangement; execution with monitoring and replanning")
    registrar.add("learner", "push-models", "pliant_tsrrt.learner:PushModelsLearner",
                  description="LEARN_MODEL (ICHR 2010 poster): displacement models per object class and push "
                              "primitive, learned in the simulator until their variance is below sigma_ref^2")


@hookimpl
def pliant_report(run, directory):
    """``tsrrt.png`` (the plan) and ``push-models.png`` (the learned models) for runs of the ``tsrrt`` planner or the
    ``push-models`` learner; None when the run has neither."""
    from pliant_tsrrt.figures import draw_run

    return draw_run(run, directory)


@hookimpl
def pliant_reproductions():
    """The TS-RRT poster (ICHR 2010): ``pliant experiment poster``."""
    from pliant_tsrrt.reproduce import declarations

    return declarations()
