"""Benchmarks from a file (``pliant bench FILE.toml``, issue 35 part 4): a grid of planners (pliant's and OMPL's
through the ``ompl`` planner) x problems x seeds x budgets, run on the core's executor (resumable, parallel), written
as OMPL benchmark logs, the SQLite database OMPL's ``ompl_benchmark_statistics`` builds from them (Planner Arena reads
it), and a report (markdown table and plots).  docs/benchmarking.md describes the file format.

Every cell (problem, planner, budget, seed) is one task: the problem's pipeline with the cell's planner, its
``[planning]`` table the budget and its ``seed`` the seed, planned as ``pliant run`` plans it (the planner draws from
the run's ``planning`` stream, :mod:`pliant.seeds`), without metric, controller or execution.  So a cell is
reproduced by ``pliant run`` on the same pipeline with ``--set seed=S`` and the planner's options.  Every solved path
is judged the same way for every planner: pliant's validity check of the whole path (``PlanningProblem.path_verdict``)
and the cost ``path integral of the state cost (at the scene's resolution) + length_weight x path length``.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import hashlib
import json
import math
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pliant.errors import ConfigError, PliantError
from pliant.files import dumps, write_json, write_text
from pliant.validation import read_toml, safe_name

__all__ = ["BenchFile", "load_benchfile", "main", "parse_benchfile", "run_benchfile", "run_cell", "write_outputs"]

TOP_KEYS = ("name", "description", "output", "seeds", "problems", "planners", "budgets")
PROBLEM_KEYS = ("name", "scene", "pipeline", "set", "length_weight")
#: the component tables a problem may give (with a scene); the planner is the grid's
PROBLEM_COMPONENTS = ("robot", "cost", "simulator")
#: pipeline parts a benchmark cell never runs (it plans only)
NOT_PLANNING = ("execution", "controller", "metric", "trajectory", "learner", "driver")
#: record fields that depend on the machine's speed, not on the seed and the budget
WALL_TIME_FIELDS = ("time", "time_to_first", "progress", "seconds")


@dataclass(frozen=True)
class Problem:
    """A problem of a benchmark file (``[[problems]]``): its ``name`` in tables, its pipeline table ``data`` (scene and
    components, the ``set`` overrides applied), the ``source`` file and the ``base_dir`` its paths are relative to,
    and ``length_weight``, the judged cost's weight per unit of path length."""
    name: str
    data: dict                    # the pipeline table (scene, components), overrides applied
    source: str
    base_dir: str
    length_weight: float


@dataclass(frozen=True)
class PlannerSpec:
    """A planner of a benchmark file (``[[planners]]``): its ``label`` in tables, the planner's registered ``name`` and
    its ``options`` (checked by creating the planner)."""
    label: str
    name: str
    options: dict
    #: the planner declares a ``length_weight`` option the file leaves unset: it gets the problem's
    weighs_length: bool = False


@dataclass(frozen=True)
class BudgetSpec:
    """A budget of a benchmark file (``[[budgets]]``): its ``label`` in tables (default e.g. ``"1000 it, 120 s"``) and
    ``table``, a cell's ``[planning]`` table (``max_iterations``, ``max_time`` in s, ``stop_on_first``)."""
    label: str
    table: dict


@dataclass
class BenchFile:
    """A parsed benchmark file: the grid and where it goes."""

    name: str
    source: str
    output: Path
    seeds: list[int]
    problems: list[Problem]
    planners: list[PlannerSpec]
    budgets: list[BudgetSpec]
    description: str = ""
    cells: list[dict] = field(default_factory=list)

    def grid(self) -> list[dict]:
        """Every cell, problems outermost, then budgets, planners, seeds; each cell a JSON-able dict (the task's
        argument) with its ``key`` and ``definition`` (a hash of everything its result depends on)."""
        out = []
        for problem in self.problems:
            for budget in self.budgets:
                for planner in self.planners:
                    for seed in self.seeds:
                        cell = {"problem": problem.name, "planner": planner.label, "budget": budget.label,
                                "seed": seed, "pipeline": cell_pipeline(problem, planner, budget, seed),
                                "source": problem.source, "base_dir": problem.base_dir,
                                "length_weight": problem.length_weight}
                        cell["key"] = cell_key(cell)
                        cell["definition"] = hashlib.sha256(dumps({k: cell[k] for k in (
                            "pipeline", "length_weight")}, sort_keys=True).encode()).hexdigest()[:16]
                        out.append(cell)
        return out


def cell_key(cell: dict) -> str:
    """The cell's key in the records: ``"problem | planner | budget | seed S"``."""
    return f"{cell['problem']} | {cell['planner']} | {cell['budget']} | seed {cell['seed']}"


def cell_pipeline(problem: Problem, planner: PlannerSpec, budget: BudgetSpec, seed: int) -> dict:
    """The pipeline table of one cell: the problem's without the parts a benchmark never runs (:data:`NOT_PLANNING`),
    with the cell's planner (given the problem's ``length_weight`` when it weighs length), its budget as the
    ``[planning]`` table and its seed."""
    data = copy.deepcopy(problem.data)
    for key in NOT_PLANNING:
        data.pop(key, None)
    data["name"] = safe_name(f"{problem.name}-{planner.label}-s{seed}")
    data["planner"] = {"name": planner.name, **planner.options}
    if planner.weighs_length:
        data["planner"]["length_weight"] = problem.length_weight
    data["planning"] = dict(budget.table)
    data["seed"] = seed
    return data


# --- the file ----------------------------------------------------------------------------------------------------


def _error(source: str, field_: str, message: str, value: Any = ...) -> ConfigError:
    return ConfigError(message, source=source, field=field_, **({} if value is ... else {"value": value}))


def _label(value: Any, source: str, field_: str) -> str:
    if not isinstance(value, str) or not value.strip() or any(c in value for c in "|\n;"):
        raise _error(source, field_, "must be a non-empty string without '|', ';' or a line break", value)
    return value.strip()


def _table(value: Any, source: str, field_: str) -> dict:
    if not isinstance(value, dict):
        raise _error(source, field_, "must be a table", value)
    return value


def _unknown(table: dict, allowed: tuple[str, ...], source: str, prefix: str) -> None:
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise _error(source, f"{prefix}{unknown[0]}", f"not a known field (fields: {', '.join(allowed)})",
                     table[unknown[0]])


def _seeds(value: Any, source: str) -> list[int]:
    if isinstance(value, bool):
        raise _error(source, "seeds", "must be a count (seeds 0..N-1) or a list of distinct seeds >= 0", value)
    if isinstance(value, int):
        if not 1 <= value <= 100_000:
            raise _error(source, "seeds", "a count must be 1..100000", value)
        return list(range(value))
    if isinstance(value, list) and value:
        for k, s in enumerate(value):
            if isinstance(s, bool) or not isinstance(s, int) or s < 0:
                raise _error(source, f"seeds[{k}]", "must be an integer >= 0", s)
        if len(set(value)) != len(value):
            raise _error(source, "seeds", "has a seed twice", value)
        return list(value)
    raise _error(source, "seeds", "must be a count (seeds 0..N-1) or a non-empty list of seeds >= 0", value)


def _array(data: dict, key: str, source: str) -> list[dict]:
    value = data.get(key)
    if value is None:
        raise _error(source, key, f"is missing: give at least one [[{key}]] table")
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list) or not value:
        raise _error(source, key, f"must be a non-empty array of tables ([[{key}]])", value)
    for k, item in enumerate(value):
        _table(item, source, f"{key}[{k}]")
    return value


def _problem(k: int, table: dict, source: str, base_dir: Path) -> Problem:
    from pliant.pipeline import _resolve_pipeline_path, apply_overrides
    from pliant.scene import available_scenes

    prefix = f"problems[{k}]."
    _unknown(table, PROBLEM_KEYS + PROBLEM_COMPONENTS, source, prefix)
    if ("scene" in table) == ("pipeline" in table):
        raise _error(source, f"problems[{k}]", "give exactly one of scene (a scene name or file) and pipeline (a "
                     "pipeline name or file)", dict(table))
    length_weight = table.get("length_weight", 0.0)
    if isinstance(length_weight, bool) or not isinstance(length_weight, (int, float)) \
            or not math.isfinite(length_weight) or length_weight < 0:
        raise _error(source, prefix + "length_weight", "must be a finite number >= 0", length_weight)
    if "pipeline" in table:
        for kind in PROBLEM_COMPONENTS:
            if kind in table:
                raise _error(source, prefix + kind, "a pipeline problem takes its components from the pipeline; "
                             "change them with set = [\"KIND.OPTION=VALUE\", ...]", table[kind])
        spec = table["pipeline"]
        if not isinstance(spec, str) or not spec:
            raise _error(source, prefix + "pipeline", "must be a pipeline name or file", spec)
        candidate = base_dir / spec
        try:
            path = _resolve_pipeline_path(candidate if candidate.is_file() else spec)
        except ConfigError as exc:
            raise _error(source, prefix + "pipeline", exc.message, spec) from None
        data = read_toml(path, ConfigError)
        pipeline_source, pipeline_dir = str(path), path.parent
        default_name = data.get("name") if isinstance(data.get("name"), str) else path.stem
    else:
        spec = table["scene"]
        if not isinstance(spec, str) or not spec:
            raise _error(source, prefix + "scene", "must be a scene name or file", spec)
        if not (base_dir / spec).is_file() and spec not in available_scenes():
            raise _error(source, prefix + "scene", f"no scene file or bundled scene of that name (bundled: "
                         f"{', '.join(available_scenes())})", spec)
        data = {"scene": spec}
        for kind in PROBLEM_COMPONENTS:
            if kind in table:
                component = table[kind]
                if not isinstance(component, (str, dict)):
                    raise _error(source, prefix + kind, "must be a component name or a table with name and options",
                                 component)
                data[kind] = component
        pipeline_source, pipeline_dir = source, base_dir
        default_name = Path(spec).stem
    overrides = table.get("set", [])
    if isinstance(overrides, dict):
        overrides = [f"{key}={json.dumps(value)}" for key, value in overrides.items()]
    if not isinstance(overrides, list) or not all(isinstance(o, str) for o in overrides):
        raise _error(source, prefix + "set", "must be a list of \"KEY=VALUE\" strings (as pliant run --set) or a "
                     "table of them", table.get("set"))
    try:
        data = apply_overrides(data, overrides, source)
    except ConfigError as exc:
        raise _error(source, f"{prefix}set: {exc.field}", exc.message, exc.value if exc.has_value else ...) \
            from None
    if "goal" in data:
        raise _error(source, prefix + "pipeline", "goals given as a pose ([goal]) are not benchmarked yet; give the "
                     "goal as the scene's configuration", spec)
    name = _label(table.get("name", default_name), source, prefix + "name")
    return Problem(name, data, pipeline_source, str(pipeline_dir), float(length_weight))


def _planner(k: int, table: dict, source: str) -> PlannerSpec:
    from pliant.registry import default_registry

    prefix = f"planners[{k}]."
    options = {key: value for key, value in table.items() if key not in ("name", "label")}
    name = table.get("name")
    if not isinstance(name, str) or not name:
        raise _error(source, prefix + "name", "must be a planner name (pliant plugins --kind planner)", name)
    for key in ("max_time", "max_iterations", "seed"):
        if key in options:
            raise _error(source, prefix + key, "the budget and the seed are the grid's ([[budgets]], seeds), not a "
                         "planner option", options[key])
    try:        # the options are the planner's own checks: an unknown name or a bad value, named
        component = default_registry().create("planner", name, source=source, **options)
    except PliantError as exc:
        field_ = prefix + (exc.field.removeprefix("planner.") if exc.field and exc.field != "planner" else "name")
        raise _error(source, field_, exc.message, exc.value if exc.has_value else ...) from None
    default = f"ompl-{options['algorithm']}" if name == "ompl" and "algorithm" in options else name
    declared = getattr(type(component), "Options", None)
    weighs = "length_weight" not in options and dataclasses.is_dataclass(declared) and \
        "length_weight" in {f.name for f in dataclasses.fields(declared)}
    return PlannerSpec(_label(table.get("label", default), source, prefix + "label"), name, options, weighs)


def _budget(k: int, table: dict, source: str) -> BudgetSpec:
    from pliant.termination import BUDGET_KEYS, Budget

    prefix = f"budgets[{k}]."
    options = {key: value for key, value in table.items() if key != "label"}
    unknown = sorted(set(options) - set(BUDGET_KEYS))
    if unknown:
        raise _error(source, prefix + unknown[0], f"not a known field (fields: label, {', '.join(BUDGET_KEYS)})",
                     options[unknown[0]])
    try:
        budget = Budget.from_table(options)
    except ConfigError as exc:
        raise _error(source, prefix + str(exc.field).removeprefix("planning."), exc.message,
                     exc.value if exc.has_value else ...) from None
    if budget.max_iterations is None and budget.max_time is None:
        raise _error(source, f"budgets[{k}]", "needs max_iterations (the work budget: what a result depends on) "
                     "and/or max_time (a wall-clock cap)", dict(table))
    parts = ([f"{budget.max_iterations} it"] if budget.max_iterations is not None else []) + \
            ([f"{budget.max_time:g} s"] if budget.max_time is not None else [])
    return BudgetSpec(_label(table.get("label", ", ".join(parts)), source, prefix + "label"), options)


def parse_benchfile(data: dict, *, source: str = "<dict>", base_dir: Path | None = None,
                    output: str | Path | None = None) -> BenchFile:
    """A :class:`BenchFile` from a parsed TOML table; every field checked (a :class:`ConfigError` naming the file,
    the field and the value).  ``output`` replaces the file's ``output``."""
    base_dir = Path(base_dir or Path.cwd())
    _table(data, source, "<top>")
    _unknown(data, TOP_KEYS, source, "")
    name = _label(data.get("name", Path(source).stem if source.endswith(".toml") else "benchmark"), source, "name")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise _error(source, "description", "must be a string", description)
    out = output if output is not None else data.get("output", f"out/bench/{safe_name(name)}")
    if not isinstance(out, (str, Path)) or not str(out).strip() or "\0" in str(out):
        raise _error(source, "output", "must be a directory path", out)
    if "seeds" not in data:
        raise _error(source, "seeds", "is missing: a count (seeds 0..N-1) or a list of seeds")
    seeds = _seeds(data["seeds"], source)
    problems = [_problem(k, t, source, base_dir) for k, t in enumerate(_array(data, "problems", source))]
    planners = [_planner(k, t, source) for k, t in enumerate(_array(data, "planners", source))]
    budgets = [_budget(k, t, source) for k, t in enumerate(_array(data, "budgets", source))]
    for what, items in (("problems", problems), ("planners", planners), ("budgets", budgets)):
        labels = [getattr(item, "label", getattr(item, "name", None)) for item in items]
        for k, label in enumerate(labels):
            if label in labels[:k]:
                raise _error(source, f"{what}[{k}].{'name' if what == 'problems' else 'label'}",
                             "is used twice: give each a distinct name", label)
    return BenchFile(name, source, Path(out), seeds, problems, planners, budgets, description)


def load_benchfile(path: str | Path, *, output: str | Path | None = None) -> BenchFile:
    """Read and check a benchmark file (TOML)."""
    path = Path(path)
    data = read_toml(path, ConfigError)
    return parse_benchfile(data, source=str(path), base_dir=path.parent, output=output)


def check_grid(bench: BenchFile) -> None:
    """Build every problem once and check that every planner can plan on it (a planner without the simulator or
    the cost model it needs, or of another space, is an error naming the problem and the planner) -- before any
    cell runs."""
    from pliant.components.planner import check_planner
    from pliant.pipeline import Pipeline
    from pliant.registry import default_registry

    for problem in bench.problems:
        data = cell_pipeline(problem, bench.planners[0], bench.budgets[0], bench.seeds[0])
        data.pop("planner")
        context = Pipeline.from_dict(data, source=problem.source, base_dir=Path(problem.base_dir)).build()
        for k, planner in enumerate(bench.planners):
            component = default_registry().create("planner", planner.name, source=bench.source, **planner.options)
            try:
                check_planner(component, context, source=bench.source)
            except PliantError as exc:
                raise _error(bench.source, f"planners[{k}]", f"cannot plan on problem '{problem.name}': "
                             f"{exc.message}", planner.label) from None


# --- one cell ----------------------------------------------------------------------------------------------------


def run_cell(cell: dict) -> dict:
    """Plan one cell (the task function: seeded, idempotent) and judge its path; returns its record."""
    import numpy as np

    from pliant.pipeline import Pipeline
    from pliant.results import Status

    t0 = time.perf_counter()
    pipeline = Pipeline.from_dict(cell["pipeline"], source=cell["source"], base_dir=Path(cell["base_dir"]))
    run = pipeline.run(write=False)
    result, problem = run.result, run.problem
    stats = result.statistics
    record = {k: cell[k] for k in ("key", "problem", "planner", "budget", "seed", "definition")}
    # solved: an exact solution (an approximate one is OMPL's "approximate solution", not counted as solved)
    record.update(status=result.status.value, solved=result.status is Status.SOLVED, message=result.message or "",
                  iterations=stats.get("iterations"), nodes=stats.get("nodes"),
                  planner_cost=_finite(result.cost), time=float(stats.get("planning_time", stats.get("time", 0.0))),
                  binding=(stats.get("budget") or {}).get("binding"))
    if record["solved"] and result.path is not None:
        path = np.asarray(result.path.configurations, dtype=float)
        step = float(problem.scene.resolution) if problem.scene is not None else None
        length = float(problem.space.path_length(path))
        integral = float(problem.path_cost(path, step)) if problem.cost is not None else 0.0
        record.update(cost=_finite(integral + cell["length_weight"] * length), length=length,
                      valid=bool(problem.path_verdict(path).valid), states=len(path))
        first = stats.get("time_to_first")
        record["time_to_first"] = float(first) if first is not None else record["time"]
    else:
        record.update(cost=None, length=None, valid=None, states=None, time_to_first=None)
    history = stats.get("cost_history") or []
    record["progress"] = [[float(t), float(c)] for t, c in history if math.isfinite(float(c))]
    if not record["progress"] and record["planner_cost"] is not None and record["solved"]:
        record["progress"] = [[record["time"], record["planner_cost"]]]
    record["seconds"] = time.perf_counter() - t0
    return record


def _finite(value) -> float | None:
    try:
        value = float(value)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def describe(record: dict) -> str:
    """One line on a cell's record: its key, status, planning time (s) and judged cost (when solved)."""
    cost = f", cost {record['cost']:.4g}" if record.get("cost") is not None else ""
    return f"{record['key']}: {record['status']}, {record['time']:.2f} s{cost}"


# --- the grid ----------------------------------------------------------------------------------------------------


def run_benchfile(bench: BenchFile, *, jobs: int = 1, fresh: bool = False, echo=print, executor=None,
                  check: bool = True, plots: bool = True) -> list[dict]:
    """Run the cells not yet on file in ``bench.output/runs.jsonl`` (a cell on file whose definition changed is an
    error naming it: use ``fresh``), then write the outputs (``plots``: with the figures); returns the grid's
    records in grid order.  On Ctrl-C the logs, database and report of the finished cells are written (without
    figures) before :class:`KeyboardInterrupt` is raised; the same call again resumes."""
    from pliant.experiments.runs import open_log, run_tasks
    from pliant.files import rewrite_jsonl

    output = bench.output
    if fresh and (output / "runs.jsonl").exists():
        rewrite_jsonl(output / "runs.jsonl", [])
    log, records = open_log(output, "output", echo)
    cells = bench.grid()
    by_key = {c["key"]: c for c in cells}
    done = {}
    for record in records:
        cell = by_key.get(record.get("key"))
        if cell is None:
            continue                                   # a cell of an earlier grid: kept on file, not reported
        if record.get("definition") != cell["definition"]:
            raise ConfigError("this cell is on file with other settings (problem, planner options or budget "
                              "changed since); rerun with --fresh, or another output", source=str(log),
                              field="cell", value=cell["key"])
        done[cell["key"]] = record
    todo = [c for c in cells if c["key"] not in done]
    write_json(output / "benchfile.json", {"name": bench.name, "source": bench.source, "cells": len(cells)})
    if todo:
        if check:
            check_grid(bench)
        echo(f"{bench.name}: {len(cells)} cells ({len(bench.problems)} problems x {len(bench.budgets)} budgets x "
             f"{len(bench.planners)} planners x {len(bench.seeds)} seeds), {len(done)} on file, {len(todo)} to run")

        def on_interrupt() -> None:
            write_outputs(bench, _in_grid(cells, records), plots=False)

        run_tasks(run_cell, [(c,) for c in todo], jobs=jobs, log=log, records=records, describe=describe,
                  on_interrupt=on_interrupt, echo=echo, executor=executor)
    else:
        echo(f"{bench.name}: all {len(cells)} cells on file in {log}")
    ordered = _in_grid(cells, records)
    write_outputs(bench, ordered, plots=plots)
    return ordered


def _in_grid(cells: list[dict], records: list[dict]) -> list[dict]:
    by_key = {r.get("key"): r for r in records}
    return [by_key[c["key"]] for c in cells if c["key"] in by_key and
            by_key[c["key"]].get("definition") == c["definition"]]


# --- outputs -----------------------------------------------------------------------------------------------------


def _median(values: list[float]) -> float | None:
    values = sorted(v for v in values if v is not None)
    if not values:
        return None
    n = len(values)
    return values[n // 2] if n % 2 else 0.5 * (values[n // 2 - 1] + values[n // 2])


def summarize(bench: BenchFile, records: list[dict]) -> list[dict]:
    """One row per problem x budget x planner: runs, solved, valid, median time to first solution, median and
    mean final cost, median planning time."""
    import numpy as np

    rows = []
    for problem in bench.problems:
        for budget in bench.budgets:
            for planner in bench.planners:
                runs = [r for r in records if (r["problem"], r["budget"], r["planner"]) ==
                        (problem.name, budget.label, planner.label)]
                if not runs:
                    continue
                solved = [r for r in runs if r["solved"]]
                costs = [r["cost"] for r in solved if r.get("cost") is not None]
                cap = budget.table.get("max_time")
                capped = sum(r.get("binding") == "time" or (r.get("binding") is None and cap is not None
                                                             and r["time"] >= cap) for r in runs)
                rows.append({"problem": problem.name, "budget": budget.label, "planner": planner.label,
                             "runs": len(runs), "solved": len(solved),
                             "valid": sum(bool(r.get("valid")) for r in solved),
                             "success": len(solved) / len(runs),
                             "time_to_first": _median([r.get("time_to_first") for r in solved]),
                             "cost_median": _median(costs),
                             "cost_mean": float(np.mean(costs)) if costs else None,
                             "cost_std": float(np.std(costs)) if costs else None,
                             "time": _median([r["time"] for r in runs]),
                             "time_capped": capped})
    return rows


def _fmt(value, spec: str = ".3g") -> str:
    return "-" if value is None else format(value, spec)


def report_markdown(bench: BenchFile, rows: list[dict], figures: list[Path]) -> str:
    """The text of ``report.md``: the summary ``rows`` (:func:`summarize`) as a Markdown table, then the ``figures``
    (in ``plots/``)."""
    lines = [f"# Benchmark {bench.name}", ""]
    if bench.description:
        lines += [bench.description, ""]
    lines += [f"From `{bench.source}`: {len(bench.problems)} problems x {len(bench.budgets)} budgets x "
              f"{len(bench.planners)} planners x {len(bench.seeds)} seeds. Cost: the path integral of the state "
              "cost plus the problem's length weight x length, the same for every planner, of the solved runs. "
              "Times: median, seconds (time to first solution: the planner's `time_to_first`, else its planning "
              "time). Time cap bound: runs the wall-clock cap stopped before the work budget (their result depends "
              "on the machine's speed and load).", ""]
    header = "| problem | budget | planner | solved | valid | time to first (s) | cost median | cost mean (std) | " \
             "time (s) | time cap bound |"
    lines += [header, "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        mean = "-" if r["cost_mean"] is None else f"{r['cost_mean']:.4g} ({r['cost_std']:.3g})"
        lines.append(f"| {r['problem']} | {r['budget']} | {r['planner']} | {r['solved']}/{r['runs']} | "
                     f"{r['valid']}/{r['solved']} | {_fmt(r['time_to_first'])} | {_fmt(r['cost_median'], '.4g')} | "
                     f"{mean} | {_fmt(r['time'])} | {r['time_capped']}/{r['runs']} |")
    lines.append("")
    for figure in figures:
        lines += [f"![{figure.stem}](plots/{figure.name})", ""]
    return "\n".join(lines)


def write_ompl_logs(bench: BenchFile, records: list[dict]) -> list[Path]:
    """One OMPL benchmark log per problem x budget (an OMPL "experiment"), one planner configuration per planner,
    one run per seed; progress: the planner's best cost over time where it reports one."""
    from pliant.experiments.ompl import PlannerRuns, run_properties, write_ompl_log

    logs = []
    for problem in bench.problems:
        for budget in bench.budgets:
            planners, total = [], 0.0
            for planner in bench.planners:
                runs = [r for r in records if (r["problem"], r["budget"], r["planner"]) ==
                        (problem.name, budget.label, planner.label)]
                if not runs:
                    continue
                total += sum(r["time"] for r in runs)
                properties = []
                for r in runs:
                    p = run_properties({**r, "cost": r.get("cost")})
                    p["valid BOOLEAN"] = None if r.get("valid") is None else int(r["valid"])
                    p["planner cost REAL"] = r.get("planner_cost")
                    properties.append(p)
                progress = [[{"time REAL": t, "best cost REAL": c} for t, c in r.get("progress") or []]
                            for r in runs]
                settings = {"planner": planner.name, **{k: json.dumps(v) if isinstance(v, (dict, list)) else v
                                                        for k, v in planner.options.items()}}
                planners.append(PlannerRuns(planner.label, settings, properties,
                                            progress if any(progress) else None))
            if not planners:
                continue
            experiment = f"{problem.name} {budget.label}" if len(bench.budgets) > 1 else problem.name
            name = safe_name(experiment.replace(" ", "-").replace(",", ""))
            logs.append(write_ompl_log(
                bench.output / "logs" / f"{name}.log", experiment, planners,
                time_limit=float(budget.table.get("max_time") or 0.0), total_time=total,
                seed=",".join(map(str, bench.seeds)) if len(bench.seeds) <= 10 else f"{bench.seeds[0]}..",
                setup=f"pliant bench {bench.source}\nproblem {problem.name}: {dumps(problem.data, sort_keys=True)}\n"
                      f"budget {budget.label}: {dumps(budget.table, sort_keys=True)}",
                properties={"length_weight REAL": problem.length_weight,
                            "max_iterations INTEGER": budget.table.get("max_iterations")}))
    return logs


def draw_figures(bench: BenchFile, records: list[dict]) -> list[Path]:
    """Per problem x budget, one figure of three panels: success over time (the share of runs solved by time t),
    best cost over time (median over the runs solved by then, the planners' own objective), and the time to the
    first solution (a box per planner)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    figures = []
    (bench.output / "plots").mkdir(parents=True, exist_ok=True)
    for problem in bench.problems:
        for budget in bench.budgets:
            chosen = [r for r in records if (r["problem"], r["budget"]) == (problem.name, budget.label)]
            if not chosen:
                continue
            times = [r["time"] for r in chosen] + [t for r in chosen for t, _ in r.get("progress") or []]
            horizon = max(times + [1e-2])
            grid = np.geomspace(max(min([t for t in times if t > 0] + [horizon]) / 2, 1e-3), horizon * 1.05, 300)
            fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
            labels, firsts = [], []
            for planner in bench.planners:
                runs = [r for r in chosen if r["planner"] == planner.label]
                if not runs:
                    continue
                first = np.array([r["time_to_first"] if r["solved"] else np.inf for r in runs])
                line, = axes[0].step(grid, [(first <= t).mean() * 100 for t in grid], where="post",
                                     label=planner.label)
                best = np.full((len(runs), len(grid)), np.nan)
                for i, r in enumerate(runs):
                    for t, c in r.get("progress") or []:
                        best[i, grid >= t] = np.fmin(best[i, grid >= t], c)
                with np.errstate(all="ignore"), warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    solved_share = np.isfinite(best).mean(axis=0)
                    curve = np.where(solved_share >= 0.5, np.nanmedian(np.where(np.isfinite(best), best, np.nan),
                                                                       axis=0), np.nan) \
                        if np.isfinite(best).any() else np.full(len(grid), np.nan)
                axes[1].plot(grid, curve, color=line.get_color(), label=planner.label)
                labels.append(planner.label)
                firsts.append([r["time_to_first"] for r in runs if r["solved"]])
            axes[0].set(xlabel="time (s)", ylabel="solved (%)", title="success over time", ylim=(-2, 102),
                        xscale="log")
            axes[1].set(xlabel="time (s)", ylabel="best cost (median of runs solved)", xscale="log",
                        title="cost over time (planner's own objective)")
            axes[2].boxplot([f if f else [np.nan] for f in firsts])
            axes[2].set_xticks(range(1, len(labels) + 1), labels, rotation=40, ha="right", fontsize=8)
            axes[2].set(ylabel="time to first solution (s)", title="time to first solution", yscale="log")
            axes[0].legend(fontsize=7, loc="lower right")
            fig.suptitle(f"{problem.name} ({budget.label}, {len(bench.seeds)} seeds)")
            fig.tight_layout()
            name = safe_name(f"{problem.name}-{budget.label}".replace(" ", "-").replace(",", ""))
            path = bench.output / "plots" / f"{name}.png"
            fig.savefig(path, dpi=90)
            plt.close(fig)
            figures.append(path)
    return figures


def write_outputs(bench: BenchFile, records: list[dict], *, plots: bool = True) -> dict[str, Any]:
    """The OMPL logs (``logs/*.log``), OMPL's database of them (``benchmark.db``), ``summary.json`` and
    ``report.md`` (with the plots, ``plots/*.png``) for the records so far."""
    from pliant.experiments.ompl import ompl_database

    if not records:
        return {}
    rows = summarize(bench, records)
    logs = write_ompl_logs(bench, records)
    database = ompl_database(bench.output / "benchmark.db", logs)
    figures = draw_figures(bench, records) if plots else []
    write_json(bench.output / "summary.json", {"name": bench.name, "rows": rows})
    report = write_text(bench.output / "report.md", report_markdown(bench, rows, figures))
    return {"logs": logs, "database": database, "figures": figures, "report": report, "rows": rows}


# --- the command -------------------------------------------------------------------------------------------------


def main(argv: list[str]) -> int:
    """``pliant bench FILE.toml [--jobs N] [--fresh] [--output DIR] [--executor local|ray] [--address A]``."""
    import os

    from pliant.experiments.executor import add_executor_arguments, from_args, using

    parser = argparse.ArgumentParser(prog="pliant bench",
                                     description="run a benchmark file: planners x problems x seeds x budgets "
                                                 "(docs/benchmarking.md)")
    parser.add_argument("file", help="benchmark file (TOML)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="cells at a time (default: the cores)")
    parser.add_argument("--output", help="directory (default: the file's output)")
    parser.add_argument("--fresh", action="store_true", help="forget the cells on file (a second run resumes)")
    parser.add_argument("--check", action="store_true", help="only check the file and list the grid")
    add_executor_arguments(parser)
    args = parser.parse_args(argv)
    if args.jobs < 1:
        raise ConfigError("must be >= 1", field="--jobs", value=args.jobs)
    if args.output is not None:
        from pliant.files import check_path_name

        check_path_name(args.output, "--output")
    bench = load_benchfile(args.file, output=args.output)
    if args.check:
        check_grid(bench)
        print(f"{bench.name}: {len(bench.grid())} cells; problems {', '.join(p.name for p in bench.problems)}; "
              f"planners {', '.join(p.label for p in bench.planners)}; budgets "
              f"{', '.join(b.label for b in bench.budgets)}; seeds {bench.seeds}; output {bench.output}")
        return 0
    with using(from_args(args)):
        records = run_benchfile(bench, jobs=args.jobs, fresh=args.fresh)
    print(f"{len(records)} cells: {bench.output / 'report.md'}, {bench.output / 'benchmark.db'} "
          f"(OMPL's database: Planner Arena reads it), logs in {bench.output / 'logs'}")
    return 0

