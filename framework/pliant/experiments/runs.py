"""Resumable experiments: seeded tasks run by an executor (:mod:`pliant.experiments.executor`: a local process
pool by default, or a Ray cluster), each record appended to ``runs.jsonl`` in this process as it finishes (the
belief planner's ch. 5 experiments, the path metric's ch. 6 tables, the learners' ch. 4 trials).

Guarantees (docs/conventions.md, "Interruption and files"): every finished task is appended and fsynced at once;
Ctrl-C cancels the queued tasks, ends the workers within seconds and raises :class:`KeyboardInterrupt` after the
caller's ``on_interrupt`` has written what it writes; workers die with the parent process, even one killed by
``kill -9``; a torn last line is dropped on resume (:func:`pliant.files.read_jsonl`); a resume whose settings
differ from the run's ``settings.json`` is refused (:func:`check_settings`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

from pliant.errors import ConfigError
from pliant.experiments.executor import Executor, ExecutorError, LocalExecutor, current, stop_pool, worker_init
from pliant.files import append_jsonl, read_json, read_jsonl, rewrite_jsonl, write_json
from pliant.progress import ProgressLine
from pliant.termination import Condition

__all__ = ["TasksFailed", "check_settings", "open_log", "run_tasks", "stop_pool", "worker_init"]


class TasksFailed(ExecutorError):
    """Some tasks of an experiment raised: the others ran to the end and are on file, the failures are in
    ``errors.jsonl`` beside the records (``failures``: their entries), and the same command runs them again.
    ``pliant`` exits with status 3 (``failed``: the work raised), not 2 (bad input)."""

    exit_status = 3

    def __init__(self, message: str, failures: list[dict], **where) -> None:
        super().__init__(message, **where)
        self.failures = failures


def check_settings(directory: Path, settings: dict, keys: Sequence[str], *, replace: bool) -> dict:
    """The run's settings on file (``settings.json``), checked against ``settings``: a resume whose ``keys`` differ is
    refused, naming the setting (as its ``--flag``) and both values; ``replace`` (a fresh start, a replay, an empty
    log) writes the new ones."""
    path = directory / "settings.json"
    if path.exists() and not replace:
        stored = read_json(path)          # a damaged file is one error naming it (remove it, or --fresh)
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
              echo=print, executor: Executor | None = None, stop: Condition | None = None,
              label: Callable[[tuple], str] | None = None) -> list[dict]:
    """Run ``work(*task)`` for every task with ``executor`` -- by default the one installed by
    :func:`pliant.experiments.executor.using` (``pliant ... --executor ray``), else a local pool of ``jobs``
    processes.  Each record is appended to ``records`` and to ``log`` (fsynced) in this process as it finishes,
    exactly once, and echoed as ``[k/n] describe(record)`` (with the node that ran it when the executor is remote).

    On Ctrl-C: the tasks left are cancelled, ``on_interrupt()`` runs (e.g. writes a summary of the finished tasks),
    and :class:`KeyboardInterrupt` is raised.  When ``stop`` holds (checked with the number of finished tasks) or
    the executor is cancelled from another thread, the tasks left are cancelled, ``on_interrupt()`` runs and the
    records so far are returned; a second call resumes with the tasks not on file.

    A task that raises does not stop the others: its error is appended to ``errors.jsonl`` beside ``log`` (the task
    as ``label(task)`` says it, the exception's type, message and the worker's traceback) and echoed; once every
    other task has finished, ``on_interrupt()`` runs and :class:`TasksFailed` is raised naming the failed tasks in the
    tasks' order.  A failed task has no record, so the same command runs it again."""
    tasks = list(tasks)
    label = label or (lambda task: repr(task)[:200])
    failures: list[tuple[int, dict]] = []           # (task index, errors.jsonl entry), in the order they failed
    own = executor is None and current() is None
    executor = executor or current() or LocalExecutor(jobs)
    line = ProgressLine("tasks")
    finished = 0

    def show(running: dict) -> None:                 # live, where the executor reports running tasks (Ray)
        fields = {"done": f"{finished}/{len(tasks)}", "running": len(running),
                  "nodes": len({node.split()[1] if node.startswith("node ") else node for node, _ in running.values()})}
        for index, (_, values) in sorted(running.items())[:2]:
            fields[f"task {index}"] = " ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                               for k, v in values.items() if k in ("iterations", "best_cost", "nodes"))
        line.update(**fields)

    previous, executor.on_progress = executor.on_progress, show
    try:
        with log.open("a") as sink:
            for k, result in enumerate(executor.run(work, tasks, stop, errors="record"), start=1):
                finished = k
                if result.error is not None:
                    failures.append((result.index, _record_failure(log, label(tasks[result.index]), result.error)))
                    echo(f"[{k}/{len(tasks)}] FAILED {failures[-1][1]['task']}: {result.error['type']}: "
                         f"{result.error['message']}")
                    continue
                records.append(result.record)
                append_jsonl(sink, result.record)
                where = f" [{result.node}]" if executor.remote else ""
                echo(f"[{k}/{len(tasks)}] {describe(result.record)}{where}")
    except KeyboardInterrupt:
        on_interrupt()
        echo(f"interrupted: the {len(records)} finished tasks are in {log}; run the same command again to resume")
        raise
    finally:
        line.close()
        executor.on_progress = previous
        if own:
            executor.close()
    if executor.stopped:
        on_interrupt()
        echo(f"stopped: the {len(records)} finished tasks are in {log}; run the same command again to resume")
    elif failures:
        on_interrupt()
        # in the tasks' order, not the order the workers happened to finish them: the message is the same every run
        failures = [entry for _, entry in sorted(failures, key=lambda pair: pair[0])]
        listed = "; ".join(f"{f['task']}: {f['type']}: {f['message'][:160]}" for f in failures[:3])
        more = f" and {len(failures) - 3} more" if len(failures) > 3 else ""
        raise TasksFailed(f"{len(failures)} of {len(tasks)} tasks failed ({listed}{more}); the others finished and "
                          f"are in {log}, the errors with their tracebacks in {log.parent / 'errors.jsonl'}; run the "
                          "same command again to run the failed tasks again", failures, field="task",
                          value=failures[0]["task"])
    return records


def _record_failure(log: Path, task: str, error: dict) -> dict:
    """Append a failed task's entry to ``errors.jsonl`` beside ``log`` (fsynced); returns the entry."""
    entry = {"task": task, **error, "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    with (log.parent / "errors.jsonl").open("a") as sink:
        append_jsonl(sink, entry)
    return entry
