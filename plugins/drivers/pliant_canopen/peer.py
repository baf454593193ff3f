"""Deprecated spelling: the emulated drives moved to :mod:`pliant_canopen.testing` (tests, benchmarks and demos only);
the names below still import from here, with a :class:`DeprecationWarning`."""

from __future__ import annotations

import warnings

from pliant_canopen.testing.drive import PeerDrive
from pliant_canopen.testing.peer import CanopenPeer, run_peer

__all__ = ["CanopenPeer", "PeerDrive", "run_peer"]

warnings.warn("pliant_canopen.peer moved to pliant_canopen.testing (peer, drive)", DeprecationWarning, stacklevel=2)
