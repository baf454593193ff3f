"""Planning results in OMPL's benchmark formats, written from pliant's own records, so that pliant's planning
benchmarks can be compared with OMPL's planners in OMPL's tools: the benchmark log
(``ompl::tools::Benchmark::saveResultsToStream``) and the SQLite database its ``ompl_benchmark_statistics`` script
builds from logs (tables experiments, plannerConfigs, enums, runs, progress and two views), which Planner Arena
reads (https://ompl.kavrakilab.org/benchmark.html)."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from pliant.errors import ConfigError
from pliant.files import write_text

__all__ = ["PlannerRuns", "ompl_database", "run_properties", "write_ompl_log"]


#: OMPL's ``ompl::base::PlannerStatus`` in its enum order, as the ``status`` enum of a log
OMPL_STATUS = ("Unknown status", "Invalid start", "Invalid goal", "Unrecognized goal type", "Timeout",
               "Approximate solution", "Exact solution", "Crash", "Abort", "Infeasible")
#: pliant's ``Status`` values -> OMPL's status index
STATUS_TO_OMPL = {"solved": 6, "approximate": 5, "timeout": 4, "invalid start": 1, "invalid goal": 2,
                  "infeasible": 9}


@dataclass
class PlannerRuns:
    """One planner configuration of an OMPL benchmark: its name, its settings (``key -> value``, OMPL's "common
    properties"), one dict of run properties per run (``"time REAL"`` keys: name and SQL type, as OMPL writes them),
    and optionally per run a list of progress samples (dicts with the same kind of keys, e.g. ``"time REAL"``,
    ``"best cost REAL"``)."""

    name: str
    settings: dict
    runs: list[dict]
    progress: list[list[dict]] | None = None


def run_properties(record: dict) -> dict:
    """OMPL's run properties from a pliant planning record (``status`` as in :class:`pliant.results.Status`, ``time``,
    ``cost`` and, when present, ``nodes``, ``iterations``, ``time_to_first``, ``length``): the columns Planner Arena
    plots (time, solved, status, best cost, graph states ...)."""
    status = record.get("status", "solved" if record.get("cost") is not None else "timeout")
    solved = status in ("solved", "approximate")
    out = {"time REAL": record.get("time"), "solved BOOLEAN": int(solved),
           "approximate solution BOOLEAN": int(status == "approximate"),
           "status ENUM": STATUS_TO_OMPL.get(status, 0), "best cost REAL": record.get("cost") if solved else None,
           "memory REAL": record.get("memory", 0.0)}
    for key, column in (("nodes", "graph states INTEGER"), ("iterations", "iterations INTEGER"),
                        ("time_to_first", "time to first solution REAL"), ("length", "solution length REAL"),
                        ("seed", "seed INTEGER")):
        if key in record:
            out[column] = record[key]
    return out


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, float):
        return "nan" if math.isnan(value) else "inf" if math.isinf(value) else repr(value)
    return str(value).replace(";", ",").replace("\n", " ")


def _columns(rows: list[dict]) -> list[str]:
    columns: list[str] = []
    for row in rows:
        for key in row:
            if key not in columns:
                if len(key.split()) < 2:
                    raise ConfigError("an OMPL property is 'name TYPE' (e.g. 'time REAL')", field="property",
                                      value=key)
                columns.append(key)
    return columns


def write_ompl_log(path: Path, experiment: str, planners: Sequence[PlannerRuns], *, time_limit: float,
                   total_time: float, seed: int | str = 0, setup: str = "", memory_limit: float = 0.0,
                   properties: dict | None = None, hostname: str | None = None, date: str | None = None) -> Path:
    """Write an OMPL benchmark log (the format of ``ompl::tools::Benchmark``) for ``planners``; ``properties``:
    experiment properties (``"name TYPE" -> value``).  The file is written atomically."""
    import datetime
    import socket

    from pliant.version import __version__

    if not planners:
        raise ConfigError("needs at least one planner", field="planners", value=[])
    lines = [f"pliant version {__version__}", f"Experiment {experiment.replace(' ', '_')}"]
    properties = dict(properties or {})
    if properties:
        lines.append(f"{len(properties)} experiment properties")
        lines += [f"{key} = {_cell(value)}" for key, value in properties.items()]
    lines += [f"Running on {hostname or socket.gethostname()}",
              f"Starting at {date or datetime.datetime.now().strftime('%Y-%m-%dT%H:%M:%S')}",
              "<<<|", *(setup.rstrip("\n").splitlines() or ["(pliant)"]), "|>>>",
              f"{seed} is the random seed", f"{float(time_limit)} seconds per run",
              f"{float(memory_limit)} MB per run"]
    runcounts = {len(p.runs) for p in planners}
    if len(runcounts) == 1:
        lines.append(f"{runcounts.pop()} runs per planner")
    lines += [f"{float(total_time)} seconds spent to collect the data", "1 enum type",
              "status|" + "|".join(OMPL_STATUS), f"{len(planners)} planners"]
    for planner in planners:
        lines += [planner.name.replace("\n", " "), f"{len(planner.settings)} common properties"]
        lines += [f"{key} = {_cell(value)}" for key, value in planner.settings.items()]
        columns = _columns(planner.runs)
        lines.append(f"{len(columns)} properties for each run")
        lines += columns
        lines.append(f"{len(planner.runs)} runs")
        lines += ["".join(f"{_cell(run.get(c))}; " for c in columns) for run in planner.runs]
        if planner.progress:
            progress_columns = _columns([s for series in planner.progress for s in series])
            lines.append(f"{len(progress_columns)} progress properties for each run")
            lines += progress_columns
            lines.append(f"{len(planner.progress)} runs")
            lines += ["".join("".join(f"{_cell(s.get(c))}," for c in progress_columns) + ";" for s in series)
                      for series in planner.progress]
        lines.append(".")
    write_text(Path(path), "\n".join(lines) + "\n")
    return Path(path)


def ompl_database(database: Path, logs: Sequence[Path]) -> Path:
    """Build OMPL's benchmark database (SQLite, the schema of ``ompl_benchmark_statistics``, with its views
    ``bestPlannerConfigsPerExperiment`` and ``bestPlannerConfigs``) from OMPL benchmark logs -- written by
    :func:`write_ompl_log` or by OMPL itself.  A database already at ``database`` is replaced."""
    import sqlite3

    database = Path(database)
    tmp = database.with_name(database.name + ".tmp")
    tmp.unlink(missing_ok=True)
    connection = sqlite3.connect(tmp)
    try:
        c = connection.cursor()
        c.execute("PRAGMA FOREIGN_KEYS = ON")
        c.executescript(_OMPL_SCHEMA)
        for log in logs:
            _load_log(c, Path(log))
        _ompl_views(c)
        connection.commit()
    finally:
        connection.close()
    os.replace(tmp, database)
    return database


_OMPL_SCHEMA = """
CREATE TABLE IF NOT EXISTS experiments
    (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512), totaltime REAL, timelimit REAL, memorylimit REAL,
     runcount INTEGER, version VARCHAR(128), hostname VARCHAR(1024), cpuinfo TEXT, date DATETIME, seed VARCHAR(24),
     setup TEXT);
CREATE TABLE IF NOT EXISTS plannerConfigs
    (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512) NOT NULL, settings TEXT);
CREATE TABLE IF NOT EXISTS enums (name VARCHAR(512), value INTEGER, description TEXT, PRIMARY KEY (name, value));
CREATE TABLE IF NOT EXISTS runs
    (id INTEGER PRIMARY KEY AUTOINCREMENT, experimentid INTEGER, plannerid INTEGER,
     FOREIGN KEY (experimentid) REFERENCES experiments(id) ON DELETE CASCADE,
     FOREIGN KEY (plannerid) REFERENCES plannerConfigs(id) ON DELETE CASCADE);
CREATE TABLE IF NOT EXISTS progress
    (runid INTEGER, time REAL, PRIMARY KEY (runid, time), FOREIGN KEY (runid) REFERENCES runs(id) ON DELETE CASCADE);
"""


class _Lines:
    def __init__(self, path: Path) -> None:
        self.path = path
        self.lines = path.read_text().splitlines()
        self.k = 0

    def peek(self) -> str:
        return self.lines[self.k] if self.k < len(self.lines) else ""

    def next(self) -> str:
        if self.k >= len(self.lines):
            raise ConfigError("the log ends early", source=str(self.path), field=f"line {self.k + 1}")
        self.k += 1
        return self.lines[self.k - 1]

    def number(self, suffix: str) -> int:
        line = self.next()
        if not line.endswith(suffix):
            raise ConfigError(f"expected '<n> {suffix}'", source=str(self.path), field=f"line {self.k}", value=line)
        return int(line.split()[0])

    def block(self) -> str:
        self.next()                                       # <<<|
        out = []
        while not self.peek().startswith("|>>>"):
            out.append(self.next())
        self.next()
        return "".join(line + "\n" for line in out)


def _value(text: str):
    return None if not text or text in ("nan", "inf") else text


def _load_log(c, path: Path) -> None:
    log = _Lines(path)
    first = log.peek().split()
    version = "OMPL 0.0.0"
    if len(first) > 1 and first[1] == "version":
        version = f"{first[0]} {first[-1]}"
        log.next()
    name = log.next().split()[-1]
    props = {}
    if log.peek().endswith("experiment properties"):
        for _ in range(log.number("experiment properties")):
            key, _, value = log.next().partition(" = ")
            words = key.split()
            props["".join(words[:-1]).replace("-", "_")] = (value, words[-1])
    existing = {row[1] for row in c.execute("PRAGMA table_info(experiments)").fetchall()}
    for key in sorted(props):
        if key not in existing:
            c.execute(f"ALTER TABLE experiments ADD {key} {props[key][1]}")
    hostname = log.next().split()[-1]
    date = " ".join(log.next().split()[2:])
    setup = log.block()
    cpuinfo = log.block() if log.peek().startswith("<<<|") else None
    seed = log.next().split()[0]
    time_limit = float(log.next().split()[0])
    memory_limit = float(log.next().split()[0])
    runcount = log.number("runs per planner") if log.peek().endswith("runs per planner") else -1
    total_time = float(log.next().split()[0])
    if log.peek().split()[-2:-1] == ["enum"] or log.peek().endswith("enum types"):
        for _ in range(int(log.next().split()[0])):
            enum = log.next().split("|")
            if c.execute("SELECT 1 FROM enums WHERE name = ?", (enum[0],)).fetchone() is None:
                c.executemany("INSERT INTO enums VALUES (?,?,?)", [(enum[0], j, d) for j, d in enumerate(enum[1:])])
    columns = ["name", "totaltime", "timelimit", "memorylimit", "runcount", "version", "hostname", "cpuinfo", "date",
               "seed", "setup", *props]
    values = [name, total_time, time_limit, memory_limit, runcount, version, hostname, cpuinfo, date, seed, setup,
              *(v for v, _ in props.values())]
    c.execute(f"INSERT INTO experiments ({','.join(columns)}) VALUES ({','.join('?' * len(values))})", values)
    experiment = c.lastrowid
    for _ in range(log.number("planners")):
        planner = log.next()
        settings = "".join(log.next() + "\n;" for _ in range(log.number("common properties")))
        found = c.execute("SELECT id FROM plannerConfigs WHERE name = ? AND settings = ?",
                          (planner, settings)).fetchone()
        if found is None:
            c.execute("INSERT INTO plannerConfigs VALUES (?,?,?)", (None, planner, settings))
            planner_id = c.lastrowid
        else:
            planner_id = found[0]
        names = _add_columns(c, "runs", [log.next() for _ in range(log.number("properties for each run"))])
        run_ids = []
        for _ in range(log.number("runs")):
            cells = [_value(x) for x in (log.next() + "\n").split("; ")[:-1]]
            c.execute(f"INSERT INTO runs (experimentid,plannerid,{','.join(names)}) "
                      f"VALUES ({','.join('?' * (len(cells) + 2))})", [experiment, planner_id, *cells])
            run_ids.append(c.lastrowid)
        line = log.next().strip()
        if line != ".":
            names = _add_columns(c, "progress", [log.next() for _ in range(int(line.split()[0]))])
            for k in range(log.number("runs")):
                for sample in log.next().split(";")[:-1]:
                    cells = [_value(x) for x in sample.split(",")[:-1]]
                    c.execute(f"INSERT OR IGNORE INTO progress (runid,{','.join(names)}) "
                              f"VALUES ({','.join('?' * (len(cells) + 1))})", [run_ids[k], *cells])
            log.next()                                      # .


def _add_columns(c, table: str, fields: list[str]) -> list[str]:
    existing = {row[1] for row in c.execute(f"PRAGMA table_info({table})").fetchall()}
    names = []
    for field_ in fields:
        words = field_.split()
        name = "_".join(words[:-1])
        if name not in existing:
            c.execute(f"ALTER TABLE {table} ADD {name} {words[-1]}")
            existing.add(name)
        names.append(name)
    return names


def _ompl_views(c) -> None:
    columns = {row[1] for row in c.execute("PRAGMA table_info(runs)").fetchall()}
    total = "time + simplification_time" if "simplification_time" in columns else "time"
    base = (f"SELECT plannerid, plannerConfigs.name AS plannerName, experimentid, solved, {total} AS total_time "
            "FROM plannerConfigs INNER JOIN experiments INNER JOIN runs "
            "ON plannerConfigs.id=runs.plannerid AND experiments.id=runs.experimentid")
    per_experiment = (f"SELECT plannerid, experimentid, MIN(avg_solved) AS avg_solved, avg_total_time FROM "
                      f"(SELECT plannerid, plannerName, experimentid, AVG(solved) AS avg_solved, AVG(total_time) AS "
                      f"avg_total_time FROM ({base}) GROUP BY plannerid, experimentid) GROUP BY plannerName, "
                      "experimentid ORDER BY avg_solved DESC, avg_total_time ASC")
    overall = (f"SELECT plannerid, MIN(avg_solved) AS avg_solved, avg_total_time FROM (SELECT plannerid, "
               f"plannerName, AVG(solved) AS avg_solved, AVG(total_time) AS avg_total_time FROM ({base}) GROUP BY "
               "plannerid) GROUP BY plannerName ORDER BY avg_solved DESC, avg_total_time ASC")
    c.execute("DROP VIEW IF EXISTS bestPlannerConfigsPerExperiment")
    c.execute(f"CREATE VIEW bestPlannerConfigsPerExperiment AS {per_experiment}")
    c.execute("DROP VIEW IF EXISTS bestPlannerConfigs")
    c.execute(f"CREATE VIEW bestPlannerConfigs AS {overall}")
