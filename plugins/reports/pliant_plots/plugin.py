"""Entry point of the report-figure plugin: draws the scene and the planned path, and the path's trajectory over
time when the run has one."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """This plugin adds no components, only report figures."""


@hookimpl
def pliant_report(run, directory):
    """``path.png`` (the scene and the planned path) and ``trajectory.png`` (when the run has a trajectory); None when
    neither is drawn."""
    from pliant_plots.scene_figure import draw_run
    from pliant_plots.trajectory_figure import draw_trajectory

    return [*(draw_run(run, directory) or []), *(draw_trajectory(run, directory) or [])] or None
