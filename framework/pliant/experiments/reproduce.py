"""``pliant experiment NAME``: every thesis table and figure by one command, each with a report of ours beside the
thesis's (docs/experiments.md).

Plugins declare their reproductions through the hook ``pliant_reproductions()`` (a list of
:class:`Reproduction`), so the core imports no plugin: the runner is a ``"module:function"`` string imported only
when the reproduction runs.  The core keeps the catalogue of the thesis's tables and figures
(:data:`CATALOGUE`): one no plugin provides is listed as *waiting*, naming the plugin it waits for.

A runner is called as ``runner(run: ReproductionRun) -> Outcome``.  ``run.mode`` is one of

- ``full``: the thesis's protocol (hours to days on two cores; ``--executor ray`` spreads it over a cluster);
- ``quick``: CI-sized, minutes;
- ``ci``: for reproductions whose quick mode takes more than a few minutes, a smaller one that still checks the
  headline numbers (the reproduction's ``modes`` says what each does).

The :class:`Outcome` holds the rows of the table (ours beside the thesis's, each with the tolerance within which a
difference is not marked), the headline numbers with their documented tolerance ranges (checked: ``pliant
reproduce`` exits with status 3 when one is outside, so CI fails on a change that breaks a result), the exact
settings, the raw record files and the figures.  :func:`run_reproduction` writes ``report.md`` and
``outcome.json`` into ``out/reproduce/<name>/<mode>/``.
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

from pliant.errors import ConfigError, PluginError
from pliant.files import write_json, write_text

MODES = ("full", "quick", "ci")

#: every thesis table and figure `pliant experiment` knows, with what a missing one waits for
CATALOGUE: dict[str, tuple[str, str]] = {
    "figure-3.5": ("Figure 3.5: A* path classes on the triple-wall over p", "the A* planner (pliant_astar)"),
    "table-3.1": ("Table 3.1: T-RRT and GradienT-RRT on the cube-wall", "the T-RRT planners (pliant_trrt)"),
    "table-4.1": ("Table 4.1: planning with recovered sensitivities against the demonstrations",
                  "the PIIRL learner (pliant_piirl)"),
    "table-4.2": ("Table 4.2: uniform, demonstrated and recovered-sensitivity paths in the planar environment",
                  "the PIIRL learner (pliant_piirl)"),
    "table-5.1": ("Table 5.1: belief planner clustering methods on the SE(3) peg-in-hole",
                  "the belief planner (pliant_belief)"),
    "table-5.2": ("Table 5.2: Simple RRT, Contact RRT and the belief planner over actuation noise",
                  "the belief planner (pliant_belief)"),
    "table-6.1": ("Table 6.1: path-quality metrics' P_exec on the SE(3) peg-in-hole",
                  "the reachable-volume metrics (pliant_reachability)"),
    "table-6.2": ("Table 6.2: path-quality metrics' P_exec on the SE(2) through-hole",
                  "the reachable-volume metrics (pliant_reachability)"),
    "table-6.3": ("Table 6.3: path-quality metrics' computation time on the SE(3) peg-in-hole",
                  "the reachable-volume metrics (pliant_reachability)"),
    "table-6.4": ("Table 6.4: path-quality metrics' computation time on the SE(2) through-hole",
                  "the reachable-volume metrics (pliant_reachability)"),
    "table-8.1": ("Table 8.1: recovered deformability against ground truth (appendix A)",
                  "the deformability learner (pliant_piirl)"),
    "poster": ("The TS-RRT poster (ICHR 2010): object-space planning", "the TS-RRT planner (pliant_tsrrt)"),
}


@dataclass(frozen=True)
class Reproduction:
    """A plugin's reproduction of one thesis table or figure.

    name: the catalogue name (``table-5.1``) or a new one; title: what it reproduces; runner: ``"module:function"``
    called as ``function(run) -> Outcome``; modes: what each mode (``full``, ``quick``, ``ci``) runs, in words --
    a mode not listed is not offered; minutes: rough duration of each mode on two cores; arguments: optional
    ``"module:function"`` adding the reproduction's own options to its ``pliant experiment NAME`` parser (their
    values reach the runner as ``run.options``; leave a default of None to mean "the mode's setting").
    """

    name: str
    title: str
    runner: str
    modes: dict[str, str]
    minutes: dict[str, float] = field(default_factory=dict)
    arguments: str | None = None

    @property
    def plugin(self) -> str:
        """The package that provides it."""
        return self.runner.split(":")[0].split(".")[0]


@dataclass
class Row:
    """One line of the comparison: a quantity, the thesis's value, ours, and the tolerance within which a
    difference is not marked (None: not compared, e.g. a number the thesis does not give)."""

    quantity: str
    thesis: float | str | None
    ours: float | str | None
    tolerance: float | None = None
    unit: str = ""

    @property
    def difference(self) -> float | None:
        """``ours - thesis`` where both are numbers (None if either is missing or NaN: nothing to compare)."""
        if isinstance(self.thesis, (int, float)) and isinstance(self.ours, (int, float)):
            d = float(self.ours) - float(self.thesis)
            return None if math.isnan(d) else d
        return None

    @property
    def marked(self) -> bool:
        """Whether ours differs from the thesis's by more than the tolerance."""
        d = self.difference
        return self.tolerance is not None and d is not None and not (abs(d) <= self.tolerance)


@dataclass
class Headline:
    """A number CI checks: ours must lie in ``[low, high]`` (the documented tolerance), the thesis's beside it."""

    name: str
    ours: float
    low: float
    high: float
    thesis: float | None = None
    why: str = ""

    @property
    def ok(self) -> bool:
        """``low <= ours <= high`` (NaN is never within)."""
        return isinstance(self.ours, (int, float)) and self.low <= self.ours <= self.high


@dataclass
class Outcome:
    """What a runner returns: the table, the headline numbers, settings, raw records, figures and notes."""

    rows: list[Row]
    headlines: list[Headline]
    settings: dict
    records: list[Path] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    notes: str = ""


@dataclass
class ReproductionRun:
    """What a runner gets: the reproduction, the mode, the directory to write into, ``echo`` for progress,
    ``fresh``: forget the records on file (runners resume from them otherwise), and ``options``: the values of the
    reproduction's own options (:attr:`Reproduction.arguments`; None: the mode's setting)."""

    reproduction: Reproduction
    mode: str
    output: Path
    echo: Callable[[str], object] = print
    fresh: bool = False
    options: dict = field(default_factory=dict)

    def setting(self, name: str, default):
        """``options[name]`` if given (not None), else ``default`` (the mode's setting)."""
        value = self.options.get(name)
        return default if value is None else value


def reproductions() -> dict[str, Reproduction]:
    """Every reproduction the installed plugins declare, by name (a duplicate name: the first plugin's wins)."""
    from pliant.registry import default_registry

    found: dict[str, Reproduction] = {}
    for group in default_registry().call_isolated("pliant_reproductions"):
        for item in group or ():
            if isinstance(item, Reproduction) and item.name not in found:
                found[item.name] = item
    return found


def listing() -> list[dict]:
    """The catalogue and the plugins' reproductions: name, status (available / waiting), title, provider or what
    it waits for, modes."""
    available = reproductions()
    rows = []
    for name in dict.fromkeys([*CATALOGUE, *available]):
        if name in available:
            r = available[name]
            rows.append({"name": name, "status": "available", "title": r.title, "plugin": r.plugin,
                         "modes": [m for m in MODES if m in r.modes], "minutes": r.minutes})
        else:
            title, waits = CATALOGUE[name]
            package = waits.rsplit("(", 1)[-1].rstrip(")")
            if importlib.util.find_spec(package) is not None:
                waits = f"{waits}: installed, but it declares no reproduction of this yet"
            rows.append({"name": name, "status": "waiting", "title": title, "plugin": None,
                         "waits_for": waits, "modes": []})
    return rows


def _versions() -> dict:
    import numpy

    from pliant.version import __version__

    out = {"pliant": __version__, "python": platform.python_version(), "numpy": numpy.__version__,
           "machine": f"{platform.machine()} {platform.system()}"}
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=5,
                                cwd=Path(__file__).resolve().parent)
        if commit.returncode == 0:
            dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                                   text=True, timeout=5, cwd=Path(__file__).resolve().parent).stdout.strip()
            out["commit"] = commit.stdout.strip() + (" (with uncommitted changes)" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        pass
    return out


def _load(runner: str) -> Callable[[ReproductionRun], Outcome]:
    module, _, function = runner.partition(":")
    try:
        return getattr(importlib.import_module(module), function)
    except (ImportError, AttributeError) as exc:
        raise PluginError(f"cannot load the reproduction's runner: {exc}", field="runner", value=runner) from None


def _fmt(value, unit: str = "") -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        text = f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    else:
        text = str(value)
    return f"{text} {unit}".strip()


def render(reproduction: Reproduction, mode: str, outcome: Outcome, versions: dict, seconds: float,
           directory: Path) -> str:
    """The report as Markdown: the table (differences beyond tolerance in bold), headline checks, settings,
    versions, figures and raw records."""
    def rel(p: Path) -> str:
        try:
            return str(Path(p).resolve().relative_to(directory.resolve()))
        except ValueError:
            return str(p)

    lines = [f"# {reproduction.title}", "",
             f"`pliant experiment {reproduction.name}{'' if mode == 'full' else ' --' + mode}` -- mode **{mode}**: "
             f"{reproduction.modes.get(mode, '')}", "",
             f"Ran in {seconds:.0f} s.  Provided by the plugin `{reproduction.plugin}`.", "",
             "## Ours beside the thesis's", "",
             "| quantity | thesis | ours | difference | tolerance |", "| --- | --- | --- | --- | --- |"]
    for row in outcome.rows:
        d = row.difference
        diff = "-" if d is None else f"{d:+.3g}"
        if row.marked:
            diff = f"**{diff}**"
        lines.append(f"| {row.quantity} | {_fmt(row.thesis, row.unit)} | {_fmt(row.ours, row.unit)} | {diff} | "
                     f"{'-' if row.tolerance is None else _fmt(row.tolerance)} |")
    marked = sum(r.marked for r in outcome.rows)
    lines += ["", f"{marked} of {len(outcome.rows)} differences are beyond their tolerance (bold).", "",
              "## Headline numbers (checked)", "", "| number | ours | within | thesis | result | why this range |",
              "| --- | --- | --- | --- | --- | --- |"]
    for h in outcome.headlines:
        lines.append(f"| {h.name} | {_fmt(h.ours)} | [{_fmt(h.low)}, {_fmt(h.high)}] | {_fmt(h.thesis)} | "
                     f"{'ok' if h.ok else '**OUT OF RANGE**'} | {h.why} |")
    if outcome.notes:
        lines += ["", "## Notes", "", outcome.notes.strip()]
    if outcome.figures:
        lines += ["", "## Figures", ""] + [f"![{Path(f).stem}]({rel(f)})" for f in outcome.figures]
    lines += ["", "## Settings", "", "```", *(f"{k} = {v!r}" for k, v in outcome.settings.items()), "```", "",
              "## Versions", "", "```", *(f"{k} = {v}" for k, v in versions.items()), "```", "",
              "## Raw records", ""] + [f"- `{rel(p)}`" for p in outcome.records]
    return "\n".join(lines) + "\n"


def check_output(output: str | Path, flag: str = "--output") -> Path:
    """``output`` as a directory path a run may write into: an empty name (which would mean the current
    directory), a path holding a NUL, or an existing file is a :class:`ConfigError` naming ``flag``.  Whether it can
    be created and written is checked when it is."""
    text = str(output) if isinstance(output, Path) else output
    if not isinstance(text, str) or not text.strip():
        raise ConfigError("must name a directory (to write into the current one, say .)", field=flag, value=output)
    if "\x00" in text:
        raise ConfigError("must not hold a NUL character", field=flag, value=output)
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise ConfigError("is a file, not a directory", field=flag, value=text)
    for parent in path.parents:                 # the first one that exists must be a directory
        if parent.exists():
            if not parent.is_dir():
                raise ConfigError(f"cannot be created: {parent} is a file", field=flag, value=text)
            break
    return path


def run_reproduction(name: str, *, mode: str = "quick", output: Path = Path("out/reproduce"),
                     echo: Callable[[str], object] = print, fresh: bool = False,
                     options: dict | None = None) -> tuple[Outcome, Path]:
    """Run one reproduction; writes ``report.md`` and ``outcome.json`` into ``output/<name>/<mode>/``; returns the
    outcome and that directory.  ``options``: values of the reproduction's own options (``run.options``)."""
    if mode not in MODES:
        raise ConfigError(f"unknown mode (modes: {', '.join(MODES)})", field="mode", value=mode)
    available = reproductions()
    if name not in available:
        if name in CATALOGUE:
            waits = next(r["waits_for"] for r in listing() if r["name"] == name)
            raise ConfigError(f"not available yet: waits for {waits}", field="NAME", value=name)
        known = ", ".join(dict.fromkeys([*CATALOGUE, *available]))
        raise ConfigError(f"unknown reproduction (known: {known})", field="NAME", value=name)
    reproduction = available[name]
    if mode not in reproduction.modes:
        raise ConfigError(f"{name} has no {mode} mode (modes: {', '.join(reproduction.modes)})",
                          field=f"--{mode}", value=True)
    directory = Path(check_output(output)) / name / mode
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot be created ({exc.strerror or exc})", field="--output", value=str(output)) from None
    if not os.access(directory, os.W_OK | os.X_OK):
        raise ConfigError("is not writable", field="--output", value=str(output))
    runner = _load(reproduction.runner)
    echo(f"{name} ({mode}): {reproduction.modes[mode]}{_given(options)}")
    t0 = time.perf_counter()
    outcome = runner(ReproductionRun(reproduction, mode, directory, echo, fresh, dict(options or {})))
    seconds = time.perf_counter() - t0
    versions = _versions()
    write_text(directory / "report.md", render(reproduction, mode, outcome, versions, seconds, directory))
    write_json(directory / "outcome.json", {
        "name": name, "mode": mode, "seconds": seconds, "versions": versions, "settings": outcome.settings,
        "rows": [{**asdict(r), "difference": r.difference, "marked": r.marked} for r in outcome.rows],
        "headlines": [{**asdict(h), "ok": h.ok} for h in outcome.headlines],
        "records": [str(p) for p in outcome.records], "figures": [str(p) for p in outcome.figures]})
    return outcome, directory


def list_command(args) -> int:
    """``pliant experiment [list]``: the reproductions (available or waiting) and the plugins' other experiments
    (``args.experiments``: name -> help, filled in by the command line)."""
    rows = listing()
    others = getattr(args, "experiments", {}) or {}
    width = max([len(r["name"]) for r in rows] + [len(n) for n in others])
    for r in rows:
        if r["status"] == "available":
            modes = ", ".join(f"{m} ~{r['minutes'][m]:g} min" if m in r["minutes"] else m for m in r["modes"])
            print(f"{r['name']:<{width}}  available  {r['title']}  [{r['plugin']}; {modes}]")
        else:
            print(f"{r['name']:<{width}}  waiting    {r['title']}  [waits for {r['waits_for']}]")
    for name, text in others.items():
        print(f"{name:<{width}}  experiment {text}")
    return 0


def _given(options: dict | None) -> str:
    """The reproduction's own options that have a value (set by the user or by a default of the command line), as
    they would be typed (``"; with --plans 2 --jobs 2"``), or ``""``: the mode's description says what the mode does
    without them."""
    import shlex

    given = []
    for key, value in (options or {}).items():
        if value is None or value is False or value == [] or value == ():
            continue
        flag = "--" + key.replace("_", "-")
        values = value if isinstance(value, (list, tuple)) else [] if value is True else [value]
        given.append(" ".join([flag, *(shlex.quote(str(v)) for v in values)]))
    return f"; with {' '.join(given)}" if given else ""


def command(args) -> int:
    """``pliant experiment NAME [--quick | --ci] [--output DIR] [--fresh] [its own options]``: run one reproduction,
    print its headline checks; exit status 3 if one is out of range."""
    mode = "ci" if args.ci else "quick" if args.quick else "full"
    options = {dest: getattr(args, dest) for dest in getattr(args, "reproduction_options", ())}
    outcome, directory = run_reproduction(args.name, mode=mode, output=check_output(args.output), fresh=args.fresh,
                                          options=options)
    failed = [h for h in outcome.headlines if not h.ok]
    for h in outcome.headlines:
        print(f"  {h.name}: {_fmt(h.ours)} (within [{_fmt(h.low)}, {_fmt(h.high)}]: {'ok' if h.ok else 'NO'}; "
              f"thesis {_fmt(h.thesis)})")
    marked = sum(r.marked for r in outcome.rows)
    print(f"{len(outcome.rows)} rows, {marked} beyond tolerance; report: {directory / 'report.md'}")
    if failed:
        print(f"error: {len(failed)} headline number(s) out of range: {', '.join(h.name for h in failed)}",
              file=sys.stderr)
        return 3
    return 0
