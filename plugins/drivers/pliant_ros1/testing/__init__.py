"""Robot peers of the ROS 1 drivers: for tests, benchmarks and demos, never imported by the drivers themselves.

A peer is a ROS node that behaves as one robot's controller (Baxter, PR2, iiwa), moving a simulated arm, with fault
injection (docs/plugins/ros1.md, "Robot peers"):

* :mod:`pliant_ros1.testing.peer`: :class:`~pliant_ros1.testing.peer.RobotPeer`, the node (topics, rates, enabling,
  fault switches);
* :mod:`pliant_ros1.testing.emulator`: :class:`~pliant_ros1.testing.emulator.ArmEmulator`, the simulated arm behind
  it (a joint position servo stepping a pliant simulator in real time);
* :mod:`pliant_ros1.testing.process`: :class:`~pliant_ros1.testing.process.PeerProcess`, a peer in a child process;
* :mod:`pliant_ros1.testing.record`: the peer's record file read back, and every command checked against limits;
* :mod:`pliant_ros1.testing.command`: the command line, ``python -m pliant_ros1.testing ROBOT`` or
  ``pliant ros-peer ROBOT``.

An import-linter contract (pyproject.toml) keeps the production modules (the drivers, the node, the robots, the
messages, the master) from importing this package.
"""
