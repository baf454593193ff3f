"""How a plugin adds to the ``pliant`` command, and the options commands share.

The command has a fixed set of top-level commands (:data:`GROUPS`, docs/cli.md).  A plugin adds a sub-command to
a group by returning :class:`Command` declarations from its ``pliant_commands`` hook; it never touches another
command's parser.  An old spelling of a command keeps working through an :class:`Alias`: ``pliant`` rewrites it to
the new spelling and prints one deprecation line on stderr.

The shared options (``--jobs``, ``--seed``, ``--output``, ``--quick``, ``--fresh``, ``--set``, ``--executor`` and
``--address``) are added by :func:`add_common_arguments`, so that every experiment spells and explains them the
same way; a live page's address (``--host``, ``--port``, ``--hold``, ``--robot-meshes``) by
:func:`add_page_arguments`.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pliant.errors import PluginError

#: the top-level commands: name -> (help, whether plugins add sub-commands to it).  A group that takes no
#: sub-commands (``view``) is one command a plugin provides whole: its Command's name is the group's name.
GROUPS: dict[str, tuple[str, bool]] = {
    "run": ("run a pipeline and write its report (--view: watch it live)", False),
    "scenes": ("list bundled scenes, or describe one", False),
    "plugins": ("list plugins, components and their options", False),
    "view": ("open a 3-D view of a scene, a run folder or a policy in the browser", False),
    "experiment": ("every thesis table, figure and experiment (LIST: what exists and what waits)", True),
    "learn": ("record and import demonstrations for the learners", True),
    "robot": ("robot drivers: list, inspect a robot, emulated robots for demos and tests", True),
    "bench": ("run a benchmark script (prints a table, writes JSON), or a benchmark file FILE.toml", False),
}
#: the groups a plugin may add to (``view``: the one command of that name)
PLUGIN_GROUPS = ("experiment", "learn", "robot", "view")


@dataclass(frozen=True)
class Command:
    """A plugin's sub-command: ``pliant GROUP NAME ...`` (or ``pliant view ...`` for ``group="view"``).

    group: one of :data:`PLUGIN_GROUPS`; name: the sub-command (for ``view``: ``"view"``); help: one line for the
    group's listing; run: ``function(args) -> exit status`` or a ``"module:function"`` string imported when the
    command runs; arguments: ``function(parser)`` adding the command's arguments (or a ``"module:function"``
    string); description: the command's ``--help`` text (default: ``help``).
    """

    group: str
    name: str
    help: str
    run: Callable[[Any], int] | str
    arguments: Callable[[Any], None] | str | None = None
    description: str = ""


@dataclass(frozen=True)
class Alias:
    """An old spelling that keeps working: ``old`` (words, e.g. ``"learn-table"``) is replaced by ``new``
    (``"experiment table-4.1"``) and ``pliant`` prints ``pliant OLD is deprecated: use pliant NEW`` on stderr.  The
    longest matching ``old`` wins; an alias is never listed in ``pliant --help``."""

    old: str
    new: str


def load(target: Callable | str, field: str = "run") -> Callable:
    """``target`` itself, or the function a ``"module:function"`` string names (a :class:`PluginError` if it
    cannot be imported)."""
    if callable(target):
        return target
    module, _, function = str(target).partition(":")
    try:
        return getattr(importlib.import_module(module), function)
    except (ImportError, AttributeError, ValueError) as exc:
        raise PluginError(f"cannot load the command's function: {exc}", field=field, value=target) from None


def add_common_arguments(parser, *, jobs: str | None = None, seed: int | None = None, output: str | None = None,
                         quick: str | None = None, fresh: str | None = None, overrides: str | None = None,
                         executor: bool = False) -> None:
    """Add the options experiment commands share, each spelled and explained one way.

    jobs: what runs at a time (``"trials"``: ``--jobs``, default the machine's cores); seed: ``--seed``'s default;
    output: ``--output``'s default directory; quick: what ``--quick`` makes smaller; fresh: what ``--fresh``
    forgets; overrides: what ``--set KEY=VALUE`` (repeatable) sets; executor: ``--executor local|ray`` and
    ``--address`` (the tasks then run on that executor; ``--jobs`` stays the local pool's size).
    A ``None`` argument leaves its option out.
    """
    if jobs is not None:
        parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                            help=f"{jobs} at a time (default: this machine's cores)")
    if seed is not None:
        parser.add_argument("--seed", type=int, default=seed, help=f"seed (default {seed})")
    if quick is not None:
        parser.add_argument("--quick", action="store_true", help=f"CI-sized: {quick}")
    if fresh is not None:
        parser.add_argument("--fresh", action="store_true", help=f"forget {fresh} on file (a second run resumes)")
    if output is not None:
        parser.add_argument("--output", default=output, help=f"directory (default {output})")
    if overrides is not None:
        parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=overrides)
    if executor:
        from pliant.experiments.executor import add_executor_arguments

        add_executor_arguments(parser)


LOOPBACK = "127.0.0.1"


def add_page_arguments(parser, prefix: str = "", *, what: str = "the page") -> None:
    """Add the address of a served page: ``--{prefix}host``, ``--{prefix}port``, ``--{prefix}hold`` and
    ``--{prefix}robot-meshes`` (``pliant view`` has no prefix; ``pliant run --view`` uses ``view-``)."""
    parser.add_argument(f"--{prefix}host", default=LOOPBACK,
                        help=f"address to serve {what} on (default 127.0.0.1, loopback only; 0.0.0.0 exposes it)")
    parser.add_argument(f"--{prefix}port", type=int, default=0, help="port, 1-65535 (default: a free one)")
    parser.add_argument(f"--{prefix}hold", type=float, default=None, metavar="SECONDS",
                        help="keep serving this long (>= 0), then exit (default: until Ctrl-C)")
    parser.add_argument(f"--{prefix}robot-meshes", choices=("collision", "visual"), default="collision",
                        help="a URDF robot's meshes: collision (light, the default) or visual (detailed, slow to "
                             "draw)")
