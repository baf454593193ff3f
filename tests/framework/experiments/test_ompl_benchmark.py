"""Results in OMPL's benchmark formats (pliant.experiments.ompl): the log is read by OMPL's own benchmark statistics
script, and our database equals the one OMPL builds from the same log."""

import sqlite3

import pytest
from pliant.errors import ConfigError
from pliant.experiments.ompl import PlannerRuns, ompl_database, run_properties, write_ompl_log


def _planners() -> list[PlannerRuns]:
    records = [{"status": "solved", "time": 2.5, "cost": 543.0, "nodes": 812, "iterations": 900, "seed": 0},
               {"status": "timeout", "time": 60.0, "cost": None, "nodes": 4000, "iterations": 5000, "seed": 1},
               {"status": "approximate", "time": 3.25, "cost": 700.5, "nodes": 100, "iterations": 120, "seed": 2}]
    progress = [[{"time REAL": 0.5, "best cost REAL": float("nan")}, {"time REAL": 1.0, "best cost REAL": 600.0}],
                [{"time REAL": 0.5, "best cost REAL": float("nan")}],
                [{"time REAL": 0.5, "best cost REAL": 800.0}, {"time REAL": 1.5, "best cost REAL": 700.5}]]
    return [PlannerRuns("gradient-trrt", {"n_fail_max": 10, "max_step": 0.1}, [run_properties(r) for r in records],
                        progress),
            PlannerRuns("trrt", {"n_fail_max": 10}, [run_properties(records[0])])]


def dump_database(path) -> dict:
    """Every table and view of the SQLite database at ``path``: sorted columns and rows (order-free comparison)."""
    connection = sqlite3.connect(path)
    try:
        out = {}
        for (table,) in connection.execute("SELECT name FROM sqlite_master WHERE type IN ('table', 'view') "
                                           "AND name NOT LIKE 'sqlite_%' ORDER BY name"):
            columns = [row[1] for row in connection.execute(f"PRAGMA table_info({table})")]
            rows = connection.execute(f"SELECT * FROM {table}").fetchall()
            out[table] = (sorted(columns), sorted(tuple(sorted(zip(columns, map(str, r)))) for r in rows))
        return out
    finally:
        connection.close()


def test_the_log_replays_through_omplss_statistics_script_and_our_database_matches(tmp_path):
    tools = pytest.importorskip("ompl.tools", reason="OMPL's Python package (pip install 'pliant[bench]')")
    log = write_ompl_log(tmp_path / "trrt.log", "cube-wall table 3.1", _planners(), time_limit=60.0,
                         total_time=65.75, seed=7, setup="pipeline cube-wall-trrt",
                         properties={"task INTEGER": 3}, hostname="host", date="2026-11-25T20:00:00")
    theirs = tmp_path / "ompl.db"
    tools.readBenchmarkLog(str(theirs), [str(log)], False)
    tools.computeViews(str(theirs), False)
    ours = ompl_database(tmp_path / "pliant.db", [log])
    assert dump_database(ours) == dump_database(theirs)
    connection = sqlite3.connect(ours)
    runs = connection.execute("SELECT plannerConfigs.name, solved, status, best_cost, graph_states FROM runs JOIN "
                              "plannerConfigs ON runs.plannerid = plannerConfigs.id ORDER BY runs.id").fetchall()
    assert runs == [("gradient-trrt", 1, 6, 543.0, 812), ("gradient-trrt", 0, 4, None, 4000),
                    ("gradient-trrt", 1, 5, 700.5, 100), ("trrt", 1, 6, 543.0, 812)]
    status = dict(connection.execute("SELECT value, description FROM enums WHERE name = 'status'").fetchall())
    assert status[6] == "Exact solution" and status[4] == "Timeout"
    assert connection.execute("SELECT COUNT(*), COUNT(best_cost) FROM progress").fetchone() == (5, 3)
    assert connection.execute("SELECT task, runcount FROM experiments").fetchone() == (3, -1)
    best = connection.execute("SELECT plannerid FROM bestPlannerConfigs").fetchall()
    assert len(best) == 2


def test_bad_properties_and_empty_experiments_are_errors(tmp_path):
    with pytest.raises(ConfigError, match="planners"):
        write_ompl_log(tmp_path / "x.log", "x", [], time_limit=1, total_time=1)
    with pytest.raises(ConfigError, match="property"):
        write_ompl_log(tmp_path / "x.log", "x", [PlannerRuns("p", {}, [{"time": 1.0}])], time_limit=1, total_time=1)
