"""The pluggy hooks a pliant plugin may implement.

A plugin is a module named by an entry point in the ``pliant`` group.  It implements
:func:`pliant_register` to add its components; it may implement :func:`pliant_report` to draw
figures for pipeline reports.  Keep the module light: name component classes as
``"package.module:Class"`` strings so heavy libraries load only when a component is created.
"""

from __future__ import annotations

import pluggy

PROJECT = "pliant"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


class PliantSpec:
    """Hook specifications of pliant."""

    @hookspec
    def pliant_register(self, registrar):
        """Register components: ``registrar.add(kind, name, "module:Class", description="...")``."""

    @hookspec
    def pliant_report(self, run, directory):
        """Draw figures for a finished pipeline ``run`` into ``directory``; return the files written.

        ``run`` is a :class:`pliant.pipeline.RunRecord`.  Return a list of ``pathlib.Path`` (or
        ``None`` when the plugin has nothing to draw for this run).  It is called for every outcome
        (``run.outcome``): after a failed or interrupted execution ``run.execution`` is the partial record, possibly
        without steps.  A file written but not a figure goes into ``run.files`` instead; either way the next run into
        the folder removes it (docs/outcomes.md), and a file in neither list stays.
        """

    @hookspec
    def pliant_reproductions(self):
        """Declare reproductions of thesis tables and figures for ``pliant reproduce``: return a list of
        :class:`pliant.experiments.reproduce.Reproduction` (the runner a ``"module:function"`` string, imported only
        when it runs)."""

    @hookspec
    def pliant_add_commands(self, subparsers):
        """Add sub-commands to the ``pliant`` command line.

        ``subparsers`` is the :mod:`argparse` sub-parser action; call ``subparsers.add_parser(...)``
        and ``set_defaults(handler=function)``; the handler receives the parsed namespace and returns
        an exit code.
        """
