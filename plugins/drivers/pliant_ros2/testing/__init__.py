"""The ROS 2 peer of the ROS 2 drivers: for tests, benchmarks and demos, never imported by the drivers themselves.

* :mod:`pliant_ros2.testing.peer`: :class:`~pliant_ros2.testing.peer.ControlPeer`, a ROS 2 node that behaves as
  ros2_control with a ``forward_command_controller``, a ``joint_trajectory_controller`` and a
  ``joint_state_broadcaster``, moving an emulated arm (each joint a first-order position servo), with fault switches;
* :mod:`pliant_ros2.testing.process`: :class:`~pliant_ros2.testing.process.PeerProcess`, a peer in a child process
  (a domain id of its own, discovery limited to this machine), faults switched through its stdin;
* :mod:`pliant_ros2.testing.record`: the peer's record read back, every command checked against limits;
* :mod:`pliant_ros2.testing.command`: ``python -m pliant_ros2.testing`` / ``pliant robot ros2-peer``.
"""
