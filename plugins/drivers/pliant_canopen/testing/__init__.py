"""Emulated CiA 402 drives for the CANopen driver: for tests, benchmarks and demos, never imported by the driver.

* :mod:`pliant_canopen.testing.peer`: :class:`~pliant_canopen.testing.peer.CanopenPeer`, one emulated drive per joint
  of a joint map on a python-can bus, with fault injection, and :func:`~pliant_canopen.testing.peer.run_peer` (the
  ``pliant canopen-peer`` command);
* :mod:`pliant_canopen.testing.drive`: :class:`~pliant_canopen.testing.drive.PeerDrive`, one drive (a
  ``canopen.LocalNode``, the CiA 402 state machine, the joint model).

An import-linter contract (pyproject.toml) keeps the production modules (the driver, the joint map, the profile's
constants) from importing this package (docs/plugins/canopen.md, "The peer").
"""
