"""Entry point of the report-figure plugin: draws the scene and the planned path."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """This plugin adds no components, only report figures."""


@hookimpl
def pliant_report(run, directory):
    from pliant_plots.scene_figure import draw_run

    return draw_run(run, directory)
