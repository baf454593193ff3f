"""The Ray executor on a real two-node cluster on this machine: a head and a second worker node, each its own
``ray start`` process (with its own raylet and workers), talking over the network stack.

The experiment is real: the path metric's Table 6.x evaluations (``pliant metric-table``'s task function) on
se2-through-passage, 9 cells x 2 runs of the Simulation method with 50 simulations each (about 0.7 s a task).
The worker node is killed (``SIGKILL`` to its whole process group) after the third result; every task must still
finish exactly once, with records equal to the local pool's (but for the wall time ``seconds``).
"""

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

ray = pytest.importorskip("ray", reason="the Ray executor's tests need pip install 'pliant[ray]'")

from pliant.executor import LocalExecutor, RayExecutor, using  # noqa: E402
from pliant.experiment import open_log, run_tasks  # noqa: E402
from pliant.files import read_jsonl  # noqa: E402
from pliant.termination import iteration_limit  # noqa: E402

pytestmark = pytest.mark.slow
RAY = str(Path(sys.executable).with_name("ray"))
TASK = "se2-through-passage"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(condition, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.2)
    raise TimeoutError(what)


def _start(args: list[str], log: Path) -> subprocess.Popen:
    """``ray start --block ...`` in its own process group (so the group is its raylet and workers, and only they)."""
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    return subprocess.Popen([RAY, "start", "--block", "--disable-usage-stats", "--num-cpus=1",
                             "--object-store-memory=80000000", f"--dashboard-agent-listen-port={_free_port()}",
                             *args], stdout=log.open("w"), stderr=subprocess.STDOUT, start_new_session=True, env=env)


def _kill(process: subprocess.Popen) -> None:
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    process.wait(10)


@pytest.fixture(scope="module")
def cluster():
    """A head (1 CPU) and a worker node (1 CPU) on loopback; both process groups are killed afterwards."""
    temp = Path(tempfile.mkdtemp(prefix="pliant-ray-", dir="/tmp"))        # short: Ray's socket paths
    head_log = temp / "head.log"
    head = _start(["--head", f"--port={_free_port()}", "--node-ip-address=127.0.0.1", "--include-dashboard=false",
                   f"--temp-dir={temp / 'ray'}"], head_log)
    processes = [head]
    try:
        # Ray replaces 127.0.0.1 by this machine's own address (reachable from other nodes); read it back
        address = _wait(lambda: (m := re.search(r"--address='([^']+)'", head_log.read_text())) and m.group(1),
                        60.0, f"the Ray head did not start: {head_log.read_text()[-2000:]}")
        worker = _start([f"--address={address}"], temp / "worker.log")
        processes.append(worker)
        yield {"address": address, "head": head, "worker": worker, "temp": temp}
    finally:
        if ray.is_initialized():
            ray.shutdown()
        for process in processes:
            _kill(process)
        shutil.rmtree(temp, ignore_errors=True)


def _tasks() -> list[tuple]:
    from pliant_reachability.evaluation import task_density
    from pliant_reachability.tasks import TASKS

    density = task_density(TASKS[TASK])
    return [(TASK, "simulation", cell, run, density, 50, {}, 5) for run in range(2) for cell in range(9)]


def _timeless(records: list[dict]) -> dict:
    return {(r["cell"], r["run"]): {k: v for k, v in r.items() if k != "seconds"} for r in records}


def _connected(address: str, cpus: float) -> RayExecutor:
    executor = RayExecutor(address, grace=2.0)
    _wait(lambda: executor.cluster_cpus() >= cpus, 60.0, "the worker node did not join")
    return executor


def test_a_stop_condition_cancels_the_tasks_left_on_the_cluster(cluster, tmp_path):
    from pliant_reachability.tables import _evaluate

    executor = _connected(cluster["address"], 2)
    try:
        assert "2 nodes" in executor.describe()
        log, records = open_log(tmp_path / "stopped", "--output")
        t0 = time.monotonic()
        run_tasks(_evaluate, _tasks(), jobs=1, log=log, records=records, describe=str, echo=lambda _: None,
                  executor=executor, stop=iteration_limit(2))
        assert executor.stopped and 2 <= len(records) < 18 and time.monotonic() - t0 < 30.0
        assert read_jsonl(log)[0] == records
    finally:
        executor.close()


def test_a_killed_worker_node_loses_no_task_and_the_records_equal_the_local_pools(cluster, tmp_path):
    from pliant_reachability.tables import _evaluate

    tasks = _tasks()
    log, local = open_log(tmp_path / "local", "--output")
    run_tasks(_evaluate, tasks, jobs=2, log=log, records=local, describe=str, echo=lambda _: None,
              executor=LocalExecutor(2))

    executor = _connected(cluster["address"], 2)
    lines, killed = [], []

    def echo(line: str) -> None:
        lines.append(line)
        if line.startswith("[3/") and not killed:                 # mid-run: the worker node dies with its tasks
            _kill(cluster["worker"])
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
