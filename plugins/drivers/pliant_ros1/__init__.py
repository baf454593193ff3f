"""ROS 1 robot drivers for pliant: PR2 and Baxter arms and the KUKA LBR iiwa, each with a robot peer to test it.

``pliant_ros1.plugin`` registers the drivers ``pr2-ros``, ``baxter-ros`` and ``iiwa-ros`` (light: no rospy import).
The transports (rospy imported there only): ``pliant_ros1.pr2``, ``pliant_ros1.baxter``, ``pliant_ros1.iiwa`` on
the shared :mod:`pliant_ros1.driver` (the process's one ROS node, the master watchdog).  ``pliant_ros1.robots``:
joint names read from the URDFs, the topics, the limits files.  ``pliant_ros1.messages``: the message types Debian
does not package, generated with genpy from the ``.msg`` files shipped in ``msg/``.  ``pliant_ros1.master``: a ROS
master on loopback.  ``pliant_ros1.testing``: the robot peers, a ROS node that behaves as each robot's controller,
moving a simulated arm, with fault injection (for tests and demos; docs/plugins/ros1.md).
"""
