"""The swap matrix: every bundled pipeline x every registered simulator x every robot that fits its space.

"Swap the simulator or the robot by changing one name" holds when each such combination either runs to an outcome
or is refused when the pipeline is built, with a one-line reason that names what does not fit.  This module
generates the combinations (nothing is listed by hand: a new pipeline file, simulator plugin or robot scene joins
at once) and tries each::

    from pliant.experiments.swap import swap_matrix
    for result in swap_matrix(["push-slide"]):
        print(result.cell.label, result.outcome, result.reason)

    python -m pliant.experiments.swap                       # the whole matrix, printed
    python -m pliant.experiments.swap --write               # and regenerate docs/swap-matrix.md and the tests'
                                                            # expectations (tests/e2e/swap_matrix.json)

The axes (docs/swap-matrix.md):

* **pipelines**: the bundled pipelines (:func:`pliant.pipeline.available_pipelines`);
* **simulators**: :func:`registry.available("simulator") <pliant.registry.available>`.  What is swapped is the world
  the pipeline executes in: ``execution.world=NAME`` when the pipeline names an ``[execution] world`` (its own
  ``simulator`` then plans, e.g. the belief planner's particles), else ``simulator=NAME``.  Either override replaces
  the component with its default options, as ``pliant run ... --set`` does.  A pipeline with neither a simulator nor
  a controller executes nothing: its cells are ``n/a``.  The cell of the pipeline's own simulator is the pipeline as
  bundled (no override);
* **robots**: for a pipeline whose scene has a URDF robot, every (model, group) the bundled scenes use (their
  ``[robot]`` and a robot-independent task's ``[task.robots.NAME]``), swapped by ``robot.model=M`` and
  ``robot.group=G``; for a rigid-body scene, the scene's own robot only.

Each cell is built (:meth:`Pipeline.build`, then its execution world as :meth:`Pipeline.run` creates it), except
that with ``build="swapped"`` (the default) a cell that swaps nothing but the execution world builds only that world
(with the pipeline's scene and robot): the rest of it is the bundled pipeline, which its own tests build, and
building it again for every world is most of the matrix's cost.  In quick mode (the default) the cells whose plan is
given -- a planner that needs no budget (no ``[planning]`` table, e.g.
``waypoints``) and no learner -- also run, with ``execution.time_limit`` capped at :data:`QUICK_TIME_LIMIT` s of
simulated time; the others stop after the build.  ``run="all"`` runs every cell that builds, with the work budget
``max_iterations``.  Builds share the core's scene-preprocessing cache (:mod:`pliant.cache`), and the cells that
differ only in the execution world share one build of the rest of the pipeline.

Outcomes: ``builds`` (built, not run), a run's :class:`~pliant.results.Outcome` (``reached``, ``stuck``, ``planned``,
``not planned``), ``refused`` (a :class:`~pliant.errors.PliantError` with a one-line message naming a file or field,
while building; "refused at run" in the table when it came from a later stage of a run), ``n/a``, and the two that
are defects: ``failed`` (the execution raised) and ``defect`` (anything else: an exception that is not a PliantError,
a message of several lines, over :data:`MAX_REASON` characters, or naming no file or field).  Reasons are one line,
with absolute paths cut to the file name.
"""

from __future__ import annotations

import argparse
import json
import logging
import re
import resource
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pliant.errors import PliantError
from pliant.pipeline import Pipeline, available_pipelines
from pliant.registry import Registry, default_registry
from pliant.results import Outcome
from pliant.scene import available_scenes, load_scene

log = logging.getLogger(__name__)

#: simulated seconds an execution may take in quick mode
QUICK_TIME_LIMIT = 30.0
#: the longest refusal counted as one clear line (characters, after paths are shortened)
MAX_REASON = 400
#: outcomes that break "runs to an outcome or is refused at build time with a one-line reason"
BAD_OUTCOMES = ("failed", "defect")
#: the robot label of a rigid-body pipeline's row
SCENE_ROBOT = "scene robot"
#: where ``--write`` puts the table and the tests' expectations (relative to the repository)
DOCS_FILE = Path("docs/swap-matrix.md")
EXPECTATIONS_FILE = Path("tests/e2e/swap_matrix.json")
COMMAND = "python -m pliant.experiments.swap --write"


@dataclass(frozen=True)
class Cell:
    """One combination: a bundled ``pipeline``, a ``simulator`` (the execution world), a ``robot`` (``"model
    group"`` for URDF robots, :data:`SCENE_ROBOT` for the scene's own) and the ``overrides`` that make it."""

    pipeline: str
    simulator: str
    robot: str
    overrides: tuple[str, ...] = ()
    swap_key: str = "simulator"          # "simulator", "execution.world", or "" (the pipeline executes nothing)

    @property
    def label(self) -> str:
        return f"{self.pipeline} | {self.simulator} | {self.robot}"


@dataclass
class CellResult:
    """What one cell did: ``outcome`` (module docstring), a one-line ``reason`` (empty when it built or reached),
    the ``stage`` it ended in (``build``, ``run`` or ``none``) and the CPU seconds it took (``cpu``, not compared)."""

    cell: Cell
    outcome: str
    reason: str = ""
    stage: str = "build"
    cpu: float = 0.0

    @property
    def bad(self) -> bool:
        return self.outcome in BAD_OUTCOMES

    def key(self) -> dict[str, str]:
        """What the tests compare: outcome and reason (numbers in a run's reason masked: they may move in the last
        digits between platforms; a refusal's reason is compared as written)."""
        reason = self.reason if self.stage != "run" else re.sub(r"\d+(\.\d+)?", "#", self.reason)
        return {"outcome": self.outcome, "reason": reason}

    def to_dict(self) -> dict[str, Any]:
        return {"pipeline": self.cell.pipeline, "simulator": self.cell.simulator, "robot": self.cell.robot,
                "overrides": list(self.cell.overrides), "outcome": self.outcome, "reason": self.reason,
                "stage": self.stage}


# --- the axes --------------------------------------------------------------------------------------------------------


def urdf_robots() -> list[tuple[str, str]]:
    """Every (model, group) the bundled scenes use for a URDF robot: their ``[robot]`` and the robots a
    robot-independent task names (``[task.robots.NAME]``: its group, and every group its ``tool`` table names),
    sorted."""
    found: set[tuple[str, str]] = set()
    for name in available_scenes():
        try:
            raw = load_scene(name).raw
        except PliantError as exc:          # a broken bundled scene is its own tests' business; say so and go on
            log.warning("swap matrix: scene %s not read: %s", name, exc)
            continue
        robot = raw.get("robot") or {}
        if robot.get("kind") != "urdf":
            continue
        if isinstance(robot.get("model"), str) and isinstance(robot.get("group"), str):
            found.add((robot["model"], robot["group"]))
        robots = (raw.get("task") or {}).get("robots") or {}
        for model, table in robots.items() if isinstance(robots, dict) else ():
            if not isinstance(table, dict):
                continue
            if isinstance(table.get("group"), str):
                found.add((model, table["group"]))
            if isinstance(table.get("tool"), dict):         # a tool frame per group: each of those groups
                found.update((model, group) for group in table["tool"] if isinstance(group, str))
    return sorted(found)


def _swap_key(pipeline: Pipeline) -> str:
    """The override that swaps where ``pipeline`` executes: ``execution.world``, ``simulator``, or ``""``."""
    if pipeline.world_settings.get("world") is not None:
        return "execution.world"
    if "simulator" in pipeline.components or "controller" in pipeline.components:
        return "simulator"
    return ""


def _own_simulator(pipeline: Pipeline, key: str) -> str | None:
    if key == "execution.world":
        return pipeline.world_settings["world"].name
    spec = pipeline.components.get("simulator")
    return spec.name if spec is not None else None


def _own_robot(raw: dict) -> tuple[Any, Any]:
    """The (model, group) a scene file sets up: its ``[robot]``, the group from its task's entry for that model."""
    robot = raw.get("robot") or {}
    model, group = robot.get("model"), robot.get("group")
    entry = ((raw.get("task") or {}).get("robots") or {}).get(model)
    if group is None and isinstance(entry, dict):
        group = entry.get("group")
    return model, group


def cells(pipelines: list[str] | None = None, simulators: list[str] | None = None,
          registry: Registry | None = None) -> list[Cell]:
    """The matrix's cells, in order: ``pipelines`` (default every bundled one) x ``simulators`` (default every
    registered one) x the robots that fit each pipeline's scene."""
    registry = registry or default_registry()
    simulators = list(simulators) if simulators is not None else registry.available("simulator")
    robots = None
    out: list[Cell] = []
    for name in pipelines if pipelines is not None else available_pipelines():
        pipeline = Pipeline.from_file(name, registry=registry)
        key = _swap_key(pipeline)
        own_world = _own_simulator(pipeline, key)
        scene = pipeline.load_scene()
        if scene.robot.kind == "urdf":
            robots = robots if robots is not None else urdf_robots()
            own = _own_robot(scene.raw)
            rows = [(f"{model} {group}", () if (model, group) == own else
                     (f"robot.model={model}", f"robot.group={group}")) for model, group in robots]
        else:
            rows = [(SCENE_ROBOT, ())]
        for robot, robot_overrides in rows:
            for simulator in simulators:
                swap = () if not key or simulator == own_world else (f"{key}={simulator}",)
                out.append(Cell(name, simulator, robot, (*robot_overrides, *swap), key))
    return out


# --- trying a cell ---------------------------------------------------------------------------------------------------


def one_line(text: str) -> str:
    """``text`` with absolute paths cut to their last part (the bundled scenes' ``pipelines/`` kept)."""
    text = re.sub(r"(?:/[\w.+@-]+)*/scenes/(pipelines/)?([\w.+@-]+)", r"\1\2", str(text))
    return re.sub(r"(?:/[\w.+@-]+)+/([\w.+@-]+)", r"\1", text)


def _refusal(exc: BaseException, stage: str) -> tuple[str, str]:
    """(outcome, reason) of an exception raised at ``stage``: ``refused`` for a clear PliantError, else ``defect``."""
    if isinstance(exc, PliantError):
        text = one_line(str(exc))
        if "\n" in text.strip():
            return "defect", f"a message of several lines at {stage}: " + text.strip().replace("\n", " / ")[:300]
        if len(text) > MAX_REASON:
            return "defect", f"a message of {len(text)} characters at {stage}: {text[:200]}..."
        if not exc.source and not exc.field:
            return "defect", f"a message naming no file or field at {stage}: {text}"
        return "refused", text
    first = one_line(str(exc)).strip().splitlines()
    return "defect", f"{type(exc).__name__} at {stage}: {first[0][:300] if first else ''}"


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _build(pipeline: Pipeline, base: Any = None) -> Any:
    """Build ``pipeline`` as :meth:`Pipeline.run` does: its components, then its execution world; ``base``: the
    context of an earlier build of the same pipeline but for the execution world, reused."""
    pipeline.check_execution()
    context = base if base is not None else pipeline.build()
    if context.controller is not None and (context.simulator is not None or pipeline.world_settings.get("world")):
        pipeline.execution_world(context)
    return context


def _runs_in_quick_mode(pipeline: Pipeline) -> bool:
    """Whether a quick matrix runs this pipeline: its plan is given (a planner without a budget, no learner) and
    it executes."""
    budget = pipeline.budget
    return ("planner" in pipeline.components and "learner" not in pipeline.components
            and "controller" in pipeline.components and budget.max_iterations is None and budget.max_time is None)


def try_cell(cell: Cell, *, run: str = "quick", build: str = "swapped", max_iterations: int = 1,
             registry: Registry | None = None, _bases: dict | None = None) -> CellResult:
    """Build ``cell`` (``build``: ``"swapped"``, what the swap changes; ``"all"``, the whole pipeline) and, as ``run``
    says (``"none"``, ``"quick"``, ``"all"``), run it; never raises (but Ctrl-C)."""
    t0 = _cpu()
    result = _try(cell, run, build, max_iterations, registry or default_registry(),
                  _bases if _bases is not None else {})
    result.cpu = _cpu() - t0
    return result


def _try(cell: Cell, run: str, build: str, max_iterations: int, registry: Registry, bases: dict) -> CellResult:
    if not cell.swap_key:
        return CellResult(cell, "n/a", "executes nothing (no simulator, no controller)", "none")
    try:
        pipeline = Pipeline.from_file(cell.pipeline, overrides=list(cell.overrides), registry=registry)
    except PliantError as exc:
        return CellResult(cell, *_refusal(exc, "build"))
    # the cells of one pipeline and robot that differ in the execution world only share the rest of the build
    shared = cell.swap_key == "execution.world"
    robot_key = (cell.pipeline, tuple(o for o in cell.overrides if not o.startswith("execution.world=")))
    world_only = shared and build == "swapped" and not robot_key[1]
    try:
        if world_only:                  # the rest is the bundled pipeline (built by its own tests): the world only
            pipeline.check_execution()
            pipeline.execution_world(None)
        elif shared and robot_key in bases:
            base = bases[robot_key]
            if isinstance(base, BaseException):
                raise base
            _build(pipeline, base)
        elif shared:
            try:
                base = Pipeline.from_file(cell.pipeline, overrides=list(robot_key[1]), registry=registry).build()
            except Exception as exc:
                bases[robot_key] = exc
                raise
            bases[robot_key] = base
            _build(pipeline, base)
        else:
            _build(pipeline)
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        return CellResult(cell, *_refusal(exc, "build"))
    if run == "none" or (run == "quick" and not _runs_in_quick_mode(pipeline)):
        return CellResult(cell, "builds", "", "build")
    limit = min(pipeline.execution["time_limit"], QUICK_TIME_LIMIT) if run == "quick" else None
    overrides = list(cell.overrides)
    if limit is not None:
        overrides.append(f"execution.time_limit={limit}")
    if run == "all" and pipeline.budget.max_iterations is not None:
        overrides.append(f"planning.max_iterations={max_iterations}")
    try:
        record = Pipeline.from_file(cell.pipeline, overrides=overrides, registry=registry).run(write=False)
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        outcome, reason = _refusal(exc, "run")
        return CellResult(cell, outcome, reason, "run")
    outcome = record.outcome
    reason = one_line(record.error).strip().replace("\n", " / ")
    if outcome is Outcome.FAILED:
        return CellResult(cell, "failed", reason, "run")
    return CellResult(cell, outcome.value, reason if outcome not in (Outcome.REACHED, Outcome.PLANNED) else "", "run")


def swap_matrix(pipelines: list[str] | None = None, simulators: list[str] | None = None, *, run: str = "quick",
                build: str = "swapped", max_iterations: int = 1, registry: Registry | None = None,
                progress: Any = None) -> list[CellResult]:
    """Try every cell of :func:`cells` (module docstring); ``progress(result)`` is called after each."""
    if run not in ("none", "quick", "all"):
        raise ValueError(f"run must be none, quick or all (got {run!r})")
    if build not in ("swapped", "all"):
        raise ValueError(f"build must be swapped or all (got {build!r})")
    registry = registry or default_registry()
    bases: dict = {}
    out = []
    for cell in cells(pipelines, simulators, registry):
        result = try_cell(cell, run=run, build=build, max_iterations=max_iterations, registry=registry,
                          _bases=bases)
        out.append(result)
        if progress is not None:
            progress(result)
    return out


# --- the table and the expectations ----------------------------------------------------------------------------------


def expectations(results: list[CellResult]) -> dict[str, dict[str, str]]:
    """``{cell label: {"outcome", "reason"}}``: what ``tests/e2e/test_swap_matrix.py`` compares."""
    return {r.cell.label: r.key() for r in results}


def markdown(results: list[CellResult]) -> str:
    """The matrix as markdown: one row per pipeline and robot, one column per simulator; each reason once, numbered
    below the table; the defects listed."""
    simulators = list(dict.fromkeys(r.cell.simulator for r in results))
    rows: dict[tuple[str, str], dict[str, CellResult]] = {}
    for r in results:
        rows.setdefault((r.cell.pipeline, r.cell.robot), {})[r.cell.simulator] = r
    reasons: dict[str, int] = {}

    def text(r: CellResult | None) -> str:
        if r is None:
            return ""
        shown = f"**{r.outcome}**" if r.bad else r.outcome
        if r.outcome == "refused" and r.stage == "run":
            shown += " at run"
        if r.cell.overrides == () and r.outcome != "n/a":
            shown += " (as bundled)"
        if r.reason:
            shown += f" [{reasons.setdefault(r.reason, len(reasons) + 1)}]"
        return shown

    lines = ["| pipeline | robot | swapped by | " + " | ".join(simulators) + " |",
             "| --- | --- | --- | " + " | ".join("---" for _ in simulators) + " |"]
    for (pipeline, robot), by_simulator in rows.items():
        first = next(iter(by_simulator.values())).cell
        robot_text = robot if robot == SCENE_ROBOT or not any(
            o.startswith("robot.") for o in first.overrides) else robot + " (`robot.model`, `robot.group`)"
        lines.append(f"| {pipeline} | {robot_text} | {f'`{first.swap_key}`' if first.swap_key else '-'} | "
                     + " | ".join(text(by_simulator.get(s)) for s in simulators) + " |")
    lines += ["", "Reasons:", ""]
    lines += [f"{n}. {_escape(reason)}" for reason, n in reasons.items()]
    bad = [r for r in results if r.bad]
    lines += ["", "Cells that fail badly (after the build, or without a clear one-line reason):", ""]
    lines += [f"- {r.cell.label}: {r.outcome}: {_escape(r.reason)}" for r in bad] or ["- none"]
    return "\n".join(lines) + "\n"


def _escape(text: str) -> str:
    return text.replace("|", "\\|").replace("<", "&lt;")


def write_docs(results: list[CellResult], path: Path) -> None:
    """Replace the generated part of the docs page (between its two markers) with :func:`markdown`."""
    begin, end = "<!-- swap-matrix: begin (generated) -->", "<!-- swap-matrix: end -->"
    page = path.read_text()
    head, _, rest = page.partition(begin)
    _, _, tail = rest.partition(end)
    if not rest:
        raise ValueError(f"{path} has no {begin!r} marker")
    path.write_text(f"{head}{begin}\n{markdown(results)}{end}{tail}")


def write_expectations(results: list[CellResult], path: Path) -> None:
    """Write the tests' expectations (:func:`expectations`, with the command that regenerates them) to ``path`` as
    JSON."""
    path.write_text(json.dumps({"command": COMMAND, "cells": expectations(results)}, indent=1, sort_keys=True) + "\n")


def _names(text: str | None) -> list[str] | None:
    return [x.strip() for x in text.split(",") if x.strip()] if text else None


def main(argv: list[str] | None = None) -> int:
    """``python -m pliant.experiments.swap``: try every cell of the matrix (or of the ``--pipelines`` / ``--simulators``
    given) and print each; ``--write`` also regenerates :data:`DOCS_FILE` and :data:`EXPECTATIONS_FILE`."""
    parser = argparse.ArgumentParser(prog="python -m pliant.experiments.swap", description=__doc__.split("\n")[0])
    parser.add_argument("--pipelines", help="comma-separated bundled pipelines (default every one)")
    parser.add_argument("--simulators", help="comma-separated simulators (default every registered one)")
    parser.add_argument("--run", choices=("none", "quick", "all"), default="quick",
                        help="none: build only; quick (default): also run the cells whose plan is given; all: run "
                             "every cell that builds, with --max-iterations")
    parser.add_argument("--build", choices=("swapped", "all"), default="swapped",
                        help="swapped (default): a cell that swaps only the execution world builds that world; all: "
                             "every cell builds its whole pipeline")
    parser.add_argument("--max-iterations", type=int, default=1, help="the work budget of --run all (default 1)")
    parser.add_argument("--write", action="store_true",
                        help=f"write the table into {DOCS_FILE} and the expectations to {EXPECTATIONS_FILE} "
                             "(run from the repository; the whole quick matrix only)")
    args = parser.parse_args(argv)
    if args.write and (args.pipelines or args.simulators or args.run != "quick" or args.build != "swapped"):
        parser.error("--write regenerates the whole quick matrix: drop --pipelines, --simulators, --run, --build")
    total = 0.0

    def show(result: CellResult) -> None:
        nonlocal total
        total += result.cpu
        print(f"{result.cpu:6.2f} s  {result.cell.label:60s} {result.outcome}"
              + (f": {result.reason}" if result.reason else ""), flush=True)

    results = swap_matrix(_names(args.pipelines), _names(args.simulators), run=args.run,
                          build=args.build, max_iterations=args.max_iterations, progress=show)
    bad = [r for r in results if r.bad]
    print(f"{len(results)} cells, {total:.1f} CPU s; {len(bad)} fail badly")
    if args.write:
        write_docs(results, DOCS_FILE)
        write_expectations(results, EXPECTATIONS_FILE)
        print(f"wrote {DOCS_FILE} and {EXPECTATIONS_FILE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
