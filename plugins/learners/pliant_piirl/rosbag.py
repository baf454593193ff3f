"""Demonstrations from ROS bags (the ``rosbags`` package, pure Python: no ROS installation needed).

People record demonstrations on real robots as a topic in a bag.  Accepted: a ROS 1 ``.bag`` file; a ROS 2
(rosbag2) bag folder (its ``metadata.yaml`` and storage files: sqlite3 ``.db3`` or MCAP ``.mcap``, split bags and
zstd compression included); a single rosbag2 storage file (``.db3`` or ``.mcap``) without its folder.  ROS 2
messages are CDR, decoded with the definitions the bag carries (rosbag2 writes them since Iron, MCAP always) or,
for a bag without them (sqlite3 bags of Foxy and Humble), with ROS 2's standard definitions; ROS 1 bags always
carry theirs.  :func:`read_path` turns one topic into a path:

- ``geometry_msgs/PoseStamped``, ``geometry_msgs/Pose`` and ``geometry_msgs/TransformStamped``: SE(3)
  configurations ``(x, y, z, qx, qy, qz, qw)`` (metres; quaternions normalised, their sign made continuous);
- ``sensor_msgs/JointState``: joint positions in the order of ``joints`` (every named joint must be in every
  message; other joints are ignored).

Messages are taken in bag time order; ``min_step`` drops a configuration closer than that (Euclidean, in the
configuration's own units) to the last one kept, thinning a high-rate recording.  :func:`import_demonstration`
adds the task (the first configuration is the task's start unless one is given).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pliant.api import ConfigError

from pliant_piirl.demonstration import Demonstration, DemonstrationTask

POSE_TYPES = ("geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/Pose", "geometry_msgs/msg/TransformStamped")
JOINT_TYPES = ("sensor_msgs/msg/JointState",)
#: the files a bag may be given as (a folder is a ROS 2 bag folder)
BAG_SUFFIXES = (".bag", ".db3", ".mcap")
FORMS = "a ROS 1 .bag file, a ROS 2 bag folder with its metadata.yaml, or a ROS 2 .db3 / .mcap storage file"


def read_path(bag: str | Path, topic: str, *, joints: list[str] | None = None, min_step: float = 0.0) -> np.ndarray:
    """The configurations ``(k, d)`` recorded on ``topic`` in ``bag`` (see the module docstring)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = Path(bag)
    if not path.exists():
        raise ConfigError("no such bag", field="bag", value=str(path))
    if not (np.isfinite(min_step) and min_step >= 0):
        raise ConfigError("must be a non-negative number", field="min_step", value=min_step)
    if path.is_file() and path.suffix not in BAG_SUFFIXES:
        raise ConfigError(f"not a ROS bag: expected {FORMS}", source=str(path), field="bag", value=str(path))
    # rosbags tells the formats apart by the name: a .bag file is ROS 1, anything else ROS 2
    store = Stores.ROS1_NOETIC if path.suffix == ".bag" else Stores.ROS2_HUMBLE
    try:
        reader = AnyReader([path], default_typestore=get_typestore(store))
        reader.open()
    except Exception as exc:           # rosbags raises its own error types for every kind of broken bag
        raise ConfigError(f"not a readable ROS bag ({FORMS}): {exc}", source=str(path)) from None
    try:
        connections = [c for c in reader.connections if c.topic == topic]
        if not connections:
            topics = sorted({c.topic for c in reader.connections})
            raise ConfigError(f"no such topic in the bag (topics: {', '.join(topics) or 'none'})", source=str(path),
                              field="topic", value=topic)
        kind = connections[0].msgtype
        if kind not in POSE_TYPES + JOINT_TYPES:
            raise ConfigError(f"unsupported message type {kind} (supported: {', '.join(POSE_TYPES + JOINT_TYPES)})",
                              source=str(path), field="topic", value=topic)
        if kind in JOINT_TYPES and not joints:
            raise ConfigError("a JointState topic needs the joint names, in configuration order", source=str(path),
                              field="joints", value=joints)
        rows = []
        try:
            for connection, _, raw in reader.messages(connections=connections):
                message = reader.deserialize(raw, connection.msgtype)
                rows.append(_configuration(message, kind, joints, str(path)))
        except ConfigError:
            raise
        except Exception as exc:       # a truncated file, a message its definition does not decode, ...
            raise ConfigError(f"message {len(rows)} of the topic is not readable: {type(exc).__name__}: {exc}",
                              source=str(path), field="topic", value=topic) from None
    finally:
        reader.close()
    if not rows:
        raise ConfigError("the topic holds no messages", source=str(path), field="topic", value=topic)
    out = np.array(rows, dtype=np.float64)
    if not np.all(np.isfinite(out)):
        raise ConfigError("the recording holds non-finite values", source=str(path), field="topic", value=topic)
    if kind in POSE_TYPES:
        for i in range(1, len(out)):                 # q and -q are one rotation: keep the path continuous
            if out[i, 3:] @ out[i - 1, 3:] < 0:
                out[i, 3:] *= -1.0
    keep = [0]
    for i in range(1, len(out)):
        if np.linalg.norm(out[i] - out[keep[-1]]) >= min_step:
            keep.append(i)
    return out[keep]


def _configuration(message, kind: str, joints, source: str) -> list[float]:
    if kind in JOINT_TYPES:
        names = list(message.name)
        missing = [j for j in joints if j not in names]
        if missing:
            raise ConfigError(f"joint(s) {missing} missing from a message (it has {names})", source=source,
                              field="joints", value=list(joints))
        return [float(message.position[names.index(j)]) for j in joints]
    if kind.endswith("TransformStamped"):
        t, r = message.transform.translation, message.transform.rotation
    else:
        pose = message.pose if kind.endswith("PoseStamped") else message
        t, r = pose.position, pose.orientation
    q = np.array([r.x, r.y, r.z, r.w], dtype=np.float64)
    norm = np.linalg.norm(q)
    if not norm > 0:
        raise ConfigError("a pose's orientation is not a rotation (zero quaternion)", source=source, field="topic")
    return [float(t.x), float(t.y), float(t.z), *(q / norm).tolist()]


def import_demonstration(bag: str | Path, topic: str, target, *, planes=None, start=None, objects=(),
                         joints: list[str] | None = None, min_step: float = 0.0) -> Demonstration:
    """A demonstration of the task (``target`` m, ``planes`` rows ``(n, offset)``) recorded on ``topic``."""
    path = read_path(bag, topic, joints=joints, min_step=min_step)
    if len(path) < 2:
        raise ConfigError("the recording holds fewer than two distinct configurations", source=str(bag),
                          field="topic", value=topic)
    target = np.asarray(target, dtype=np.float64)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise ConfigError("must be three finite numbers (m)", field="target", value=np.asarray(target).tolist())
    planes = np.zeros((0, 4)) if planes is None else np.asarray(planes, dtype=np.float64).reshape(-1, 4)
    start = path[0] if start is None else np.asarray(start, dtype=np.float64)
    task = DemonstrationTask(start, target, planes, tuple(objects))
    return Demonstration(task, path, f"rosbag:{topic}")
