"""The pluggy hooks a pliant plugin may implement.

A plugin is a module named by an entry point in the ``pliant`` group.  It implements
:func:`pliant_register` to add its components; it may implement :func:`pliant_report` to draw
figures for pipeline reports and :func:`pliant_commands` to add sub-commands.  Keep the module light: name component
classes as ``"package.module:Class"`` strings so heavy libraries load only when a component is created.
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
        """Declare reproductions of thesis tables and figures for ``pliant experiment``: return a list of
        :class:`pliant.experiments.reproduce.Reproduction` (the runner a ``"module:function"`` string, imported only
        when it runs)."""

    @hookspec
    def pliant_commands(self):
        """Declare sub-commands of the ``pliant`` command line: return a list of
        :class:`pliant.api.Command` (a sub-command of a group: ``experiment``, ``learn``, ``robot``, or the ``view``
        command) and :class:`pliant.api.Alias` (an old spelling that keeps working, with a deprecation line).
        Functions may be ``"module:function"`` strings, imported only when the command runs (docs/cli.md)."""

    @hookspec(warn_on_impl=DeprecationWarning("pliant_add_commands is no longer called: declare the plugin's "
                                              "sub-commands with pliant_commands (docs/cli.md)"))
    def pliant_add_commands(self, subparsers):
        """Deprecated and no longer called: it let a plugin add to (and patch) the command line's parsers.  Declare
        sub-commands with :func:`pliant_commands` instead; a plugin that still implements this loads, without those
        commands."""

    @hookspec(firstresult=True)
    def pliant_run_view(self, pipeline, args):
        """``pliant run PIPELINE --view``: open a live view of ``pipeline`` (a :class:`pliant.pipeline.Pipeline`,
        not yet run) with the ``--view-*`` options in ``args``; return an object with ``on_step(step)`` (called at
        every execution step) and ``finish(record)`` (called after the run, with its
        :class:`~pliant.pipeline.RunRecord`, or None if it raised; it may hold the page open), or None to leave it
        to another plugin."""
