"""The executor interface (pliant.experiments.executor) with the local pool, and run_tasks on top of it."""

import sys
import threading
import time
from types import SimpleNamespace

import pytest
from pliant.errors import ConfigError, SimulationError
from pliant.experiments import executor as executor_module
from pliant.experiments.executor import (
    LocalExecutor,
    RayExecutor,
    TaskResult,
    add_executor_arguments,
    create,
    from_args,
    using,
)
from pliant.experiments.runs import TasksFailed, open_log, run_tasks
from pliant.files import read_jsonl
from pliant.termination import Termination, iteration_limit


class Listener:
    """A TCP server on loopback that answers a connection as ``kind`` says: ``grpc`` (an HTTP/2 SETTINGS frame, as a
    Ray head's gRPC server does), ``http1`` (an HTTP/1.1 error, as the dashboard's port), ``silent`` (nothing)."""

    def __init__(self, kind: str) -> None:
        import socket

        self.kind = kind
        self.server = socket.create_server(("127.0.0.1", 0))
        self.address = f"127.0.0.1:{self.server.getsockname()[1]}"
        self.connections = []

    def _serve(self) -> None:
        while True:
            try:
                connection, _ = self.server.accept()
            except OSError:
                return
            self.connections.append(connection)
            if self.kind == "grpc":
                connection.sendall(bytes([0, 0, 6, 4, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0, 100]))   # SETTINGS
            elif self.kind == "http1":
                connection.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")

    def __enter__(self) -> "Listener":
        threading.Thread(target=self._serve, daemon=True).start()
        return self

    def __exit__(self, *exc) -> None:
        self.server.close()
        for connection in self.connections:
            connection.close()


def _closed_port() -> int:
    import socket

    with socket.socket() as s:                  # bound, never listening: a connection is refused
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def square(x: int, pause: float = 0.0) -> dict:
    """A seeded, idempotent task that also runs a planner-like loop publishing progress values."""
    stop = Termination(max_iterations=x + 1)
    stop.start()
    i = 0
    while not stop.should_stop(i, best_cost=1.0 / (i + 1)):
        i += 1
    stop.publish(nodes=10 * x)
    time.sleep(pause)
    return {"x": x, "square": x * x}


def test_the_local_pool_runs_every_task_once_and_collects_progress():
    with LocalExecutor(2) as pool:
        results = list(pool.run(square, [(x,) for x in range(6)]))
    assert sorted(r.index for r in results) == list(range(6))
    assert all(isinstance(r, TaskResult) and r.record == {"x": r.index, "square": r.index ** 2} for r in results)
    by_index = {r.index: r for r in results}
    assert by_index[3].progress["nodes"] == 30 and by_index[3].progress["iterations"] == 4
    assert by_index[3].seconds >= 0 and ":" in by_index[3].node and not pool.stopped


def test_run_tasks_appends_each_record_once_and_a_stop_condition_ends_it_early(tmp_path):
    log, records = open_log(tmp_path / "run", "--output")
    lines, summaries = [], []
    run_tasks(square, [(x, 0.3) for x in range(8)], jobs=2, log=log, records=records, describe=str,
              echo=lines.append, stop=iteration_limit(3), on_interrupt=lambda: summaries.append(len(records)))
    on_file, torn = read_jsonl(log)
    assert not torn and on_file == records and 3 <= len(records) < 8
    assert summaries == [len(records)] and lines[-1].startswith("stopped")
    # a resume runs the rest, each task once
    done = {r["x"] for r in records}
    run_tasks(square, [(x, 0.0) for x in range(8) if x not in done], jobs=2, log=log, records=records,
              describe=str, echo=lambda _: None)
    assert sorted(r["x"] for r in read_jsonl(log)[0]) == list(range(8))


def test_a_failing_task_is_recorded_with_its_error_and_the_others_finish(tmp_path):
    from pliant.testing.tasks import fails_for

    tasks = [(k, (1, 4)) for k in range(6)]
    log, records = open_log(tmp_path / "run", "--output")
    lines, summaries = [], []
    with pytest.raises(TasksFailed, match=r"2 of 6 tasks failed \(seed 1: SimulationError: seed: the task's "
                       r"simulator refused its start \(got 1\); seed 4: .*errors.jsonl") as caught:
        run_tasks(fails_for, tasks, jobs=2, log=log, records=records, describe=str, echo=lines.append,
                  label=lambda task: f"seed {task[0]}", on_interrupt=lambda: summaries.append(len(records)))
    # every other task ran to its end and is on file; the summary was written once, after the last of them
    assert sorted(r["seed"] for r in read_jsonl(log)[0]) == [0, 2, 3, 5] and summaries == [4]
    errors = read_jsonl(tmp_path / "run" / "errors.jsonl")[0]
    assert sorted(e["task"] for e in errors) == ["seed 1", "seed 4"] == sorted(f["task"] for f in caught.value.failures)
    assert {e["type"] for e in errors} == {"SimulationError"} and all("fails_for" in e["traceback"] for e in errors)
    assert sum("FAILED seed" in line for line in lines) == 2 and caught.value.exit_status == 3
    # the failed tasks have no record: the same command runs them (here they succeed) and nothing else
    done = {r["seed"] for r in records}
    again = [(k, ()) for k in range(6) if k not in done]
    run_tasks(fails_for, again, jobs=2, log=log, records=records, describe=str, echo=lambda _: None)
    assert sorted(r["seed"] for r in read_jsonl(log)[0]) == list(range(6))


def test_the_executor_re_raises_a_task_error_unless_asked_to_record_it():
    from pliant.testing.tasks import fails_for

    with LocalExecutor(1) as pool:
        with pytest.raises(SimulationError, match="refused its start"):
            list(pool.run(fails_for, [(0, (0,))]))
        [result] = pool.run(fails_for, [(0, (0,))], errors="record")
        assert result.record == {} and result.error["type"] == "SimulationError"
        with pytest.raises(ConfigError, match="errors"):
            list(pool.run(fails_for, [(0, ())], errors="ignore"))


def test_cancel_from_another_thread_stops_the_pool_within_seconds():
    pool = LocalExecutor(2)
    threading.Timer(0.5, pool.cancel).start()
    t0 = time.perf_counter()
    results = list(pool.run(square, [(x, 30.0) for x in range(4)]))
    assert results == [] and pool.stopped and time.perf_counter() - t0 < 10.0


def test_run_tasks_uses_the_installed_executor():
    class Recording(LocalExecutor):
        used = 0

        def run(self, work, tasks, stop=None, *, errors="raise"):
            Recording.used += 1
            yield from super().run(work, tasks, stop, errors=errors)

    records = []
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp, using(Recording(1)):
        log, records = open_log(Path(tmp), "--output")
        run_tasks(square, [(1,), (2,)], jobs=4, log=log, records=records, describe=str, echo=lambda _: None)
    assert Recording.used == 1 and sorted(r["x"] for r in records) == [1, 2]
    assert executor_module.current() is None


def test_executor_flags_and_errors_name_the_flag():
    import argparse

    parser = argparse.ArgumentParser()
    add_executor_arguments(parser)
    assert from_args(parser.parse_args([])) is None                          # the default local pool
    with Listener("grpc") as head:                                         # answers as a Ray head (gRPC) would
        ray = from_args(parser.parse_args(["--executor", "ray", "--address", head.address]))
    assert isinstance(ray, RayExecutor) and ray.address == head.address
    with pytest.raises(ConfigError, match="--address"):
        from_args(SimpleNamespace(executor="local", address="10.0.0.1:6379"))
    with pytest.raises(ConfigError, match="--executor"):
        create("dask")
    with pytest.raises(ConfigError, match="--jobs"):
        LocalExecutor(0)
    with pytest.raises(ConfigError, match="retries"):
        RayExecutor(retries=-1)


def test_ray_missing_is_a_config_error_naming_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)                            # import ray fails
    with pytest.raises(ConfigError, match=r"pliant\[ray\]"):
        RayExecutor("127.0.0.1:1").describe()


def test_the_pliant_command_passes_the_executor_to_the_experiment(monkeypatch, capsys):
    """``--executor`` reaches run_tasks through the installed executor (a bad address fails before any work)."""
    from pliant.cli import main

    assert main(["experiment", "metric-tables", "se2-through-passage", "--executor", "local", "--address", "h:1"]) == 2
    assert "--address" in capsys.readouterr().err


def test_the_local_pool_shows_running_tasks_and_a_cancel_stops_them_by_their_own_conditions(tmp_path):
    from pliant.testing.tasks import anytime

    pool = LocalExecutor(2, grace=10.0, interval=0.2)
    seen = []

    def on_progress(running: dict) -> None:
        seen.append(running)
        if len(running) == 2 and all(values.get("iterations", 0) > 5 for _, values in running.values()):
            pool.cancel()

    pool.on_progress = on_progress
    markers = [tmp_path / f"task{k}" for k in range(4)]
    t0 = time.perf_counter()
    results = list(pool.run(anytime, [(k, 60.0, str(markers[k])) for k in range(4)]))
    assert results == [] and pool.stopped and time.perf_counter() - t0 < 20.0
    assert all(values["nodes"] > 5 and values["best_cost"] < 100 for _, values in seen[-1].values())
    # the running tasks ended through their Termination; queued ones the pool had already handed to its workers'
    # call queue (up to workers + 1 of them) may still start, and each stops at its first check: whatever started
    # was interrupted, and nothing returned a result
    ended = [m.read_text() for m in markers if m.exists()]
    assert set(ended) == {"interrupted"} and 2 <= len(ended) <= len(markers)


def blas_threads() -> dict:
    """What a worker's BLAS sees: the thread variables and the thread count of every loaded OpenBLAS."""
    import ctypes
    import os

    import numpy  # noqa: F401  (loads numpy's OpenBLAS, as every pliant task does)

    counts = []
    with open("/proc/self/maps") as maps:
        paths = sorted({line.split()[-1] for line in maps if "openblas" in line.rsplit("/", 1)[-1].lower()})
    for path in paths:
        library = ctypes.CDLL(path)
        for name in ("openblas_get_num_threads", "openblas_get_num_threads64_", "scipy_openblas_get_num_threads",
                     "scipy_openblas_get_num_threads64_"):
            getter = getattr(library, name, None)
            if getter is not None:
                getter.restype = ctypes.c_int
                counts.append(getter())
                break
    return {"env": {k: os.environ.get(k) for k in executor_module.THREAD_VARIABLES}, "openblas": counts}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/maps")
def test_pool_workers_pin_blas_to_one_thread_unless_the_user_chose(monkeypatch):
    for name in executor_module.THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    with LocalExecutor(1) as pool:
        pinned = next(iter(pool.run(blas_threads, [()]))).record
    assert set(pinned["env"].values()) == {"1"}
    assert all(count == 1 for count in pinned["openblas"])
    with LocalExecutor(1, threads=None) as pool:
        free = next(iter(pool.run(blas_threads, [()]))).record
    assert set(free["env"].values()) == {None}
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")              # the user's choice wins
    with LocalExecutor(1) as pool:
        chosen = next(iter(pool.run(blas_threads, [()]))).record
    assert chosen["env"]["OPENBLAS_NUM_THREADS"] == "2" and chosen["env"]["OMP_NUM_THREADS"] is None
    with pytest.raises(ConfigError, match="threads"):
        LocalExecutor(1, threads=0)


@pytest.mark.parametrize("address", ["not-a-host:port", "127.0.0.1", "127.0.0.1:", ":6379", "127.0.0.1:0",
                                     "127.0.0.1:65536", "127.0.0.1:-1", "127.0.0.1: 6379", "ray://", "a b:6379",
                                     "user@host:6379", "http://host:6379", ""])
def test_an_address_of_the_wrong_form_is_refused_naming_it_without_any_lookup(address, monkeypatch):
    import socket

    def no_lookup(*args, **kwargs):
        raise AssertionError("looked up")

    monkeypatch.setattr(socket, "getaddrinfo", no_lookup)
    monkeypatch.setattr(socket, "create_connection", no_lookup)
    with pytest.raises(ConfigError, match="--address") as caught:
        from_args(SimpleNamespace(executor="ray", address=address))
    assert repr(address) in str(caught.value)
    with pytest.raises(ConfigError, match="--address"):
        RayExecutor(address)


def test_parse_address_reads_the_forms_ray_accepts():
    assert executor_module.parse_address(None) is None and executor_module.parse_address("auto") is None
    assert executor_module.parse_address("10.0.0.1:6379") == ("10.0.0.1", 6379)
    assert executor_module.parse_address("ray://head.example:10001") == ("head.example", 10001)
    assert executor_module.parse_address("[::1]:6379") == ("::1", 6379)


def test_a_head_that_does_not_answer_as_ray_is_refused_within_the_connect_timeout():
    """ray.init retries such an address for minutes; check_head refuses it in seconds, naming --address."""
    refused = f"127.0.0.1:{_closed_port()}"
    with pytest.raises(ConfigError, match=r"--address: cannot reach the Ray head \(Connection refused\)"):
        executor_module.check_head(refused)
    with Listener("http1") as web, pytest.raises(ConfigError, match=r"--address: .*not a Ray head"):
        executor_module.check_head(web.address)
    with Listener("silent") as mute, pytest.raises(ConfigError, match=r"--address: .*does not answer"):
        executor_module.check_head(mute.address, timeout=0.5)
    with Listener("grpc") as head:
        executor_module.check_head(head.address)
        executor_module.check_head("ray://" + head.address)
    executor_module.check_head(None)                        # Ray on this machine alone: nothing to reach


def test_connecting_to_an_unreachable_head_fails_before_ray_init(monkeypatch):
    """``RayExecutor.run`` through the API: the same bounded check, so it never hangs in ``ray.init``."""
    pytest.importorskip("ray")
    import ray

    def init(*args, **kwargs):
        raise AssertionError("ray.init was called")

    monkeypatch.setattr(ray, "init", init)
    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    executor = RayExecutor(f"127.0.0.1:{_closed_port()}")
    with pytest.raises(ConfigError, match="--address"):
        list(executor.run(square, [(1,)]))


@pytest.mark.parametrize("options", [{"grace": -1.0}, {"grace": float("nan")}, {"interval": 0.0},
                                     {"interval": float("inf")}, {"cpus": 0}, {"cpus": True}, {"grace": "5"}])
def test_executor_times_and_cpus_must_be_finite_and_positive(options):
    name = next(iter(options))
    with pytest.raises(ConfigError, match=name):
        RayExecutor(None, **options)
    if name != "cpus":
        with pytest.raises(ConfigError, match=name):
            LocalExecutor(1, **options)


def test_auto_and_a_missing_ray_are_refused_before_the_command_runs(monkeypatch):
    """``--address auto`` with no cluster here (Ray's own lookup says so) and ``--executor ray`` without Ray fail in
    from_args, before a command writes its settings; an auto address Ray finds is checked like any other."""
    pytest.importorskip("ray")
    from ray._private import services

    def none_here(address):
        raise ConnectionError("Could not find any running Ray instance.")

    monkeypatch.setattr(services, "canonicalize_bootstrap_address_or_die", none_here)
    with pytest.raises(ConfigError, match=r"--address: no Ray cluster found on this machine .*'auto'"):
        from_args(SimpleNamespace(executor="ray", address="auto"))
    refused = f"127.0.0.1:{_closed_port()}"
    monkeypatch.setattr(services, "canonicalize_bootstrap_address_or_die", lambda address: refused)
    with pytest.raises(ConfigError, match="--address: cannot reach the Ray head"):
        from_args(SimpleNamespace(executor="ray", address="auto"))
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(ConfigError, match=r"--executor: Ray is not installed"):
        from_args(SimpleNamespace(executor="ray", address=None))
