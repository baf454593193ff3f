"""Demonstrations from ROS 2 bags (rosbag2: sqlite3 and MCAP, folders and single storage files), written here with
rosbags' writer: the same recording gives the same path and the same demonstration as through a ROS 1 bag, a
Humble-era bag without message definitions is decoded with ROS 2's, and broken bags are clear errors."""

import shutil
import sqlite3

import numpy as np
import pytest
from pliant.errors import ConfigError
from pliant_piirl.rosbag import import_demonstration, read_path
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

ROS1 = get_typestore(Stores.ROS1_NOETIC)
ROS2 = get_typestore(Stores.ROS2_HUMBLE)
JOINT_STATE = "sensor_msgs/msg/JointState"
POSE = "geometry_msgs/msg/PoseStamped"
NAMES = ["lbr_A2", "lbr_A1", "gripper"]                     # not in configuration order, one joint not wanted
POSITIONS = [[0.1 * k, -0.2 * k, 0.01] for k in range(5)]
POSES = [((0.1, 0.2, 0.3 - 0.02 * k), (0.0, 0.0, 0.0, 1.0 if k % 2 else -1.0)) for k in range(4)]   # sign flips


def _messages(store):
    """(joint states, poses) of the test recording as messages of ``store`` (ROS 1 headers carry a seq)."""
    T = store.types
    ros1 = store is ROS1

    def header(k):
        stamp = T["builtin_interfaces/msg/Time"](sec=k, nanosec=0)
        return T["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id="world") if ros1 else \
            T["std_msgs/msg/Header"](stamp=stamp, frame_id="world")

    zeros = np.zeros(len(NAMES))
    joints = [T[JOINT_STATE](header=header(k), name=NAMES, position=np.array(q, float), velocity=zeros, effort=zeros)
              for k, q in enumerate(POSITIONS)]
    poses = []
    for k, (p, q) in enumerate(POSES):
        point = T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2])
        orientation = T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])
        poses.append(T[POSE](header=header(k), pose=T["geometry_msgs/msg/Pose"](position=point,
                                                                               orientation=orientation)))
    return joints, poses


def ros1_bag(path):
    joints, poses = _messages(ROS1)
    with Writer1(path) as writer:
        for topic, msgtype, messages in (("/lbr/joint_states", JOINT_STATE, joints), ("/probe/pose", POSE, poses)):
            connection = writer.add_connection(topic, msgtype, typestore=ROS1)
            for k, message in enumerate(messages):
                writer.write(connection, (k + 1) * 10**8, ROS1.serialize_ros1(message, msgtype))
    return path


def ros2_bag(path, storage=StoragePlugin.SQLITE3, extra=()):
    """A rosbag2 folder (format version 9, with message definitions); ``extra``: (topic, msgtype, raw messages)."""
    joints, poses = _messages(ROS2)
    with Writer2(path, version=9, storage_plugin=storage) as writer:
        for topic, msgtype, messages in (("/lbr/joint_states", JOINT_STATE, joints), ("/probe/pose", POSE, poses)):
            connection = writer.add_connection(topic, msgtype, typestore=ROS2)
            for k, message in enumerate(messages):
                writer.write(connection, (k + 1) * 10**8, ROS2.serialize_cdr(message, msgtype))
        for topic, msgtype, raws in extra:
            connection = writer.add_connection(topic, msgtype, typestore=ROS2)
            for k, raw in enumerate(raws):
                writer.write(connection, (k + 1) * 10**8, raw)
    return path


def without_definitions(folder):
    """The sqlite3 bag as Foxy and Humble record it: no message definitions (CDR only)."""
    (db,) = folder.glob("*.db3")
    with sqlite3.connect(db) as connection:
        connection.execute("DELETE FROM message_definitions")
    return folder


def _forms(tmp_path):
    """name -> a ROS 2 form of the test recording."""
    sqlite = ros2_bag(tmp_path / "sqlite")
    mcap = ros2_bag(tmp_path / "mcap", StoragePlugin.MCAP)
    bare = tmp_path / "bare"
    bare.mkdir()
    shutil.copy(next(sqlite.glob("*.db3")), bare / "demo.db3")
    shutil.copy(next(mcap.glob("*.mcap")), bare / "demo.mcap")
    humble = without_definitions(ros2_bag(tmp_path / "humble"))
    return {"sqlite3 folder": sqlite, "MCAP folder": mcap, ".db3 file": bare / "demo.db3",
            ".mcap file": bare / "demo.mcap", "sqlite3 folder without definitions": humble}


def test_rosbag2_sqlite3_and_mcap_read_as_the_ros1_bag(tmp_path):
    ros1 = ros1_bag(tmp_path / "demo.bag")
    joints1 = read_path(ros1, "/lbr/joint_states", joints=["lbr_A1", "lbr_A2"])
    np.testing.assert_allclose(joints1, [[-0.2 * k, 0.1 * k] for k in range(5)])
    poses1 = read_path(ros1, "/probe/pose")
    assert np.all(poses1[:, 6] == -1.0)                      # the quaternion's sign kept continuous (as the first)
    demo1 = import_demonstration(ros1, "/probe/pose", [0.1, 0.2, 0.2], planes=[[0, 0, 1, 1.0]])
    for form, bag in _forms(tmp_path).items():
        np.testing.assert_array_equal(read_path(bag, "/lbr/joint_states", joints=["lbr_A1", "lbr_A2"]), joints1,
                                      err_msg=form)
        np.testing.assert_array_equal(read_path(bag, "/lbr/joint_states", joints=["lbr_A1"], min_step=0.3),
                                      read_path(ros1, "/lbr/joint_states", joints=["lbr_A1"], min_step=0.3))
        np.testing.assert_array_equal(read_path(bag, "/probe/pose"), poses1, err_msg=form)
        demo = import_demonstration(bag, "/probe/pose", [0.1, 0.2, 0.2], planes=[[0, 0, 1, 1.0]])
        np.testing.assert_array_equal(demo.path, demo1.path)
        np.testing.assert_array_equal(demo.task.start, demo1.task.start)
        assert demo.source == demo1.source == "rosbag:/probe/pose"


def test_broken_rosbag2_bags_are_clear_errors(tmp_path):
    folder = ros2_bag(tmp_path / "bag", extra=[("/bad/joint_states", JOINT_STATE, [b"\x00\x01\x00\x00\xff\xff"])])
    with pytest.raises(ConfigError, match=r"no such topic .*topics: /bad/joint_states, /lbr/joint_states, /probe/pose"):
        read_path(folder, "/joint_states", joints=["lbr_A1"])
    with pytest.raises(ConfigError, match="message 0 of the topic is not readable"):
        read_path(folder, "/bad/joint_states", joints=["lbr_A1"])
    with pytest.raises(ConfigError, match=r"joint\(s\) \['lbr_A7'\] missing"):
        read_path(folder, "/lbr/joint_states", joints=["lbr_A1", "lbr_A7"])
    # a folder without its metadata.yaml, one whose storage file is gone, garbage storage files, other files
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match=r"not a readable ROS bag \(a ROS 1 .bag file, a ROS 2 bag folder"):
        read_path(tmp_path / "empty", "/x")
    (db,) = folder.glob("*.db3")
    moved = tmp_path / "moved.db3"
    db.rename(moved)
    with pytest.raises(ConfigError, match=r"not a readable ROS bag.*missing"):
        read_path(folder, "/lbr/joint_states", joints=["lbr_A1"])
    for name in ("junk.db3", "junk.mcap"):
        (tmp_path / name).write_bytes(b"not a bag at all")
        with pytest.raises(ConfigError, match="not a readable ROS bag"):
            read_path(tmp_path / name, "/x")
    (tmp_path / "demo.yaml").write_text("rosbag2_bagfile_information: {}\n")
    with pytest.raises(ConfigError, match=r"not a ROS bag: expected a ROS 1 .bag file"):
        read_path(tmp_path / "demo.yaml", "/x")


def test_the_command_imports_a_ros2_bag(tmp_path, capsys):
    from pliant.cli import main
    from pliant_piirl.demonstration import load_demonstrations

    bag = ros2_bag(tmp_path / "demo", StoragePlugin.MCAP)
    out = tmp_path / "demos.json"
    assert main(["learn", "import", str(bag), "--topic", "/probe/pose", "--scene", "hollow-cube", "--target", "0.1",
                 "0.2", "0.2", "--plane", "0", "0", "1", "1.0", "--output", str(out)]) == 0
    assert "added 4 configurations" in capsys.readouterr().out
    scene, demos = load_demonstrations(out)
    assert scene == "hollow-cube" and len(demos) == 1
    np.testing.assert_array_equal(demos[0].path, read_path(ros1_bag(tmp_path / "demo.bag"), "/probe/pose"))
