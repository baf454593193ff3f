"""Resumable experiments: seeded tasks run in a local process pool, each record appended to ``runs.jsonl`` as it
finishes (the belief planner's ch. 5 experiments, the path metric's ch. 6 tables).

Guarantees (docs/conventions.md, "Interruption and files"): every finished task is appended and fsynced at once;
Ctrl-C cancels the queued tasks, ends the workers within seconds and raises :class:`KeyboardInterrupt` after the
caller's ``on_interrupt`` has written what it writes; workers die with the parent process, even one killed by
``kill -9``; a torn last line is dropped on resume (:func:`pliant.files.read_jsonl`); a resume whose settings
differ from the run's ``settings.json`` is refused (:func:`check_settings`).
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from pliant.errors import ConfigError
from pliant.files import append_jsonl, read_jsonl, rewrite_jsonl, write_json


def worker_init(parent: int) -> None:
    """Pool workers: leave Ctrl-C to the parent (it cancels the queue and ends the workers), and die with the parent
    (Linux: the kernel sends SIGTERM when it exits, even by kill -9; elsewhere a watcher thread polls)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
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


def check_settings(directory: Path, settings: dict, keys: Sequence[str], *, replace: bool) -> dict:
    """The run's settings on file (``settings.json``), checked against ``settings``: a resume whose ``keys`` differ is
    refused, naming the setting (as its ``--flag``) and both values; ``replace`` (a fresh start, a replay, an empty
    log) writes the new ones."""
    path = directory / "settings.json"
    if path.exists() and not replace:
        try:
            stored = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ConfigError(f"cannot read the run's settings: {exc}", source=str(path), field="<file>") from None
        for key in keys:
            if key in stored and stored[key] != settings[key]:
                flag = "--" + key.replace("_", "-")
                raise ConfigError(f"this run was started with {flag} {stored[key]}; resuming with {settings[key]} "
                                  "would mix incomparable tasks (use the same value, --fresh to start over, or "
                                  "another --output)", source=str(path), field=flag, value=settings[key])
        return stored
    write_json(path, settings)
    return settings


def open_log(directory: Path, output_flag: str, echo=print) -> tuple[Path, list[dict]]:
    """Create ``directory`` (an error naming ``output_flag`` if it cannot be) and read its ``runs.jsonl``, dropping
    (and reporting) a torn last line; returns the log's path and its records."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot be created ({exc.strerror or exc})", field=output_flag,
                          value=str(directory.parent)) from None
    log = directory / "runs.jsonl"
    records, torn = read_jsonl(log)
    if torn:
        echo(f"{log}: its last line was cut off (a crash while writing it): dropped, that task runs again")
        rewrite_jsonl(log, records)
    return log, records


def run_tasks(work: Callable[..., dict], tasks: Iterable[tuple], *, jobs: int, log: Path, records: list[dict],
              describe: Callable[[dict], str], on_interrupt: Callable[[], object] = lambda: None,
              echo=print) -> list[dict]:
    """Run ``work(*task)`` for every task in a pool of ``jobs`` processes; each record is appended to ``records`` and
    to ``log`` (fsynced) as it finishes and echoed as ``[k/n] describe(record)``.  On Ctrl-C: the pool is stopped,
    ``on_interrupt()`` runs (e.g. writes a summary of the finished tasks), and :class:`KeyboardInterrupt` is raised."""
    tasks = list(tasks)
    pool = ProcessPoolExecutor(max_workers=jobs, initializer=worker_init, initargs=(os.getpid(),))
    try:
        with log.open("a") as sink:
            futures = [pool.submit(work, *task) for task in tasks]
            for k, future in enumerate(as_completed(futures), start=1):
                record = future.result()
                records.append(record)
                append_jsonl(sink, record)
                echo(f"[{k}/{len(tasks)}] {describe(record)}")
    except KeyboardInterrupt:
        stop_pool(pool)
        on_interrupt()
        echo(f"interrupted: the {len(records)} finished tasks are in {log}; run the same command again to resume")
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return records
