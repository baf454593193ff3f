"""Scene preprocessing with and without the content-addressed cache (pliant.cache; docs/architecture.md).

For each bundled pipeline, in fresh processes (so that only the cache on disk carries over): the pipeline's build
(scene, robot, simulator, cost: the voxel grid, the kinematic simulator's contact tables and distance fields) and the
validity checker the planner uses (its grid), timed

* ``uncached``: ``PLIANT_CACHE=0``, what every run paid before the cache;
* ``cold``: an empty cache directory (built, then written);
* ``warm``: the same directory again (read).

Then ``pliant run peg-slide`` twice on an empty cache directory (the build time its ``run.json`` reports, imports of
the plugins included), and two processes building peg-slide at once on an empty directory (how many built it: the
other waits for the one build and reads it, as experiment workers do).

Figure to reach (issue 32): a second ``pliant run peg-slide`` builds in under 1 s.

    pliant bench scene_cache [PIPELINE ...]      (or: python benchmarks/bench_scene_cache.py [PIPELINE ...])
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, write_json

PIPELINES = ["peg-slide", "peg-tight-policy", "learn-hollow-cube", "baxter-policy", "cube-wall-trrt", "maze-slide"]

_BUILD = """
import json, sys, time
t0, c0 = time.perf_counter(), time.process_time()
from pliant import cache
from pliant.pipeline import Pipeline
from pliant.planning.validity import ValidityChecker
pipeline = Pipeline.from_file(sys.argv[1])
t1, c1 = time.perf_counter(), time.process_time()
context = pipeline.build()
t2, c2 = time.perf_counter(), time.process_time()
ValidityChecker.from_context(context)
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "build": t2 - t1, "build_cpu": c2 - c1, "validity": t3 - t2,
                  "counts": cache.counts}))
"""


def _python(code: str, *args: str, env: dict) -> dict:
    out = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _env(cache_dir: Path | None) -> dict:
    env = dict(os.environ)
    if cache_dir is None:
        env["PLIANT_CACHE"] = "0"
    else:
        env["PLIANT_CACHE"] = "1"
        env["PLIANT_CACHE_DIR"] = str(cache_dir)
    return env


def builds(pipeline: str, root: Path) -> dict:
    """Uncached, cold and warm build of ``pipeline`` (s), each in a fresh process."""
    directory = root / f"cache-{pipeline}"
    row = {"uncached": _python(_BUILD, pipeline, env=_env(None)),
           "cold": _python(_BUILD, pipeline, env=_env(directory)),
           "warm": _python(_BUILD, pipeline, env=_env(directory))}
    row["cache_bytes"] = sum(p.stat().st_size for p in directory.rglob("*.npz"))
    return row


def pliant_run(pipeline: str, root: Path) -> dict:
    """``pliant run PIPELINE`` twice on an empty cache directory: the build time of each (run.json)."""
    directory = root / f"run-{pipeline}"
    pliant = Path(sys.executable).with_name("pliant")
    runs = []
    for i in range(2):
        output = root / f"out-{pipeline}-{i}"
        t = time.perf_counter()
        subprocess.run([str(pliant), "run", pipeline, "--output", str(output)], env=_env(directory),
                       capture_output=True, text=True, check=True)
        wall = time.perf_counter() - t
        timings = json.loads((output / "run.json").read_text())["timings"]
        runs.append({"build": timings["build"], "wall": wall, "timings": timings,
                     "result": json.loads((output / "result.json").read_text())})
    same = _without_times(runs[0]["result"]) == _without_times(runs[1]["result"])
    return {"first": runs[0], "second": runs[1], "same_result": same}


def _without_times(data):
    if isinstance(data, dict):
        return {k: _without_times(v) for k, v in data.items() if "time" not in k}
    if isinstance(data, list):
        return [_without_times(v) for v in data]
    return data


def workers(pipeline: str, root: Path, n: int = 2) -> dict:
    """``n`` processes building ``pipeline`` at once on an empty cache directory: how many built each result."""
    directory = root / f"workers-{pipeline}"
    procs = [subprocess.Popen([sys.executable, "-c", _BUILD, pipeline], env=_env(directory), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(n)]
    outs = [json.loads(p.communicate()[0].strip().splitlines()[-1]) for p in procs]
    return {"processes": n, "results": len(list(directory.rglob("*.npz"))),
            "built": sum(o["counts"]["built"] for o in outs), "read": sum(o["counts"]["disk"] for o in outs),
            "builds": [o["build"] for o in outs]}


def main(argv: list[str]) -> int:
    pipelines = argv or PIPELINES
    with tempfile.TemporaryDirectory(prefix="pliant-bench-cache-") as tmp:
        root = Path(tmp)
        rows = {name: builds(name, root) for name in pipelines}
        run = pliant_run("peg-slide", root)
        shared = workers("peg-slide", root)
    print_table("Pipeline build and validity checker, fresh process each (s; cpu: the build's CPU time)",
                ("pipeline", "uncached build", "cold build", "warm build", "uncached cpu", "warm cpu",
                 "uncached validity", "warm validity", "cache MB"),
                [(name, f"{r['uncached']['build']:.2f}", f"{r['cold']['build']:.2f}", f"{r['warm']['build']:.2f}",
                  f"{r['uncached']['build_cpu']:.2f}", f"{r['warm']['build_cpu']:.2f}",
                  f"{r['uncached']['validity']:.2f}", f"{r['warm']['validity']:.2f}", f"{r['cache_bytes'] / 1e6:.1f}")
                 for name, r in rows.items()])
    print_table("pliant run peg-slide, twice on an empty cache (s; run.json timings)",
                ("run", "build", "plan", "execute", "wall"),
                [(k, f"{run[k]['build']:.2f}", f"{run[k]['timings'].get('plan', 0):.2f}",
                  f"{run[k]['timings'].get('execute', 0):.2f}", f"{run[k]['wall']:.1f}") for k in ("first", "second")])
    print(f"\nsame result.json (times aside): {run['same_result']}; second build under 1 s: "
          f"{run['second']['build'] < 1.0}")
    print(f"{shared['processes']} processes building peg-slide at once on an empty cache: {shared['results']} results "
          f"on disk, {shared['built']} builds, {shared['read']} reads (build times "
          f"{', '.join(f'{b:.2f}' for b in shared['builds'])} s)")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    print(f"load average (1 min) at the end: {load}")
    for r in run.values():
        if isinstance(r, dict):
            r.pop("result", None)
    write_json("scene_cache", {"load_average": load, "pipelines": rows, "pliant_run_peg_slide": run,
                               "concurrent_workers": shared})
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
