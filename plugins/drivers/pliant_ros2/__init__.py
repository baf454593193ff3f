"""ROS 2 robot drivers for pliant: any arm under ros2_control (``ros2-control``) and the KUKA LBR iiwa 7 R800 of the
lbr_fri_ros2_stack (``iiwa-ros2``), with a ROS 2 peer to test them (docs/plugins/ros2.md).

``pliant_ros2.plugin`` registers them (light: nothing of ROS is imported).  ``pliant_ros2.driver``: the driver,
whose ROS 2 node runs in a child process (``pliant_ros2.bridge``) started in the environment
``pliant_ros2.environment`` builds from the pip-installed ROS 2 wheels.  ``pliant_ros2.robots``: the presets and
limits files.  ``pliant_ros2.testing``: an emulated ros2_control arm (tests and demos only).
"""
