"""Benchmarks from a file (pliant.experiments.benchfile, `pliant bench FILE.toml`): the file's checks, a tiny grid
run in this process (resumed without redoing a cell, its OMPL logs read by OMPL's own tools into the same database
as ours), and a cell's determinism under its seed and work budget."""

import copy
import sqlite3
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pliant.errors import ConfigError
from pliant.experiments.benchfile import WALL_TIME_FIELDS, load_benchfile, parse_benchfile, run_benchfile, run_cell
from pliant.experiments.executor import Executor, TaskResult, task_error
from test_ompl_benchmark import dump_database

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "benchmarks" / "files" / "planners-triple-wall-cube-wall-maze.toml"


def _tiny(output) -> dict:
    """2 planners x 1 small problem x 2 seeds, tiny budgets."""
    return {"name": "tiny", "output": str(output), "seeds": 2,
            "problems": [{"scene": "triple-wall", "cost": "voxel", "length_weight": 20.0}],
            "planners": [{"name": "ompl", "algorithm": "RRTConnect"}, {"name": "straight"}],
            "budgets": [{"max_iterations": 40, "max_time": 120.0}]}


class Serial(Executor):
    """Runs the tasks in this process, one after the other; ``interrupt_after``: Ctrl-C after that many."""

    def __init__(self, interrupt_after: int | None = None) -> None:
        super().__init__()
        self.calls = 0
        self.interrupt_after = interrupt_after

    def run(self, work, tasks, stop=None, *, errors="raise"):
        for k, task in enumerate(tasks):
            if self.interrupt_after is not None and self.calls >= self.interrupt_after:
                raise KeyboardInterrupt
            self.calls += 1
            try:
                record = work(*task)
            except Exception as exc:
                if errors == "raise":
                    raise
                yield TaskResult(k, {}, error=task_error(exc))
                continue
            yield TaskResult(k, record, {}, "here", 0.0)


def test_the_bundled_file_is_the_issue_35_grid():
    bench = load_benchfile(EXAMPLE)
    assert [p.name for p in bench.problems] == ["triple-wall", "cube-wall", "se2-maze"]
    labels = [p.label for p in bench.planners]
    assert {"rrtstar", "trrt", "gradient-trrt"} <= set(labels)
    assert len([label for label in labels if label.startswith("ompl-")]) >= 5
    cells = bench.grid()
    assert len(cells) == 3 * len(labels) * len(bench.seeds) and len({c["key"] for c in cells}) == len(cells)
    # a planner declaring length_weight (rrtstar, ompl) gets the problem's; T-RRT declares none
    triple = [c for c in cells if c["problem"] == "triple-wall"]
    assert {c["pipeline"]["planner"].get("length_weight") for c in triple if c["planner"] == "rrtstar"} == {20.0}
    assert all("length_weight" not in c["pipeline"]["planner"] for c in cells if c["planner"] == "trrt")
    cube = next(c for c in cells if c["problem"] == "cube-wall")      # a pipeline problem: its robot kept
    assert cube["pipeline"]["robot"]["rotation_weight"] == 0.2 and cube["pipeline"]["planning"]["max_iterations"]


BAD = [  # (change to the tiny file, field named, value named)
    (lambda d: d.update(seeds=0), "seeds", 0),
    (lambda d: d.update(seeds=[1, 1]), "seeds", [1, 1]),
    (lambda d: d.update(seeds=[0, -2]), "seeds[1]", -2),
    (lambda d: d.update(seeds="3"), "seeds", "3"),
    (lambda d: d.pop("seeds"), "seeds", None),
    (lambda d: d.update(colour="red"), "colour", "red"),
    (lambda d: d.update(problems=[]), "problems", []),
    (lambda d: d["problems"][0].update(scene="no-such-scene"), "problems[0].scene", "no-such-scene"),
    (lambda d: d["problems"][0].update(pipeline="demo"), "problems[0]", None),
    (lambda d: d["problems"][0].update(length_weight=-1.0), "problems[0].length_weight", -1.0),
    (lambda d: d["problems"][0].update(set=["nonsense.x=1"]), "problems[0].set: nonsense.x", 1),
    (lambda d: d["problems"][0].update(speed=2), "problems[0].speed", 2),
    (lambda d: d["planners"][0].update(name="no-such-planner"), "planners[0].name", "no-such-planner"),
    (lambda d: d["planners"][0].update(algorithm="NoSuchOMPLPlanner"), "planners[0].algorithm", "NoSuchOMPLPlanner"),
    (lambda d: d["planners"][0].update(max_iterations=5), "planners[0].max_iterations", 5),
    (lambda d: d["planners"][1].update(label="ompl-RRTConnect"), "planners[1].label", "ompl-RRTConnect"),
    (lambda d: d["budgets"][0].update(max_iterations=0), "budgets[0].max_iterations", 0),
    (lambda d: d["budgets"][0].update(max_time=-1.0), "budgets[0].max_time", -1.0),
    (lambda d: d["budgets"][0].update(samples=5), "budgets[0].samples", 5),
    (lambda d: d.update(budgets=[{"label": "none"}]), "budgets[0]", None),
    (lambda d: d.update(output=""), "output", ""),
]


@pytest.mark.parametrize("change, field, value", BAD)
def test_every_bad_field_is_one_error_naming_field_and_value(tmp_path, change, field, value):
    data = _tiny(tmp_path)
    change(data)
    with pytest.raises(ConfigError) as caught:
        parse_benchfile(data, source="bad.toml")
    assert caught.value.field == field and caught.value.source == "bad.toml"
    if value is not None:
        assert caught.value.value == value


junk = st.one_of(st.none(), st.booleans(), st.integers(-5, 5), st.floats(allow_nan=True), st.text(max_size=4),
                 st.lists(st.integers(-2, 4), max_size=4), st.dictionaries(st.sampled_from(["a", "label",
                                                                                            "max_time"]),
                                                                           st.integers(-1, 3), max_size=2))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(field=st.sampled_from(["seeds", "output", "name", "description", "budgets", "length_weight", "label"]),
       value=junk)
def test_the_loader_accepts_or_names_the_field_never_crashes(tmp_path, field, value):
    data = _tiny(tmp_path)
    if field == "length_weight":
        data["problems"][0][field] = value
    elif field == "label":
        data["planners"][1][field] = value
    else:
        data[field] = value
    try:
        bench = parse_benchfile(data, source="fuzz.toml")
    except ConfigError as exc:
        assert exc.source == "fuzz.toml" and exc.field
    else:
        assert bench.grid() and all(isinstance(s, int) and s >= 0 for s in bench.seeds)


def test_a_tiny_grid_runs_resumes_and_its_logs_load_with_ompls_tools(tmp_path):
    bench = parse_benchfile(_tiny(tmp_path / "out"), source="tiny.toml")
    lines = []
    with pytest.raises(KeyboardInterrupt):          # Ctrl-C after one cell: that cell is kept
        run_benchfile(bench, executor=Serial(interrupt_after=1), echo=lines.append, check=False)
    assert len((tmp_path / "out" / "runs.jsonl").read_text().splitlines()) == 1
    resumed = Serial()
    records = run_benchfile(bench, executor=resumed, echo=lines.append, check=False)
    assert resumed.calls == 3 and len(records) == 4
    assert [r["key"] for r in records] == [c["key"] for c in bench.grid()]
    again = Serial()                                 # all on file: nothing runs
    assert run_benchfile(bench, executor=again, echo=lines.append, check=False, plots=False) == records
    assert again.calls == 0
    for r in records:
        assert r["solved"] == (r["status"] == "solved")
        if r["solved"]:
            assert r["valid"] is True and r["cost"] > 0 and r["length"] > 0
    out = tmp_path / "out"
    report = (out / "report.md").read_text()
    assert "| triple-wall | 40 it, 120 s | ompl-RRTConnect |" in report
    assert [p.name for p in (out / "plots").glob("*.png")] == ["triple-wall-40-it-120-s.png"]
    logs = sorted((out / "logs").glob("*.log"))
    assert [log.name for log in logs] == ["triple-wall.log"]
    ours = sqlite3.connect(out / "benchmark.db")
    rows = ours.execute("SELECT plannerConfigs.name, COUNT(*), SUM(solved) FROM runs JOIN plannerConfigs ON "
                        "runs.plannerid = plannerConfigs.id GROUP BY plannerConfigs.name ORDER BY 1").fetchall()
    solved = {p: sum(r["status"] in ("solved", "approximate") for r in records if r["planner"] == p)
              for p in ("ompl-RRTConnect", "straight")}
    assert rows == [("ompl-RRTConnect", 2, solved["ompl-RRTConnect"]), ("straight", 2, solved["straight"])]
    ours.close()
    tools = pytest.importorskip("ompl.tools", reason="OMPL's Python package (pip install 'pliant[bench]')")
    theirs = tmp_path / "ompl.db"
    tools.readBenchmarkLog(str(theirs), [str(log) for log in logs], False)
    tools.computeViews(str(theirs), False)
    assert dump_database(theirs) == dump_database(out / "benchmark.db")

    # a cell on file whose definition changed is refused, naming it
    changed = copy.deepcopy(_tiny(tmp_path / "out"))
    changed["problems"][0]["length_weight"] = 5.0
    with pytest.raises(ConfigError) as caught:
        run_benchfile(parse_benchfile(changed, source="tiny.toml"), executor=Serial(), echo=lines.append,
                      check=False, plots=False)
    assert caught.value.field == "cell" and "seed 0" in caught.value.value

    # determinism: a cell run again under its seed and work budget gives its record (but for the wall times)
    cell = bench.grid()[0]
    first = next(r for r in records if r["key"] == cell["key"])
    rerun = run_cell(cell)
    assert {k: v for k, v in rerun.items() if k not in WALL_TIME_FIELDS} == \
        {k: v for k, v in first.items() if k not in WALL_TIME_FIELDS}


def test_pliant_bench_takes_a_file_and_reports_a_bad_field_in_one_line(tmp_path, capsys):
    from pliant.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text('seeds = -1\n[[problems]]\nscene = "triple-wall"\n[[planners]]\nname = "straight"\n'
                   '[[budgets]]\nmax_iterations = 10\n')
    assert main(["bench", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "seeds" in err and "-1" in err and len(err.splitlines()) == 1


def _session_processes(session: int) -> list[int]:
    """The live processes of a session (Linux /proc): a command started with ``start_new_session`` and its pool."""
    import os

    alive = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[3]) == session and fields[0] != "Z":      # field 6 of stat: the session id
                alive.append(int(entry))
    return alive


def test_sigterm_to_a_background_bench_keeps_the_finished_cells_and_ends_the_pool(tmp_path):
    """`pliant bench ... &` from a script inherits SIGINT ignored; SIGTERM stops it as Ctrl-C does: exit status 130,
    the cells finished so far on file, the report written from them, and no worker left running."""
    import json
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "out"
    path = tmp_path / "bench.toml"                                   # 40 cells of RRT* on triple-wall
    path.write_text("\n".join([f'name = "sigterm"\noutput = "{out}"\nseeds = 40', '[[problems]]',
                               'scene = "triple-wall"\ncost = "voxel"\nlength_weight = 20.0', '[[planners]]',
                               'name = "rrtstar"', '[[budgets]]', 'max_iterations = 150\nmax_time = 600.0']) + "\n")
    assert len(load_benchfile(path).grid()) == 40

    def background():                                               # what `&` in a script does to SIGINT
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    process = subprocess.Popen([sys.executable, "-m", "pliant.cli", "bench", str(path), "--jobs", "2"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, preexec_fn=background,
                               start_new_session=True)
    runs = out / "runs.jsonl"
    try:
        while not (runs.exists() and runs.read_text().count("\n") >= 1):  # polled: the first cell is on file
            assert process.poll() is None, process.stderr.read().decode()
            time.sleep(0.2)
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130 and "interrupted (SIGTERM)" in err.decode(), err.decode()
    records = [json.loads(line) for line in runs.read_text().splitlines()]
    assert 1 <= len(records) < 40 and len({r["key"] for r in records}) == len(records)
    assert (out / "report.md").exists()
    deadline = time.monotonic() + 30.0                               # the workers end with their parent
    while _session_processes(process.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _session_processes(process.pid) == []
