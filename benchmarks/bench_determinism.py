"""Deterministic by default (issue 32 items 3 and 4): the same ``pliant run`` of every bundled pipeline, with one seed,
gives byte-identical ``result.json`` (timings aside) on an idle machine and beside two CPU-burning processes.

For each pipeline (``scenes/pipelines/*.toml``, or ``--only``), ``pliant run NAME --set seed=S`` runs twice in fresh
processes: once as the machine is, once beside two ``python -c "while True: pass"`` processes started for that run
and stopped after it.  Both ``result.json`` files (``learned.json`` for a pipeline without a planner) are read,
every timing removed (keys naming a time: ``time``, ``*_time``, ``time_*``, ``*seconds*``, ``elapsed``; the time
column of ``cost_history``; ``budget.max_time`` is the request's and stays), and the rest compared as canonical
JSON (sorted keys): identical or not, with the first differing key.  ``execution.json`` (simulated times are data,
not timings) is compared whole when the run wrote one.  Also reported: each run's outcome, the planner's stop
reason (``statistics.budget.binding``: ``iterations`` for a work budget; ``time`` would make the result depend on
the machine) and the wall time.

    python benchmarks/bench_determinism.py [--only demo,iiwa-policy] [--seed 0] [--burners 2] [--out DIR]

Writes ``out/bench/determinism.json`` (``PLIANT_BENCH_OUT`` to change the folder).  A benchmark, not a test: a full
run of the bundled pipelines takes tens of minutes on the 2-core machine.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, write_json

ROOT = Path(__file__).resolve().parents[1]
#: pipelines that need a hardware peer (a ROS master, a CAN bus) to run: none of the bundled scenes/pipelines do
NEEDS_PEER: set[str] = set()


def is_timing(key: str) -> bool:
    """Whether a statistics key holds a wall-clock measurement."""
    k = key.lower()
    return (k == "time" or k.endswith("_time") or k.startswith("time_") or "seconds" in k or k == "elapsed"
            or k.endswith("_s") or k == "timings")


def strip_timings(value, key: str = ""):
    """``value`` without wall-clock measurements (recursively); ``cost_history`` keeps its cost column."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if k == "budget" and isinstance(v, dict):
                out[k] = {kk: vv for kk, vv in v.items()}          # the request's budget (max_time included) is data
                continue
            if is_timing(k):
                continue
            out[k] = strip_timings(v, k)
        return out
    if isinstance(value, list):
        if key == "cost_history":
            return [row[1:] if isinstance(row, list) else row for row in value]
        return [strip_timings(v) for v in value]
    return value


def first_difference(a, b, where: str = "") -> str:
    """The dotted path of the first difference between two JSON values ('' when equal)."""
    if type(a) is not type(b):
        return where or "<top>"
    if isinstance(a, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return f"{where}.{k}".lstrip(".")
            found = first_difference(a[k], b[k], f"{where}.{k}")
            if found:
                return found.lstrip(".")
        return ""
    if isinstance(a, list):
        if len(a) != len(b):
            return f"{where}[len {len(a)} != {len(b)}]"
        for i, (x, y) in enumerate(zip(a, b)):
            found = first_difference(x, y, f"{where}[{i}]")
            if found:
                return found
        return ""
    return "" if a == b else (where or "<top>")


def run_once(name: str, seed: int, output: Path, burners: int) -> dict:
    """One ``pliant run`` in a fresh process (beside ``burners`` busy loops); its files and figures."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(burners)]
    try:
        started = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "pliant.cli", "run", name, "--set", f"seed={seed}",
                               "--set", f'output="{output}"'], cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - started
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    return {"exit": done.returncode, "wall": wall, "stderr": done.stderr[-2000:], **read_run(output)}


def read_run(output: Path) -> dict:
    """What a run folder holds, timings stripped: the plan, what was learned, the execution, the outcome."""
    record: dict = {}
    result = output / "result.json"
    if result.is_file():
        data = json.loads(result.read_text())
        record["result"] = strip_timings(data)
        budget = (data.get("statistics") or {}).get("budget") or {}
        record["binding"] = budget.get("binding")
        record["status"] = data.get("status")
    execution = output / "execution.json"
    if execution.is_file():
        record["execution"] = json.loads(execution.read_text())
    learned = output / "learned.json"
    if learned.is_file():
        record["learned"] = strip_timings(json.loads(learned.read_text()))
    run = output / "run.json"
    if run.is_file():
        data = json.loads(run.read_text())
        record["outcome"] = data.get("outcome")
        record["stages"] = sum((data.get("timings") or {}).values())      # build, learn, plan, execute (s)
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", default="", help="comma-separated pipeline names (default: every bundled one)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--burners", type=int, default=2, help="busy-loop processes beside the second run")
    parser.add_argument("--out", default="out/bench/determinism", help="folder for the runs' output")
    parser.add_argument("--compare", action="store_true",
                        help="run nothing: compare the idle/ and loaded/ folders already under --out")
    args = parser.parse_args()
    names = [n for n in args.only.split(",") if n] or sorted(p.stem for p in (ROOT / "scenes/pipelines").glob("*.toml"))
    if args.compare and not args.only:
        names = sorted(p.name for p in Path(args.out).iterdir() if p.is_dir())
    rows, report = [], {"seed": args.seed, "burners": args.burners, "pipelines": {}}
    for name in names:
        if name in NEEDS_PEER:
            rows.append((name, "skipped (needs a hardware peer)", "", "", "", "", ""))
            continue
        base = Path(args.out) / name
        if args.compare:
            idle, busy = read_run(base / "idle"), read_run(base / "loaded")
            if busy.get("outcome") in (None, "running"):          # not run, or still running
                continue
            for run in (idle, busy):             # the stages' time from run.json stands for the process's wall time
                run.update(exit=None, wall=run.get("stages", float("nan")), stderr="")
        else:
            idle = run_once(name, args.seed, base / "idle", 0)
            busy = run_once(name, args.seed, base / "loaded", args.burners)
        # the plan (result.json); a pipeline without a planner: what its learner fitted (learned.json)
        key = "result" if "result" in idle or "result" in busy else "learned"
        same = key in idle and key in busy and json.dumps(idle[key], sort_keys=True) == \
            json.dumps(busy[key], sort_keys=True)
        diff = "" if same else first_difference(idle.get(key), busy.get(key)) or f"{key}.json missing"
        exec_same = None
        if "execution" in idle or "execution" in busy:
            exec_same = json.dumps(idle.get("execution"), sort_keys=True) == \
                json.dumps(busy.get("execution"), sort_keys=True)
        rows.append((name, ("identical" if same else f"DIFFERS at {diff}") + ("" if key == "result" else " (learned)"),
                     "-" if exec_same is None else ("identical" if exec_same else "DIFFERS"),
                     f"{idle.get('outcome')}/{busy.get('outcome')}", f"{idle.get('binding')}/{busy.get('binding')}",
                     f"{idle['wall']:.0f}", f"{busy['wall']:.0f}"))
        report["pipelines"][name] = {
            "compared": f"{key}.json", "result_identical": same, "first_difference": diff,
            "execution_identical": exec_same,
            "outcome": [idle.get("outcome"), busy.get("outcome")], "exit": [idle["exit"], busy["exit"]],
            "binding": [idle.get("binding"), busy.get("binding")], "wall": [idle["wall"], busy["wall"]],
            "stderr": [idle["stderr"][-300:], busy["stderr"][-300:]] if not same else None}
        print(f"{name}: {rows[-1][1]}; execution {rows[-1][2]}; outcome {rows[-1][3]}; binding {rows[-1][4]}; "
              f"wall {rows[-1][5]} s / {rows[-1][6]} s", flush=True)
    print_table(f"Same seed ({args.seed}), idle vs beside {args.burners} CPU burners: result.json timings aside",
                ("pipeline", "result.json", "execution.json", "outcome idle/loaded", "binding idle/loaded",
                 "wall idle (s)", "wall loaded (s)"), rows)
    write_json("determinism", report)


if __name__ == "__main__":
    main()
