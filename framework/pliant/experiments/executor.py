"""Where an experiment's tasks run: a local process pool (the default) or a Ray cluster (``pip install
'pliant[ray]'``), behind one interface (docs/experiments.md).

A task is ``work(*args)`` returning a JSON-able record; tasks are seeded and idempotent, so a task run twice -- a
retry after a worker or node died -- returns the same record.  :func:`pliant.experiments.runs.run_tasks` gives the
records to the caller as they finish and appends each to the run's ``runs.jsonl`` in *this* process, so the result
store, resuming and Ctrl-C behave the same whichever executor ran the tasks.

- :class:`LocalExecutor`: ``jobs`` worker processes on this machine, which end with their parent (even on
  ``kill -9``); Ctrl-C cancels the queue and ends them within seconds.
- :class:`RayExecutor`: every task is a Ray task asking for one CPU, submitted at once; the cluster's CPUs decide
  how many run together.  A task whose worker process or node dies is run again elsewhere (``retries`` times).
  Cancelling marks the run's progress board cancelled: every stop condition a running task polls terminates,
  and a queued task returns without work when it starts; the tasks still running after ``grace`` seconds are
  killed.

Both run each task inside :func:`pliant.termination.task_progress`, so the progress values the task's planners
publish (``iterations``, ``best_cost``, ``nodes`` ...) come back with its record (:attr:`TaskResult.progress`),
and a result names the node that ran it.

Commands that run many tasks get ``--executor local|ray --address ADDR`` from :func:`add_executor_arguments`;
the ``pliant`` command installs the chosen executor for the command's duration (:func:`using`), and
:func:`pliant.experiments.runs.run_tasks` uses it instead of its local pool.
"""

from __future__ import annotations

import importlib.util
import math
import os
import socket
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, ProcessPoolExecutor
from concurrent.futures import wait as wait_futures
from contextlib import contextmanager
from dataclasses import dataclass, field

from pliant.errors import ConfigError, PliantError
from pliant.termination import Condition, snapshot, task_progress

#: how often a waiting executor checks its stop condition and cancel requests (s)
POLL = 0.1
EXECUTORS = ("local", "ray")
#: how long reaching a Ray head may take before ``--address`` is refused (s): connecting and its first answer
CONNECT_TIMEOUT = 5.0
#: the client's first bytes of an HTTP/2 connection (RFC 9113, 3.4): the preface, then an empty SETTINGS frame
_HTTP2_HELLO = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])
_ADDRESS_FORM = "must be HOST:PORT (port 1-65535), ray://HOST:PORT, auto, or left out (Ray on this machine alone)"


def parse_address(address: str | None) -> tuple[str, int] | None:
    """``(host, port)`` of a Ray head's ``address`` (``host:port``, ``[v6]:port`` or ``ray://host:port``), or None
    for the addresses Ray resolves itself (None: a Ray instance of this process's own; ``auto``: the cluster this
    machine belongs to).  Anything else is a :class:`ConfigError` naming ``--address``; nothing is looked up."""
    if address is None or address == "auto":
        return None
    text = address[len("ray://"):] if isinstance(address, str) and address.startswith("ray://") else address
    if not isinstance(text, str) or ":" not in text:
        raise ConfigError(_ADDRESS_FORM, field="--address", value=address)
    host, _, port = text.rpartition(":")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    if (not host or any(c.isspace() or c in "/[]@" for c in host) or not port.isascii() or not port.isdigit()
            or not 1 <= int(port) <= 65535):
        raise ConfigError(_ADDRESS_FORM, field="--address", value=address)
    return host, int(port)


def check_head(address: str | None, timeout: float = CONNECT_TIMEOUT) -> None:
    """Refuse, within about ``timeout`` seconds, an ``address`` where no Ray head answers -- a refused or timed-out
    connection, an unknown host, or a server that does not speak gRPC (Ray's protocol: HTTP/2; e.g. the dashboard's
    port) -- with a :class:`ConfigError` naming ``--address``.  ``ray.init`` itself retries such an address for many
    minutes.  With ``RAY_USE_TLS`` set only the connection is checked."""
    if address == "auto":
        address = _auto_address()
    parsed = parse_address(address)
    if parsed is None:
        return
    host, port = parsed
    try:
        connection = socket.create_connection((host, port), timeout=timeout)
    except socket.gaierror as exc:
        raise ConfigError(f"unknown host ({exc.strerror or exc})", field="--address", value=address) from None
    except TimeoutError:
        raise ConfigError(f"no Ray head answers within {timeout:g} s", field="--address", value=address) from None
    except OSError as exc:
        raise ConfigError(f"cannot reach the Ray head ({exc.strerror or exc})", field="--address",
                          value=address) from None
    with connection:
        if os.environ.get("RAY_USE_TLS", "0").lower() in ("1", "true"):
            return
        try:
            connection.settimeout(timeout)
            connection.sendall(_HTTP2_HELLO)
            answer = b""
            while len(answer) < 9:
                chunk = connection.recv(9 - len(answer))
                if not chunk:
                    break
                answer += chunk
        except TimeoutError:
            raise ConfigError(f"something listens there but does not answer as a Ray head within {timeout:g} s",
                              field="--address", value=address) from None
        except OSError as exc:
            raise ConfigError(f"the connection to the Ray head failed ({exc.strerror or exc})", field="--address",
                              value=address) from None
    if len(answer) < 9 or answer[3] != 4:          # a gRPC server's first frame is SETTINGS (type 4)
        raise ConfigError("something listens there but it is not a Ray head (no gRPC answer; the head's address "
                          "is the one `ray start --head` prints, port 6379 by default)", field="--address",
                          value=address)


def _auto_address() -> str | None:
    """The head's address ``--address auto`` means (``RAY_ADDRESS``, else the cluster this machine runs), as Ray
    finds it; None when Ray cannot tell here (``ray.init`` then decides).  No cluster at all is a ConfigError."""
    try:
        from ray._private.services import canonicalize_bootstrap_address_or_die
    except ImportError:                         # no Ray (said when connecting), or a Ray without this function
        return None
    try:
        return canonicalize_bootstrap_address_or_die("auto")
    except ConnectionError as exc:
        raise ConfigError(f"no Ray cluster found on this machine ({exc})", field="--address", value="auto") from None
    except Exception:                           # a Ray of another shape: ray.init decides
        return None


def _positive(value, name: str, *, zero: bool = False) -> float:
    """``value`` as a float if it is a finite number > 0 (>= 0 with ``zero``); else a ConfigError naming it."""
    ok = (not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
          and (value >= 0 if zero else value > 0))
    if not ok:
        raise ConfigError(f"must be a finite number {'>= 0' if zero else '> 0'}", field=name, value=value)
    return float(value)


class ExecutorError(PliantError):
    """A task could not be run (its worker or node died more often than the executor retries, or the cluster
    has another pliant version)."""


@dataclass
class TaskResult:
    """One finished task: its position in the submitted list, its record, the progress values its conditions
    published (:func:`pliant.termination.task_progress`), where it ran and how long it took there (s)."""

    index: int
    record: dict
    progress: dict = field(default_factory=dict)
    node: str = ""
    seconds: float = 0.0
    #: the task raised (only with ``errors="record"``): ``{"type", "message", "traceback"}``; ``record`` is empty
    error: dict | None = None


#: what :meth:`Executor.run` does with a task that raises: re-raise it here (the other tasks are cancelled), or
#: yield it as a :class:`TaskResult` with its :attr:`~TaskResult.error` and go on with the others
TASK_ERRORS = ("raise", "record")


def task_error(exc: BaseException, traceback_text: str | None = None) -> dict:
    """``{"type", "message", "traceback"}`` of a task's exception as it reaches this process, with the worker's
    traceback: ``traceback_text`` (Ray's error text), else a process pool's ``__cause__``, else this process's."""
    import traceback

    remote = getattr(exc.__cause__, "tb", None)             # concurrent.futures' _RemoteTraceback
    text = traceback_text or (remote if isinstance(remote, str) else "".join(traceback.format_exception(exc)))
    return {"type": type(exc).__name__, "message": str(exc), "traceback": text}


def _check_errors(errors: str) -> str:
    if errors not in TASK_ERRORS:
        raise ConfigError(f"must be one of {', '.join(TASK_ERRORS)}", field="errors", value=errors)
    return errors


def call_task(work: Callable[..., dict], args: tuple, board: str | None = None, index: int = -1,
              interval: float = 1.0) -> tuple[dict, dict, str, float, str]:
    """Run one task where the executor placed it: ``(record, progress, node, seconds, pliant version)``.

    ``board``: the name of a Ray actor (:class:`ProgressBoard`) the task reports its progress values to every
    ``interval`` seconds while it runs; its answer says whether the executor cancelled the task, which then
    terminates every stop condition the task polls (:func:`pliant.termination.task_progress`).  In a local pool's
    worker the pool's queue and event (:func:`worker_init`) do the same."""
    from pliant.version import __version__

    t0 = time.perf_counter()
    node = _node()
    cancel = threading.Event()
    done = threading.Event()

    def report(sink: dict) -> None:
        import ray

        actor = None
        while not done.wait(interval):          # a task shorter than ``interval`` never reports
            try:
                actor = actor or ray.get_actor(board)
                if ray.get(actor.report.remote(index, node, snapshot(sink))):
                    cancel.set()
            except Exception:                   # the board is gone (the run ended): stop reporting
                return

    def report_local(sink: dict) -> None:
        queue, cancelled = _channel
        last = time.monotonic()
        while not done.wait(POLL):
            if cancelled.is_set():
                cancel.set()
            if time.monotonic() - last >= interval:
                last = time.monotonic()
                try:
                    queue.put_nowait((index, node, snapshot(sink)))
                except Exception:               # the pool is ending: stop reporting
                    return

    if board is not None and _start_on_board(board, index):
        # a queued task that starts after the run was cancelled (the executor cancels queued tasks this way, not
        # through Ray): it does no work, and the executor drops its result
        return {}, {}, node, time.perf_counter() - t0, __version__
    with task_progress(cancel) as sink:
        if board is not None:
            threading.Thread(target=report, args=(sink,), name="pliant-progress", daemon=True).start()
        elif _channel is not None and index >= 0:
            threading.Thread(target=report_local, args=(sink,), name="pliant-progress", daemon=True).start()
        try:
            record = work(*args)
        finally:
            done.set()
    return record, snapshot(sink), node, time.perf_counter() - t0, __version__


def _start_on_board(board: str, index: int) -> bool:
    """Tell the run's progress board (named ``board``) that task ``index`` starts; returns whether the run was
    cancelled (a board that cannot be reached: no, the task runs and the executor kills it after its grace)."""
    import ray

    try:
        return bool(ray.get(ray.get_actor(board).start.remote(index), timeout=5.0))
    except Exception:
        return False


class ProgressBoard:
    """Where running tasks on a cluster report their progress values, and learn that they were cancelled (a Ray
    actor of no CPU, one per run)."""

    def __init__(self) -> None:
        self.running: dict[int, tuple[str, dict]] = {}
        self.started: set[int] = set()
        self.cancelled = False

    def report(self, index: int, node: str, values: dict) -> bool:
        """A running task's latest values; returns whether the run was cancelled."""
        self.running[index] = (node, values)
        return self.cancelled

    def snapshot(self) -> dict[int, tuple[str, dict]]:
        """Every running task's node and latest values."""
        return dict(self.running)

    def cancel(self) -> None:
        """Cancel every task of the run (each stops at its next check)."""
        self.cancelled = True

    def is_cancelled(self) -> bool:
        """Whether the run was cancelled."""
        return self.cancelled

    def start(self, index: int) -> bool:
        """Task ``index`` holds a worker and is about to start its work; returns whether the run was cancelled
        (then it does no work)."""
        self.started.add(index)
        return self.cancelled

    def started_tasks(self) -> set[int]:
        """The tasks that have held a worker (running, or already returned)."""
        return set(self.started)


def _node() -> str:
    """``host:pid``, and the first 8 hex digits of the Ray node's id inside a Ray worker (two Ray nodes can share
    a host)."""
    import sys

    where = f"{socket.gethostname()}:{os.getpid()}"
    ray = sys.modules.get("ray")
    if ray is not None and ray.is_initialized():
        where = f"node {ray.get_runtime_context().get_node_id()[:8]} {where}"
    return where


class Executor(ABC):
    """Runs seeded, idempotent tasks somewhere and yields their results as they finish.

    :meth:`run` is a generator: it submits every task, yields a :class:`TaskResult` per finished task, and stops
    early (cancelling what is left) when ``stop`` holds -- checked with the number of finished tasks as the
    iteration -- or :meth:`cancel` was called from any thread; :attr:`stopped` then says so.  Ctrl-C cancels the
    tasks left and re-raises :class:`KeyboardInterrupt`.
    """

    name = "executor"
    #: whether results name other machines' processes (the progress lines then show the node)
    remote = False

    def __init__(self) -> None:
        self._cancel = threading.Event()
        self.stopped = False
        #: the running tasks' latest progress, ``index -> (node, values)`` (live where the executor supports it)
        self.running: dict[int, tuple[str, dict]] = {}
        #: called with :attr:`running` whenever it is refreshed (e.g. to draw a progress line)
        self.on_progress: Callable[[dict], object] | None = None

    def cancel(self) -> None:
        """Stop a running :meth:`run` at its next check and cancel its tasks; safe from any thread."""
        self._cancel.set()

    def _should_stop(self, stop: Condition | None, finished: int) -> bool:
        return self._cancel.is_set() or (stop is not None and stop.should_stop(finished))

    @abstractmethod
    def run(self, work: Callable[..., dict], tasks: Sequence[tuple],
            stop: Condition | None = None, *, errors: str = "raise") -> Iterator[TaskResult]:
        """Run ``work(*task)`` for every task; yield the results as they finish (in any order).

        ``errors`` (:data:`TASK_ERRORS`): a task that raises an exception re-raises it here, cancelling the others
        (``"raise"``), or is yielded with its :attr:`TaskResult.error` while the others go on (``"record"``).  A
        worker or node that dies is the executor's failure (:class:`ExecutorError`) either way."""

    def close(self) -> None:
        """Release what the executor holds (pool processes, the cluster connection)."""
        self._cancel.clear()

    def describe(self) -> str:
        """A short description for progress lines (``local pool of 4``, ``ray at 10.0.0.1:6379 (16 CPUs)``)."""
        return self.name

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


#: in a local pool's worker: the pool's ``(progress queue, cancel event)`` (set by :func:`worker_init`)
_channel = None
#: the environment variables that size the thread pools of BLAS and OpenMP libraries
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                    "VECLIB_MAXIMUM_THREADS")
#: OpenBLAS's thread-count setters, as its builds name them (plain, 64-bit interface, numpy's and scipy's wheels)
_OPENBLAS_SETTERS = ("openblas_set_num_threads", "openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
                     "scipy_openblas_set_num_threads64_")


def pin_threads(threads: int = 1) -> int:
    """Make BLAS and OpenMP use ``threads`` threads in this process: a pool worker (the pool already runs one task
    per core, so more threads per task only contend for the cores), and the ``pliant`` command itself, whose
    products are small batches (a few hundred states by a few hundred body points) where OpenBLAS's threads cost
    more than they give: they spin between calls, and Table 4.2's ci plans took 169 s of CPU in 99 s with them
    against 82 s in 82 s on one thread (docs/benchmarking.md, "BLAS threads").  Sets :data:`THREAD_VARIABLES` for
    libraries loaded later and resizes the OpenBLAS libraries already loaded (a forked worker inherits its
    parent's, sized for the whole machine) through their own setter.  Does nothing when the user set any of the
    variables: their choice wins.  Returns how many loaded OpenBLAS libraries were resized."""
    if any(name in os.environ for name in THREAD_VARIABLES):
        return 0
    for name in THREAD_VARIABLES:
        os.environ[name] = str(threads)
    try:
        with open("/proc/self/maps") as maps:
            paths = sorted({line.split()[-1] for line in maps
                            if "openblas" in line.rsplit("/", 1)[-1].lower() and line.split()[-1].startswith("/")})
    except OSError:                                    # not Linux: the variables alone
        return 0
    import ctypes

    resized = 0
    for path in paths:
        try:
            library = ctypes.CDLL(path)                # the already loaded library, not a second copy
        except OSError:
            continue
        for name in _OPENBLAS_SETTERS:
            setter = getattr(library, name, None)
            if setter is not None:
                setter.argtypes, setter.restype = [ctypes.c_int], None
                setter(int(threads))
                resized += 1
                break
    return resized


def worker_init(parent: int, channel=None, threads: int | None = 1) -> None:
    """Pool workers: leave Ctrl-C to the parent (it cancels the queue and ends the workers), and die with the parent
    (Linux: the kernel sends SIGTERM when it exits, even by kill -9; elsewhere a watcher thread polls).
    ``channel``: the pool's ``(queue, event)``: tasks put their progress on the queue, the event cancels them.
    ``threads``: BLAS and OpenMP threads per worker (:func:`pin_threads`; None leaves them alone)."""
    global _channel
    import signal

    _channel = channel
    if threads is not None:
        pin_threads(threads)

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)      # the CLI's handler (forked with the pool) is the parent's
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGTERM)                  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:                         # the parent died before prctl took effect
        os._exit(1)

    def watch():
        while True:
            time.sleep(1.0)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="pliant-parent-watch", daemon=True).start()


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel every queued task and end the workers now (the running tasks' results are not waited for)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())     # shutdown forgets them
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=5.0)


class LocalExecutor(Executor):
    """``jobs`` worker processes on this machine (one task each at a time); the default executor.

    grace: seconds the running tasks get to stop by themselves when the run is stopped or cancelled (their stop
    conditions terminate), before the workers are ended; Ctrl-C ends them at once.
    interval: seconds between a running task's progress reports (:attr:`Executor.running`).
    threads: BLAS and OpenMP threads in each worker (:func:`pin_threads`; default 1: the pool already keeps every
    core busy; None leaves the libraries' own choice, usually one thread per core in every worker).
    """

    name = "local"

    def __init__(self, jobs: int | None = None, *, grace: float = 5.0, interval: float = 1.0,
                 threads: int | None = 1) -> None:
        super().__init__()
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
            raise ConfigError("must be a positive integer or None", field="threads", value=threads)
        self.threads = threads
        if jobs is None:
            jobs = os.cpu_count() or 1
        if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
            raise ConfigError("must be a positive integer", field="--jobs", value=jobs)
        self.jobs = jobs
        self.grace = _positive(grace, "grace", zero=True)
        self.interval = _positive(interval, "interval")

    def describe(self) -> str:
        """``local pool of N``."""
        return f"local pool of {self.jobs}"

    def run(self, work: Callable[..., dict], tasks: Sequence[tuple],
            stop: Condition | None = None, *, errors: str = "raise") -> Iterator[TaskResult]:
        """Submit every task to a fresh pool; yield results as they finish; end the pool afterwards."""
        _check_errors(errors)
        self.stopped = False
        if stop is not None:
            stop.start()
        import multiprocessing
        import queue as queues

        context = multiprocessing.get_context()
        channel = (context.Queue(), context.Event())
        pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=context, initializer=worker_init,
                                   initargs=(os.getpid(), channel, self.threads))
        try:
            futures = {pool.submit(call_task, work, tuple(task), None, k, self.interval): k
                       for k, task in enumerate(tasks)}
            pending = set(futures)
            finished = 0
            while pending:
                if self._should_stop(stop, finished):
                    self.stopped = True
                    pool.shutdown(wait=False, cancel_futures=True)       # queued tasks never start
                    channel[1].set()                                      # running ones stop by themselves ...
                    wait_futures(pending, timeout=self.grace)
                    stop_pool(pool)                                       # ... or are ended
                    return
                done, pending = wait_futures(pending, timeout=POLL, return_when=FIRST_COMPLETED)
                reports = False
                while True:
                    try:
                        index, node, values = channel[0].get_nowait()
                    except (queues.Empty, OSError, ValueError):
                        break
                    self.running[index] = (node, values)
                    reports = True
                still = {futures[f] for f in pending}
                if reports or len(self.running) != len(still & set(self.running)):
                    self.running = {k: v for k, v in self.running.items() if k in still}
                    if self.on_progress is not None:
                        self.on_progress(self.running)
                for future in done:
                    try:
                        record, progress, node, seconds, _ = future.result()
                    except BrokenExecutor:
                        raise
                    except Exception as exc:
                        if errors == "raise":
                            raise
                        finished += 1
                        yield TaskResult(futures[future], {}, error=task_error(exc))
                        continue
                    finished += 1
                    yield TaskResult(futures[future], record, progress, node, seconds)
        except BaseException:       # Ctrl-C, a task's error, or the consumer closing the generator early
            stop_pool(pool)
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
            self.running = {}
            channel[0].close()
            channel[0].cancel_join_thread()


class RayExecutor(Executor):
    """Tasks as Ray tasks on a cluster (``address``: ``host:port`` of its head, ``"auto"`` for the cluster this
    machine belongs to, ``None`` to start Ray on this machine alone).

    retries: how many times a task whose worker process or node died is run again (Ray's ``max_retries``).
    grace: seconds a cancelled running task gets to stop by itself before its worker is killed.
    cpus: CPUs each task asks for.
    interval: seconds between a running task's progress reports (:attr:`Executor.running`, live).
    """

    name = "ray"
    remote = True

    def __init__(self, address: str | None = None, *, retries: int = 3, grace: float = 5.0, cpus: float = 1.0,
                 interval: float = 1.0, ray_options: dict | None = None) -> None:
        super().__init__()
        if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
            raise ConfigError("must be a non-negative integer", field="retries", value=retries)
        parse_address(address)                      # the form now; whether a head answers: check_head
        self.address = address
        self.retries = retries
        self.grace = _positive(grace, "grace", zero=True)
        self.cpus = _positive(cpus, "cpus")
        self.interval = _positive(interval, "interval")
        self.ray_options = dict(ray_options or {})
        self._ray = None
        self._remote = None
        self._board = None
        self._owns_connection = False

    def _connect(self):
        if self._ray is not None:
            return self._ray
        try:
            import ray
        except ImportError:
            raise ConfigError("Ray is not installed (pip install 'pliant[ray]')", field="--executor",
                              value="ray") from None
        if not ray.is_initialized():
            check_head(self.address)                # ray.init retries an address where nothing answers for minutes
            try:
                ray.init(address=self.address, log_to_driver=False, configure_logging=False,
                         include_dashboard=False, **self.ray_options)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                raise ConfigError(f"cannot connect to the Ray cluster: {exc}", field="--address",
                                  value=self.address) from None
            self._owns_connection = True
        self._ray = ray
        self._remote = ray.remote(call_task).options(num_cpus=self.cpus, max_retries=self.retries,
                                                     retry_exceptions=False)
        return ray

    def cluster_cpus(self) -> float:
        """CPUs the cluster has now (connects on first use)."""
        return float(self._connect().cluster_resources().get("CPU", 0.0))

    def wait_for_cpus(self, cpus: float, timeout: float = 60.0) -> float:
        """Wait until the cluster has ``cpus`` CPUs (nodes still joining); returns what it has."""
        deadline = time.monotonic() + timeout
        while (have := self.cluster_cpus()) < cpus:
            if time.monotonic() > deadline:
                raise ExecutorError(f"the cluster has {have:g} CPUs after {timeout:g} s", field="cpus", value=cpus)
            time.sleep(0.2)
        return have

    def describe(self) -> str:
        """``ray at ADDRESS (N nodes, M CPUs)``."""
        ray = self._connect()
        nodes = sum(1 for n in ray.nodes() if n.get("Alive"))
        return f"ray at {self.address or 'a local instance'} ({nodes} nodes, {self.cluster_cpus():g} CPUs)"

    def run(self, work: Callable[..., dict], tasks: Sequence[tuple],
            stop: Condition | None = None, *, errors: str = "raise") -> Iterator[TaskResult]:
        """Submit every task to the cluster; yield results as they finish; cancel what is left when stopped."""
        from pliant.version import __version__

        _check_errors(errors)
        ray = self._connect()
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

        self.stopped = False
        if stop is not None:
            stop.start()
        work_ref = ray.put(work)                    # shipped once, not with every task
        board = f"pliant-progress-{os.getpid()}-{time.time_ns()}"
        # on this machine's node: the board must not die with a worker node
        here = NodeAffinitySchedulingStrategy(ray.get_runtime_context().get_node_id(), soft=True)
        self._board = ray.remote(num_cpus=0)(ProgressBoard).options(name=board, scheduling_strategy=here).remote()
        ray.get(self._board.is_cancelled.remote())  # the board is up (and named) before any task asks it
        refs = {self._remote.remote(work_ref, tuple(task), board, k, self.interval): k
                for k, task in enumerate(tasks)}
        pending = list(refs)
        finished = 0
        polled = time.monotonic()
        try:
            while pending:
                if self._should_stop(stop, finished):
                    self.stopped = True
                    self._cancel_refs({ref: refs[ref] for ref in pending})
                    return
                done, pending = ray.wait(pending, num_returns=1, timeout=POLL)
                if time.monotonic() - polled >= self.interval:
                    polled = time.monotonic()
                    still = {refs[ref] for ref in pending}
                    try:
                        board_now = ray.get(self._board.snapshot.remote(), timeout=5.0)
                    except (ray.exceptions.RayError, TimeoutError):       # progress is best effort
                        board_now = self.running
                    self.running = {k: v for k, v in board_now.items() if k in still}
                    if self.on_progress is not None:
                        self.on_progress(self.running)
                for ref in done:
                    try:
                        record, progress, node, seconds, version = ray.get(ref)
                    except ray.exceptions.RayTaskError as exc:
                        if errors == "raise":
                            raise exc.as_instanceof_cause() from None
                        finished += 1
                        # the task's own exception (the error Ray raises here wraps it), with the worker's traceback
                        yield TaskResult(refs[ref], {}, error=task_error(exc.__dict__.get("cause", exc), str(exc)))
                        continue
                    except (ray.exceptions.WorkerCrashedError, ray.exceptions.NodeDiedError,
                            ray.exceptions.ObjectLostError) as exc:
                        raise ExecutorError(f"task {refs[ref]} failed {self.retries + 1} times on the cluster: "
                                            f"{type(exc).__name__}", field="task", value=tasks[refs[ref]]) from None
                    if version != __version__:
                        raise ExecutorError(f"the cluster runs pliant {version} on {node}, this machine "
                                            f"{__version__}: install the same version on every node",
                                            field="--address", value=self.address)
                    finished += 1
                    yield TaskResult(refs[ref], record, progress, node, seconds)
        except BaseException:
            self._cancel_refs({ref: refs[ref] for ref in pending})
            raise
        finally:
            self.running = {}
            self._board = None                  # the actor ends with its last handle

    def _cancel_refs(self, refs: dict) -> None:
        """Cancel the tasks ``refs`` (their references and indices) through the progress board: a running task's stop
        conditions terminate, and a queued one returns without doing any work when it starts.  Tasks still running
        after ``grace`` seconds are killed (``ray.cancel(force=True)``); their results are dropped (a cancelled
        task's record is not the one a complete run gives).

        Queued tasks are never cancelled through Ray: in Ray 2.60, cancelling a task while a worker is being handed
        it races the worker's reply and aborts this process ("Check failed: ... Tried to complete task that was not
        pending").  Only when the board cannot be reached is every task left after the grace killed through Ray."""
        ray = self._ray
        if not refs:
            return
        try:
            ray.get(self._board.cancel.remote(), timeout=5.0)
            reached = True
        except (ray.exceptions.RayError, TimeoutError):
            reached = False                     # the tasks run on until the grace ends, then are killed
        _, left = ray.wait(list(refs), num_returns=len(refs), timeout=self.grace)
        if not left:
            return
        started = None                          # unknown: kill every task left
        if reached:
            try:
                started = ray.get(self._board.started_tasks.remote(), timeout=5.0)
            except (ray.exceptions.RayError, TimeoutError):
                pass
        for ref in left:
            if started is None or refs[ref] in started:
                try:
                    ray.cancel(ref, force=True)
                except (ValueError, TypeError):
                    pass

    def close(self) -> None:
        """Disconnect from the cluster if this executor connected (the cluster keeps running)."""
        if self._ray is not None and self._owns_connection:
            self._ray.shutdown()
        self._ray = None
        self._remote = None
        self._owns_connection = False


class LoopbackCluster:
    """A Ray cluster of ``nodes`` nodes on this machine, each its own ``ray start --block`` process group (a raylet
    with its workers) with ``cpus`` CPUs -- the emulated cluster of the tests and ``benchmarks/bench_executor.py``,
    and a way to try ``--executor ray`` without machines.  Use as a context manager; :meth:`stop` kills the process
    groups it started (only those).

    Ray replaces ``127.0.0.1`` by this machine's own address, so :attr:`address` is that address and the head's port.
    """

    def __init__(self, nodes: int = 2, cpus: int = 1, *, object_store_bytes: int = 80_000_000,
                 timeout: float = 60.0) -> None:
        if isinstance(nodes, bool) or not isinstance(nodes, int) or nodes < 1:
            raise ConfigError("must be a positive integer", field="nodes", value=nodes)
        self.nodes = nodes
        self.cpus = cpus
        self.object_store_bytes = object_store_bytes
        self.timeout = timeout
        self.processes: list = []
        self.address: str | None = None
        self._temp: str | None = None

    @staticmethod
    def _free_port() -> int:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            return s.getsockname()[1]

    def _start(self, args: list[str], log: str):
        import subprocess
        import sys
        from pathlib import Path

        ray = str(Path(sys.executable).with_name("ray"))
        env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
        with open(log, "w") as out:
            process = subprocess.Popen(
                [ray, "start", "--block", "--disable-usage-stats", f"--num-cpus={self.cpus}",
                 f"--object-store-memory={self.object_store_bytes}",
                 f"--dashboard-agent-listen-port={self._free_port()}", *args],
                stdout=out, stderr=subprocess.STDOUT, start_new_session=True, env=env)
        self.processes.append(process)
        return process

    def start(self) -> LoopbackCluster:
        """Start the head, then the other nodes; returns once the cluster has every node's CPUs."""
        import re
        import tempfile
        from pathlib import Path

        self._temp = tempfile.mkdtemp(prefix="pliant-ray-", dir="/tmp")          # short: Ray's socket paths
        head_log = Path(self._temp) / "node0.log"
        self._start(["--head", f"--port={self._free_port()}", "--node-ip-address=127.0.0.1",
                     "--include-dashboard=false", f"--temp-dir={self._temp}/ray"], str(head_log))
        deadline = time.monotonic() + self.timeout
        while self.address is None:
            found = re.search(r"--address='([^']+)'", head_log.read_text())
            if found:
                self.address = found.group(1)
            elif time.monotonic() > deadline or self.processes[0].poll() is not None:
                text = head_log.read_text()[-2000:]
                self.stop()
                raise ExecutorError(f"the Ray head did not start: {text}", field="nodes", value=self.nodes)
            else:
                time.sleep(0.1)
        for k in range(1, self.nodes):
            self._start([f"--address={self.address}"], f"{self._temp}/node{k}.log")
        return self

    def kill_node(self, k: int) -> None:
        """``SIGKILL`` node ``k``'s process group (0 is the head): a machine that fails."""
        import signal

        process = self.processes[k]
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        process.wait(10)

    def stop(self) -> None:
        """Kill every node this object started and remove its temporary directory."""
        import shutil

        for k in range(len(self.processes)):
            self.kill_node(k)
        self.processes = []
        if self._temp:
            for _ in range(5):                  # a dying node (or this process's driver) may still write a log
                shutil.rmtree(self._temp, ignore_errors=True)
                if not os.path.exists(self._temp):
                    break
                time.sleep(0.5)
            self._temp = None

    def __enter__(self) -> LoopbackCluster:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


_current: Executor | None = None


def current() -> Executor | None:
    """The executor installed by :func:`using` (None: experiments use a local pool of their ``--jobs``)."""
    return _current


@contextmanager
def using(executor: Executor | None) -> Iterator[Executor | None]:
    """Run experiments in the block with ``executor`` (closed afterwards); None leaves the default."""
    global _current
    previous, _current = _current, executor
    try:
        yield executor
    finally:
        _current = previous
        if executor is not None:
            executor.close()


def create(name: str, *, address: str | None = None, jobs: int | None = None) -> Executor:
    """An executor by name: ``local`` (``jobs`` processes) or ``ray`` (the cluster at ``address``)."""
    if name == "local":
        if address is not None:
            raise ConfigError("is for --executor ray; the local pool runs on this machine", field="--address",
                              value=address)
        return LocalExecutor(jobs)
    if name == "ray":
        return RayExecutor(address)
    raise ConfigError(f"unknown executor (executors: {', '.join(EXECUTORS)})", field="--executor", value=name)


def add_executor_arguments(parser) -> None:
    """Give an experiment command ``--executor local|ray`` and ``--address ADDR`` (the ``pliant`` command then runs
    its tasks with that executor; ``--jobs`` stays the local pool's size)."""
    parser.add_argument("--executor", choices=EXECUTORS, default="local",
                        help="where tasks run: local (a process pool of --jobs, the default) or ray (a Ray "
                             "cluster; pip install 'pliant[ray]')")
    parser.add_argument("--address", default=None, metavar="HOST:PORT",
                        help="with --executor ray: the cluster's head (auto: the cluster this machine is in; "
                             "default: start Ray on this machine)")


def from_args(args, *, check: bool = True) -> Executor | None:
    """The executor a command's ``--executor`` / ``--address`` ask for; None for the default local pool (which each
    experiment sizes by its own ``--jobs``).  ``check``: a Ray head's address must answer now (:func:`check_head`,
    seconds at most), so a wrong one fails before the command writes anything."""
    name = getattr(args, "executor", "local")
    address = getattr(args, "address", None)
    if name == "local":
        create("local", address=address, jobs=1)            # checks --address
        return None
    executor = create(name, address=address)
    if check and isinstance(executor, RayExecutor):
        try:
            missing = importlib.util.find_spec("ray") is None
        except ValueError:                      # a module without a spec (e.g. blocked in sys.modules)
            missing = True
        if missing:
            raise ConfigError("Ray is not installed (pip install 'pliant[ray]')", field="--executor", value="ray")
        check_head(executor.address)
    return executor
