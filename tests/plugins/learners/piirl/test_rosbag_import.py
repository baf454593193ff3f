"""Demonstrations from ROS 1 bags written here with rosbags: poses and joint states, and clear errors."""

import numpy as np
import pytest
from pliant.errors import ConfigError
from pliant_piirl.rosbag import import_demonstration, read_path
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.ROS1_NOETIC)
T = STORE.types


def _header(k):
    return T["std_msgs/msg/Header"](seq=k, stamp=T["builtin_interfaces/msg/Time"](sec=k, nanosec=0), frame_id="world")


def _pose(k, position, quaternion):
    point = T["geometry_msgs/msg/Point"](x=position[0], y=position[1], z=position[2])
    q = T["geometry_msgs/msg/Quaternion"](x=quaternion[0], y=quaternion[1], z=quaternion[2], w=quaternion[3])
    return T["geometry_msgs/msg/PoseStamped"](header=_header(k), pose=T["geometry_msgs/msg/Pose"](position=point,
                                                                                                   orientation=q))


def _joints(k, names, positions):
    zeros = np.zeros(len(names))
    return T["sensor_msgs/msg/JointState"](header=_header(k), name=names, position=np.asarray(positions, float),
                                           velocity=zeros, effort=zeros)


def write_bag(path, topic, msgtype, messages):
    with Writer(path) as writer:
        connection = writer.add_connection(topic, msgtype, typestore=STORE)
        for k, message in enumerate(messages):
            writer.write(connection, (k + 1) * 10**8, STORE.serialize_ros1(message, msgtype))
    return path


def test_poses_become_se3_configurations_in_time_order_with_a_continuous_quaternion(tmp_path):
    s = np.sin(0.1)
    c = np.cos(0.1)
    poses = [_pose(0, (0.1, 0.2, 0.3), (0, 0, 0, 2.0)),                  # not unit: normalised
             _pose(1, (0.1, 0.2, 0.25), (0, 0, -s, -c)),                   # the same rotation's other sign
             _pose(2, (0.1, 0.2, 0.2), (0, 0, -s, -c))]
    bag = write_bag(tmp_path / "demo.bag", "/probe/pose", "geometry_msgs/msg/PoseStamped", poses)
    path = read_path(bag, "/probe/pose")
    assert path.shape == (3, 7)
    assert np.allclose(path[0], [0.1, 0.2, 0.3, 0, 0, 0, 1])
    assert np.allclose(path[1], [0.1, 0.2, 0.25, 0, 0, s, c])               # flipped to follow the previous one
    # min_step measures whole configurations: the second is 0.11 from the first (5 cm and 0.1 of quaternion),
    # the third only 0.05 from the second
    assert np.allclose(read_path(bag, "/probe/pose", min_step=0.06)[:, 2], [0.3, 0.25])
    demo = import_demonstration(bag, "/probe/pose", [0.1, 0.2, 0.2], planes=[[0, 0, 1, 1.0]])
    assert np.array_equal(demo.task.start, path[0]) and demo.source == "rosbag:/probe/pose"
    assert demo.task.allows(np.array([[0, 0, 0.5]]))[0] and not demo.task.allows(np.array([[0, 0, 2.0]]))[0]


def test_joint_states_follow_the_given_joint_order(tmp_path):
    names = ["b", "a", "c"]
    messages = [_joints(k, names, [k, 10 * k, 100 * k]) for k in range(4)]
    bag = write_bag(tmp_path / "arm.bag", "/joint_states", "sensor_msgs/msg/JointState", messages)
    path = read_path(bag, "/joint_states", joints=["a", "b"])
    assert np.array_equal(path, [[0, 0], [10, 1], [20, 2], [30, 3]])
    with pytest.raises(ConfigError, match="needs the joint names"):
        read_path(bag, "/joint_states")
    with pytest.raises(ConfigError, match=r"joint\(s\) \['z'\] missing"):
        read_path(bag, "/joint_states", joints=["a", "z"])


def test_bad_bags_topics_and_types_are_clear_errors(tmp_path):
    bag = write_bag(tmp_path / "demo.bag", "/probe/pose", "geometry_msgs/msg/PoseStamped",
                    [_pose(0, (0, 0, 0), (0, 0, 0, 1))])
    with pytest.raises(ConfigError, match=r"no such topic .*topics: /probe/pose"):
        read_path(bag, "/other")
    with pytest.raises(ConfigError, match="fewer than two"):
        import_demonstration(bag, "/probe/pose", [0, 0, 0])
    with pytest.raises(ConfigError, match="no such bag"):
        read_path(tmp_path / "missing.bag", "/x")
    (tmp_path / "junk.bag").write_bytes(b"not a bag at all")
    with pytest.raises(ConfigError, match="not a readable ROS bag"):
        read_path(tmp_path / "junk.bag", "/x")
    strings = write_bag(tmp_path / "s.bag", "/chatter", "std_msgs/msg/String", [T["std_msgs/msg/String"](data="hi")])
    with pytest.raises(ConfigError, match="unsupported message type"):
        read_path(strings, "/chatter")


def test_the_command_adds_to_a_file_and_refuses_another_scene(tmp_path):
    import subprocess
    import sys

    from pliant_piirl.demonstration import load_demonstrations

    bag = write_bag(tmp_path / "demo.bag", "/probe/pose", "geometry_msgs/msg/PoseStamped",
                    [_pose(k, (0.1, 0.2, 0.3 - 0.05 * k), (0, 0, 0, 1)) for k in range(3)])
    out = tmp_path / "demos.json"
    command = [sys.executable, "-m", "pliant.cli", "learn", "import", str(bag), "--topic", "/probe/pose",
               "--target", "0.1", "0.2", "0.2", "--plane", "0", "0", "1", "1.0", "--output", str(out)]
    for _ in range(2):
        done = subprocess.run([*command, "--scene", "hollow-cube"], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
    scene, demos = load_demonstrations(out)
    assert scene == "hollow-cube" and len(demos) == 2 and demos[1].path.shape == (3, 7)
    done = subprocess.run([*command, "--scene", "multi-cost"], capture_output=True, text=True)
    assert done.returncode == 2 and "--output" in done.stderr and "hollow-cube" in done.stderr
    done = subprocess.run([*command[:-7], "--plane", "0", "0", "2", "1", "--output", str(out), "--scene",
                           "hollow-cube"], capture_output=True, text=True)
    assert done.returncode == 2 and "unit vector" in done.stderr
