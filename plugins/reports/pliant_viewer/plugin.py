"""Entry point of the 3-D viewer plugin: the ``pliant view`` command and ``pliant run ... --view`` (live).

Light on purpose: viser, yourdfpy and the drawing code load only when a view is opened.
"""

from pliant.hookspecs import hookimpl


@hookimpl
def pliant_register(registrar):
    """This plugin adds no components, only the ``view`` command and the ``--view`` flag of ``run``."""


@hookimpl
def pliant_add_commands(subparsers):
    from pliant_viewer.commands import add_commands

    add_commands(subparsers)
