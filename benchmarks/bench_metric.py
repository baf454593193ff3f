"""Path-quality metrics of thesis ch. 6 against the kinematic simulation baseline, per cell of the thesis's grid.

For each task (se3-peg-tight, se2-through-passage; se3-peg-in-hole, ours, with --tasks: docs/plugins/reachability.md)
and each cell (epsilon_reached,
alpha): Simulation (baseline) with --simulations runs (default: the thesis's 10,000 / 2,000), then one evaluation of
each other method; P_exec, its absolute error against the baseline, seconds and simulated control steps (every
robot counted).  Figures to reach: the reachable-volume metric within 0.05 of the baseline in every cell, <= 2 s
per path on se3-peg-tight, >= 10x fewer simulated steps than the baseline.  The thesis's own numbers (Tables
6.1-6.4, 16 threads) are printed beside, "-" where it has none (se3-peg-in-hole).

    pliant bench metric [-- --tasks se2-through-passage --simulations 10000 --jobs 2 --set particles=4000]
    pliant bench metric -- --tasks se3-peg-in-hole --jobs 2
    pliant bench metric -- --alone      # only the proposed metric, one cell at a time: its seconds per path
    pliant bench metric -- --replay out/bench/metric.json --tasks se3-peg-in-hole \
        --ground-truth out/metric-tables/runs.jsonl    # a run's tables again, each method against the ground truth

With --jobs 2 two cells run at once, so the table's seconds are those of a loaded machine; the proposed metric is
timed again alone afterwards (its line under each table).
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, write_json
from pliant_reachability.evaluation import evaluate, task_density
from pliant_reachability.tasks import (
    METHODS,
    TASKS,
    THESIS_P_EXEC,
    THESIS_SECONDS,
    THESIS_TASKS,
    cells,
    thesis_values,
)


def _value(text: str):
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _thesis(values: tuple | None, k: int | None = None) -> str:
    """The thesis's value in cell ``k`` (or its range when ``k`` is None), ``-`` where it has none."""
    if values is None:
        return "-"
    return f"{values[k]:.2f}" if k is not None else f"{min(values)}-{max(values)}"


def _cell(name: str, k: int, density: float, simulations: int | None, options: dict) -> dict:
    eps, alpha = cells()[k]
    record = {"task": name, "cell": k, "epsilon": eps, "alpha": alpha,
              "baseline": evaluate(name, "simulation", eps, alpha, 1, density, simulations, **options)}
    for method in METHODS[1:]:
        record[method] = evaluate(name, method, eps, alpha, 0, density, simulations, **options)
    return record


def _row(record: dict) -> tuple:
    name, k, base = record["task"], record["cell"], record["baseline"]
    row = [f"{record['epsilon']:g}/{record['alpha']:g}", f"{base['p_exec']:.3f}", f"{base['seconds']:.1f}"]
    for method in METHODS[1:]:
        r = record[method]
        thesis = thesis_values(THESIS_P_EXEC, name, method)
        row.append(f"{r['p_exec']:.3f} ({r['p_exec'] - base['p_exec']:+.3f}) [{_thesis(thesis, k)}]")
        row.append(f"{r['seconds']:.2f}")
    steps = record["reachable-volume"]["simulated_steps"]
    row.append(f"{base['simulated_steps'] / max(steps, 1):.0f}x")
    return tuple(row)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="*", default=list(THESIS_TASKS), choices=list(TASKS),
                        help=f"default: the thesis's ({' '.join(THESIS_TASKS)})")
    parser.add_argument("--simulations", type=int, default=None, help="baseline runs (default: the task's)")
    parser.add_argument("--cells", type=int, default=9, help="first N cells of the grid (default 9)")
    parser.add_argument("--jobs", type=int, default=1, help="cells at a time (default 1: timings on an idle core)")
    parser.add_argument("--set", action="append", default=[], help="metric option KEY=VALUE for every method")
    parser.add_argument("--alone", action="store_true", help="time only the proposed metric, one cell at a time")
    parser.add_argument("--ground-truth", type=Path, metavar="RUNS_JSONL",
                        help="a pliant experiment metric-tables runs.jsonl with ground-truth records: every method's "
                             "mean "
                             "absolute error against them and the cells it overestimates by more than 0.05")
    parser.add_argument("--replay", type=Path, metavar="JSON",
                        help="print the tables of a previous run (out/bench/metric.json) instead of running")
    args = parser.parse_args(argv)
    options = {}
    for item in args.set:
        key, _, value = item.partition("=")
        options[key] = _value(value)
    if args.alone:
        return _alone(args.tasks, args.cells, options)
    truth = _ground_truth(args.ground_truth) if args.ground_truth else {}
    if args.replay:
        return _replay(args.replay, args.tasks, truth)
    results = []
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for name in args.tasks:
            task = TASKS[name]
            density = task_density(task)
            futures = [pool.submit(_cell, name, k, density, args.simulations, options) for k in range(args.cells)]
            records = []
            for future in as_completed(futures):
                record = future.result()
                records.append(record)
                print(f"{name} {record['epsilon']:g}/{record['alpha']:g}: " + "  ".join(_row(record)[1:]), flush=True)
            records.sort(key=lambda r: r["cell"])
            # the proposed metric timed again here, one cell at a time on an otherwise idle machine (after a warm-up
            # that compiles its kernels), so its seconds are not those of a loaded machine
            evaluate(name, "reachable-volume", *cells()[0], 99, density, args.simulations, **options)
            for r in records:
                again = evaluate(name, "reachable-volume", r["epsilon"], r["alpha"], 0, density, args.simulations,
                                 **options)
                r["reachable-volume"]["seconds_idle"] = again["seconds"]
                r["density"] = density
                r["simulations"] = task.simulations if args.simulations is None else args.simulations
            results += records
            _report(name, records, truth.get(name, {}))
    write_json("metric", {"options": options, "simulations": args.simulations, "jobs": args.jobs,
                          "results": results})
    return 0


def _report(name: str, records: list[dict], truth: dict[int, float]) -> None:
    """The task's table, the proposed metric's errors and seconds, and each method against the ground truth."""
    header = ("eps/alpha", "baseline", "s")
    for method in METHODS[1:]:
        header += (f"{method} (error) [thesis]", "s")
    density = records[0].get("density")
    print_table(f"{name}: P_exec against the kinematic baseline ({records[0]['simulations']} runs)"
                + ("" if density is None else f", density {density:.4g}"),
                header + ("baseline steps / metric steps",), [_row(r) for r in records])
    errors = [abs(r["reachable-volume"]["p_exec"] - r["baseline"]["p_exec"]) for r in records]
    seconds = [r["reachable-volume"]["seconds_idle"] for r in records]
    thesis = thesis_values(THESIS_SECONDS, name, "reachable-volume")
    print(f"reachable-volume: largest error {max(errors):.3f}, mean {sum(errors) / len(errors):.3f}; "
          f"seconds alone on the machine {min(seconds):.2f}-{max(seconds):.2f} (thesis, 16 threads: "
          f"{_thesis(thesis)})")
    if not truth:
        return
    cells_truth = [r for r in records if r["cell"] in truth]
    rows = []
    for method in ("baseline", *METHODS[1:]):
        diff = [r[method]["p_exec"] - truth[r["cell"]] for r in cells_truth]
        rows.append((method, f"{sum(abs(d) for d in diff) / len(diff):.3f}", f"{max(abs(d) for d in diff):.3f}",
                     f"{sum(d > 0.05 for d in diff)} of {len(diff)}"))
    print("ground truth per cell: " + " ".join(f"{truth[r['cell']]:.2f}" for r in cells_truth))
    print_table(f"{name}: against the ground truth", ("method", "mean |error|", "largest", "overestimates > 0.05"),
                rows)


def _ground_truth(path: Path) -> dict[str, dict[int, float]]:
    """``task -> cell -> P_exec`` of the ground-truth records in a ``pliant experiment metric-tables``
    ``runs.jsonl``."""
    from pliant.errors import ConfigError
    from pliant.files import read_jsonl

    if not path.exists():
        raise ConfigError("no such file (a runs.jsonl of pliant experiment metric-tables)", field="--ground-truth",
                          value=str(path))
    records, _ = read_jsonl(path)
    values: dict[str, dict[int, list[float]]] = {}
    for r in records:
        if r.get("method") == "ground truth":
            values.setdefault(r["task"], {}).setdefault(r["cell"], []).append(r["p_exec"])
    return {task: {cell: sum(v) / len(v) for cell, v in by_cell.items()} for task, by_cell in values.items()}


def _replay(path: Path, tasks: list[str], truth: dict) -> int:
    """The tables of a previous run's JSON (``out/bench/metric.json``), without running anything."""
    import json

    from pliant.errors import ConfigError

    try:
        data = json.loads(path.read_text())
        results = data["results"]
    except (OSError, ValueError, KeyError) as exc:
        raise ConfigError(f"cannot read a benchmark's results: {exc}", field="--replay", value=str(path)) from None
    for name in tasks:
        records = sorted((r for r in results if r["task"] == name), key=lambda r: r["cell"])
        for r in records:
            r.setdefault("simulations", data.get("simulations") or TASKS[name].simulations)
        if records:
            _report(name, records, truth.get(name, {}))
    return 0


def _alone(tasks: list[str], n_cells: int, options: dict) -> int:
    """The proposed metric's seconds per path, cell after cell in this process after a warm-up (compiled kernels)."""
    rows, records = [], []
    for name in tasks:
        density = task_density(TASKS[name])
        evaluate(name, "reachable-volume", *cells()[0], 99, density, **options)
        for eps, alpha in cells()[:n_cells]:
            r = evaluate(name, "reachable-volume", eps, alpha, 0, density, **options)
            thesis = thesis_values(THESIS_SECONDS, name, "reachable-volume")
            rows.append((name, f"{eps:g}/{alpha:g}", f"{r['p_exec']:.3f}", f"{r['seconds']:.2f}",
                         _thesis(thesis, cells().index((eps, alpha)))))
            records.append({"task": name, "epsilon": eps, "alpha": alpha, "p_exec": r["p_exec"],
                            "seconds": r["seconds"]})
    print_table("reachable-volume alone, seed 0", ("task", "eps/alpha", "P_exec", "s", "thesis s (16 threads)"), rows)
    write_json("metric-alone", {"options": options, "results": records})
    return 0


if __name__ == "__main__":
    sys.exit(main())
