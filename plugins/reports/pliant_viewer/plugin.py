"""Entry point of the 3-D viewer plugin: the ``pliant view`` command, the live view of ``pliant run ... --view`` (the
``pliant_run_view`` hook) and the run folder's view cache written with a run's report.

Light on purpose: viser, yourdfpy and the drawing code load only when a view is opened.
"""

from pliant.api import Command, hookimpl


@hookimpl
def pliant_register(registrar):
    """This plugin adds no components, only the ``view`` command and the live view of ``run --view``."""


@hookimpl
def pliant_commands():
    """``pliant view TARGET``: a 3-D view of a scene, a run folder or a policy in the browser."""
    return [Command("view", "view", "open a 3-D view of a scene, a run folder or a policy in the browser",
                    run="pliant_viewer.commands:cmd_view", arguments="pliant_viewer.commands:add_arguments",
                    description="Serve a local web page (viser) showing TARGET in 3-D: a scene name or file, a "
                                "pipeline run folder (out/<name>/), or a policy / result JSON file.  The page shows "
                                "the voxel objects coloured by material, the robot, the planned path, the executed "
                                "trajectory with a time slider, the belief tree and a Pareto front.")]


@hookimpl
def pliant_run_view(pipeline, args):
    """``pliant run PIPELINE --view``: a live page of the run (:class:`pliant_viewer.commands.LiveView`)."""
    from pliant_viewer.commands import LiveView

    return LiveView(pipeline, args)


@hookimpl
def pliant_report(run, directory):
    """Write the run folder's ``view-cache.npz`` (articulated robots), so the first ``pliant view`` of it is fast.

    Not a figure: it is added to the run's files, not returned (the report lists returned files as images)."""
    from pliant_viewer.report import write_view_cache

    path = write_view_cache(run, directory)
    if path is not None:
        run.files.append(path)
    return None
