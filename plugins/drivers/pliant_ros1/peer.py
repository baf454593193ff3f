"""Deprecated spelling: the robot peers moved to :mod:`pliant_ros1.testing` (tests, benchmarks and demos only).

``python -m pliant_ros1.peer`` still runs a peer (now ``python -m pliant_ros1.testing``); the names below still import
from here, with a :class:`DeprecationWarning`.
"""

from __future__ import annotations

import sys
import warnings

from pliant_ros1.testing.command import add_arguments, main, run_from_args
from pliant_ros1.testing.peer import DEFAULT_FAULT_TOPIC, FAULTS, READY, RobotPeer
from pliant_ros1.testing.process import PeerProcess
from pliant_ros1.testing.record import command_violations, read_record

__all__ = ["DEFAULT_FAULT_TOPIC", "FAULTS", "READY", "PeerProcess", "RobotPeer", "add_arguments",
           "command_violations", "main", "read_record", "run_from_args"]

if __name__ == "__main__":
    sys.exit(main())
warnings.warn("pliant_ros1.peer moved to pliant_ros1.testing (peer, process, record, command)", DeprecationWarning,
              stacklevel=2)
