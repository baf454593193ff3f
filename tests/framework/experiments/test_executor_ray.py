"""The Ray executor on a real two-node cluster on this machine: a head and a second worker node, each its own
``ray start`` process (with its own raylet and workers), talking over the network stack.

The experiment is real: the path metric's Table 6.x evaluations (``pliant metric-table``'s task function) on
se2-through-passage, 5 cells x 2 runs of the Simulation method with 800 simulations each (1.3-1.7 s a task on an
idle core of the 2-core test machine, measured in one process: long enough that the worker node, which starts its
first task later than the head, runs some before it is killed).
The worker node is killed (``SIGKILL`` to its whole process group) once both nodes have returned a result, before the
last; every task must still finish exactly once, with records equal to the local pool's (but for the wall time
``seconds``).
"""

import re
import time

import pytest

ray = pytest.importorskip("ray", reason="the Ray executor's tests need pip install 'pliant[ray]'")

from pliant.experiments.executor import LocalExecutor, LoopbackCluster, RayExecutor, using  # noqa: E402
from pliant.experiments.runs import open_log, run_tasks  # noqa: E402
from pliant.files import read_jsonl  # noqa: E402
from pliant.termination import iteration_limit  # noqa: E402

pytestmark = pytest.mark.slow
TASK = "se2-through-passage"
#: simulations per task: 1.3-1.7 s with the compiled rollout kernel and start check (50 took 0.1 s, and the head node
#: could finish the first results before the worker node ran any)
SIMULATIONS = 800
#: cells of the table per run: 10 tasks, of which the worker node is killed after the first result of each node
CELLS = 5


@pytest.fixture(scope="module")
def cluster():
    """A head (1 CPU) and a worker node (1 CPU) on this machine; both process groups are killed afterwards."""
    with LoopbackCluster(nodes=2, cpus=1) as running:
        try:
            yield running
        finally:
            if ray.is_initialized():
                ray.shutdown()


def _tasks() -> list[tuple]:
    from pliant_reachability.evaluation import task_density
    from pliant_reachability.tasks import TASKS

    density = task_density(TASKS[TASK])
    return [(TASK, "simulation", cell, run, density, SIMULATIONS, {}, 5) for run in range(2) for cell in range(CELLS)]


def _timeless(records: list[dict]) -> dict:
    return {(r["cell"], r["run"]): {k: v for k, v in r.items() if k != "seconds"} for r in records}


def _connected(address: str, cpus: float) -> RayExecutor:
    executor = RayExecutor(address, grace=2.0)
    executor.wait_for_cpus(cpus)
    return executor


def test_the_pliant_command_runs_an_experiment_on_the_cluster(cluster, tmp_path, capsys):
    """``pliant experiment metric-tables se2-through-passage --quick --runs 1 --methods simulation --executor ray
    --address ...``: the command-line path end to end (every experiment and reproduction takes ``--executor`` from
    the same place, :func:`pliant.cli.main`); 9 cells of 300 simulations, a few seconds."""
    from pliant.cli import main

    RayExecutor(cluster.address).wait_for_cpus(2)
    ray.shutdown()
    assert main(["experiment", "metric-tables", TASK, "--quick", "--runs", "1", "--methods", "simulation",
                 "--output", str(tmp_path), "--executor", "ray", "--address", cluster.address]) == 0
    out = capsys.readouterr().out
    assert out.count("[node ") == 9 and "written:" in out                  # nine cells, each naming its Ray node
    records = read_jsonl(tmp_path / "metric-tables-quick" / "runs.jsonl")[0]
    assert sorted(r["cell"] for r in records) == list(range(9))


def test_a_stop_condition_cancels_the_tasks_left_on_the_cluster(cluster, tmp_path, monkeypatch):
    import ray
    from pliant_reachability.tables import _evaluate

    cancels, cancel = [], ray.cancel
    monkeypatch.setattr(ray, "cancel", lambda ref, **options: (cancels.append(options), cancel(ref, **options))[1])
    executor = _connected(cluster.address, 2)
    try:
        assert "2 nodes" in executor.describe()
        log, records = open_log(tmp_path / "stopped", "--output")
        run_tasks(_evaluate, _tasks(), jobs=1, log=log, records=records, describe=str, echo=lambda _: None,
                  executor=executor, stop=iteration_limit(2))
        assert executor.stopped and 2 <= len(records) < 2 * CELLS           # the tasks left were cancelled, not run
        assert read_jsonl(log)[0] == records
    finally:
        executor.close()
    # queued tasks are cancelled through the progress board, never by a cooperative ray.cancel (whose race with a
    # worker being handed the task aborts this process in Ray 2.60: docs/experiments.md); only a started task that
    # outlives the grace is killed
    assert all(options.get("force") for options in cancels), cancels


def test_a_task_error_on_the_cluster_is_recorded_with_the_workers_traceback(cluster):
    from pliant.testing.tasks import fails_for

    executor = _connected(cluster.address, 2)
    try:
        results = sorted(executor.run(fails_for, [(k, (2,)) for k in range(4)], errors="record"),
                         key=lambda r: r.index)
    finally:
        executor.close()
    assert [r.record for r in results] == [{"seed": 0}, {"seed": 1}, {}, {"seed": 3}]
    error = results[2].error
    assert error["type"] == "SimulationError" and "refused its start" in error["message"]
    assert "fails_for" in error["traceback"]


def test_running_tasks_report_progress_live_and_a_cancel_stops_them_by_their_own_conditions(cluster, tmp_path):
    from pliant.testing.tasks import anytime

    executor = RayExecutor(cluster.address, grace=10.0, interval=0.5)
    executor.wait_for_cpus(2)
    seen = []

    def busy(running: dict) -> list:
        return [(node, values) for node, values in running.values() if values.get("iterations", 0) > 5]

    def on_progress(running: dict) -> None:
        seen.append(running)
        # two tasks well under way on the two nodes (a third may be running too: a task blocked in ray.get lends its
        # CPU to the queue, so "exactly two running" may never be seen)
        if len({node.split()[1] for node, _ in busy(running)}) == 2:
            executor.cancel()                                   # from the progress callback, as a viewer would

    executor.on_progress = on_progress
    markers = [tmp_path / f"task{k}" for k in range(4)]
    try:
        results = list(executor.run(anytime, [(k, 60.0, str(markers[k])) for k in range(4)]))
    finally:
        executor.close()
    assert executor.stopped and results == []
    live = seen[-1]
    assert len({node.split()[1] for node, _ in busy(live)}) == 2                  # what the cancel saw
    assert all(values["best_cost"] < 100 and values["nodes"] > 5 for _, values in busy(live))
    # the two running tasks ended through their Termination (interrupted).  A queued task may have started too: a
    # task blocked in ray.get (its progress report) lends its CPU to the queue, so Ray can start one before the
    # cancel reaches it; whatever started was interrupted in the same way, and nothing returned a result
    assert all(markers[index].read_text() == "interrupted" for index in live)
    assert {m.read_text() for m in markers if m.exists()} == {"interrupted"}


def test_a_killed_worker_node_loses_no_task_and_the_records_equal_the_local_pools(cluster, tmp_path):
    from pliant_reachability.tables import _evaluate

    tasks = _tasks()
    log, local = open_log(tmp_path / "local", "--output")
    run_tasks(_evaluate, tasks, jobs=2, log=log, records=local, describe=str, echo=lambda _: None,
              executor=LocalExecutor(2))

    executor = _connected(cluster.address, 2)
    lines, killed = [], []

    def echo(line: str) -> None:
        lines.append(line)
        # mid-run, once both nodes have returned a result: the worker node dies with the task it has just been
        # given (a fixed count of results, e.g. the third, can all come from the head when the load delays the
        # worker node's first task, and killing a node that never ran a task tests nothing)
        nodes = {re.search(r"node ([0-9a-f]{8})", seen).group(1) for seen in lines}
        if len(nodes) == 2 and not killed and not line.startswith(f"[{len(tasks)}/"):
            cluster.kill_node(1)
            killed.append(time.monotonic())

    log, records = open_log(tmp_path / "ray", "--output")
    with using(executor):                                          # as `pliant ... --executor ray` installs it
        run_tasks(_evaluate, tasks, jobs=1, log=log, records=records, describe=lambda r: f"cell {r['cell']}",
                  echo=echo)
    assert killed, "the run ended before the worker node was killed"
    on_file, torn = read_jsonl(log)
    keys = [(r["cell"], r["run"]) for r in on_file]
    assert not torn and len(keys) == len(set(keys)) == len(tasks)             # every task exactly once
    assert _timeless(on_file) == _timeless(local)                               # the local pool's records
    nodes = {re.search(r"node ([0-9a-f]{8})", line).group(1) for line in lines}
    assert len(nodes) == 2, lines                                               # both nodes ran tasks
