"""Entry point of the 3-D viewer plugin: the ``pliant view`` command, ``pliant run ... --view`` (live) and the run
folder's view cache written with a run's report.

Light on purpose: viser, yourdfpy and the drawing code load only when a view is opened.
"""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """This plugin adds no components, only the ``view`` command and the ``--view`` flag of ``run``."""


@hookimpl
def pliant_add_commands(subparsers):
    from pliant_viewer.commands import add_commands

    add_commands(subparsers)


@hookimpl
def pliant_report(run, directory):
    """Write the run folder's ``view-cache.npz`` (articulated robots), so the first ``pliant view`` of it is fast.

    Not a figure: it is added to the run's files, not returned (the report lists returned files as images)."""
    from pliant_viewer.report import write_view_cache

    path = write_view_cache(run, directory)
    if path is not None:
        run.files.append(path)
    return None
