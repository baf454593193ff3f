"""``make test``: the suite's two phases, run side by side.

- The real-time tests (``-m realtime``: drivers and their peers, watchdogs, the browser) run in one process, one at
  a time, at the caller's priority.  They wait more than they compute (150 s of CPU in 3:49 alone, their peers
  included).
- Every other test runs at the same time on ``--workers`` pytest-xdist processes at the lowest priority
  (``nice 19``), so that they take the CPU the real-time tests leave and never delay a peer's loop or a watchdog:
  the kernel runs a waking nice-0 thread before a nice-19 one.  A worker process that dies (a crash in native
  code) ends this phase at once with the test it was running named, rather than being replaced.

Phase 1 prints as it goes; phase 2 writes ``--log`` and is printed when both are done.  The exit status is 0 only
if both phases pass (one of them may collect no test when the arguments after ``--`` name some tests, not both).
Ctrl-C (or SIGTERM) stops both.  ``--serial`` runs them one after the other, as ``make test``
did before (docs/testing.md has the measured times of both ways).
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

BIN = Path(sys.executable).parent
NO_TESTS = 5        # pytest's exit status when no test was collected


def _arguments(argv):
    parser = argparse.ArgumentParser(prog="tests/run_phases.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2, help="pytest-xdist processes for the first phase")
    parser.add_argument("--log", type=Path, default=Path("out/test-realtime.log"),
                        help="where the real-time phase writes its output")
    parser.add_argument("--serial", action="store_true", help="run the real-time phase after the other")
    parser.add_argument("pytest_args", nargs="*", help="more arguments for both pytest runs (after --)")
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error(f"--workers: must be at least 1, got {args.workers}")
    return args


def _lowest_priority():
    os.nice(19)


def main(argv=None) -> int:
    args = _arguments(argv)
    pytest = str(BIN / "pytest")
    # a worker that dies ends the phase at once, naming the test it ran: pytest-xdist's replacement worker once
    # left the dead worker's group unscheduled and the phase waiting for ever (session 34)
    first = [pytest, "-q", "-n", str(args.workers), "--dist", "loadgroup", "--no-loadscope-reorder",
             "--max-worker-restart", "0", "-m", "not realtime", *args.pytest_args]
    # the cache plugin off in the second run: two sessions must not write .pytest_cache at once
    second = [pytest, "-q", "-m", "realtime", "-p", "no:cacheprovider", *args.pytest_args]
    args.log.parent.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    running: list[subprocess.Popen] = []

    def stop(signum, _frame):
        for process in running:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop)
    try:
        if args.serial:
            running.append(subprocess.Popen(first))
            code_first = running[-1].wait()
            print(f"real-time phase (log: {args.log}) ...", flush=True)
            with args.log.open("w") as log:
                running.append(subprocess.Popen(second, stdout=log, stderr=subprocess.STDOUT))
                code_second = running[-1].wait()
        else:
            with args.log.open("w") as log:
                running.append(subprocess.Popen(second, stdout=log, stderr=subprocess.STDOUT))
                print(f"the real-time tests run beside, at normal priority (log: {args.log}); the others at nice 19",
                      flush=True)
                running.append(subprocess.Popen(first, preexec_fn=_lowest_priority))
                code_first = running[1].wait()
                code_second = running[0].wait()
    except KeyboardInterrupt:
        for process in running:
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
        print("\ninterrupted: both phases stopped", file=sys.stderr)
        return 130
    print(f"--- the real-time phase ({args.log}):")
    print(args.log.read_text().rstrip())
    minutes, seconds = divmod(int(time.monotonic() - started), 60)
    # pytest's 5: no test collected -- one phase may have none of the tests named after --, not both
    passed = {code_first, code_second} <= {0, NO_TESTS} and (code_first, code_second) != (NO_TESTS, NO_TESTS)
    print(f"--- both phases {'passed' if passed else 'FAILED'} in {minutes}:{seconds:02d} "
          f"(exit status {code_first}, {code_second})")
    return 0 if passed else 1


if __name__ == "__main__":
    sys.exit(main())
