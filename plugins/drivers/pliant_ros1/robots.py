"""What each ROS robot is: its commanded joints (read from its URDF), topics, rates and limits file.

No rospy here: the plugin's entry point, the limits tests and ``pliant plugins`` use this module without ROS.

* **PR2** (Willow Garage): an arm's seven joints, ``r_`` or ``l_`` + shoulder_pan, shoulder_lift, upper_arm_roll,
  elbow_flex, forearm_roll, wrist_flex, wrist_roll (``_joint``), read from ``pr2_description/urdf/pr2.urdf`` of
  example-robot-data along the kinematic chain.  Commands ``trajectory_msgs/JointTrajectory`` on
  ``/r_arm_controller/command`` (``/l_arm_controller/command``); states ``sensor_msgs/JointState`` on
  ``/joint_states`` (every joint of the robot).
* **Baxter** (Rethink Robotics): ``right_`` / ``left_`` + s0, s1, e0, e1, w0, w1, w2 from
  ``baxter_description/urdf/baxter.urdf``.  Commands ``baxter_core_msgs/JointCommand`` on
  ``/robot/limb/<side>/joint_command``; states on ``/robot/joint_states`` (both arms, the head and the torso).
* **KUKA LBR iiwa 7 R800** (iiwa_stack conventions): ``lbr_iiwa_joint_1`` ... ``_7`` from pybullet_data's
  ``kuka_iiwa/model.urdf``.  Commands and states ``iiwa_msgs/JointPosition`` on ``/iiwa/command/JointPosition``
  and ``/iiwa/state/JointPosition`` (no joint names: a1 ... a7 in axis order).
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from pliant.api import ConfigError, example_robot_data_dir

#: the robots this plugin drives
ROBOTS = ("pr2", "baxter", "iiwa")
#: the arms of the two-armed robots
SIDES = ("right", "left")
#: the plugin's limits files (pliant.hardware.limits format)
LIMITS_DIR = Path(__file__).resolve().parent / "limits"
#: scenes the peer uses for robots pliant bundles no scene of
SCENES_DIR = Path(__file__).resolve().parent / "scenes"

#: Baxter's ``/robot/joint_states`` names, in the order the robot publishes them (both arms, head, torso)
BAXTER_STATE_JOINTS = ("head_nod", "head_pan",
                       "left_e0", "left_e1", "left_s0", "left_s1", "left_w0", "left_w1", "left_w2",
                       "right_e0", "right_e1", "right_s0", "right_s1", "right_w0", "right_w1", "right_w2",
                       "torso_t0")


def pybullet_data_dir() -> Path:
    """pybullet_data's directory (it holds the iiwa URDF)."""
    try:
        import pybullet_data
    except ImportError:
        raise ConfigError("pybullet (its pybullet_data package) is not installed; it provides the iiwa URDF",
                          field="robot", value="iiwa") from None
    return Path(pybullet_data.getDataPath())


def urdf_path(robot: str) -> Path:
    """The URDF file of ``robot`` (``pr2``, ``baxter`` or ``iiwa``)."""
    if robot == "pr2":
        return example_robot_data_dir() / "pr2_description/urdf/pr2.urdf"
    if robot == "baxter":
        return example_robot_data_dir() / "baxter_description/urdf/baxter.urdf"
    if robot == "iiwa":
        return pybullet_data_dir() / "kuka_iiwa/model.urdf"
    raise ConfigError(f"unknown robot (this plugin drives {', '.join(ROBOTS)})", field="robot", value=robot)


@functools.cache
def _joints(path: Path) -> dict[str, ET.Element]:
    root = ET.parse(path).getroot()
    return {j.get("name"): j for j in root.findall("joint")}


def movable_joints(path: Path) -> tuple[str, ...]:
    """Every joint of the URDF at ``path`` that is not fixed, in file order."""
    return tuple(n for n, j in _joints(Path(path)).items() if j.get("type") != "fixed")


def chain_joints(path: Path, first: str, last: str) -> tuple[str, ...]:
    """The movable joints of the kinematic chain from joint ``first`` to joint ``last`` (both included), root to
    tip, walking the URDF's parent links from ``last`` back to ``first``."""
    joints = _joints(Path(path))
    by_child = {j.find("child").get("link"): n for n, j in joints.items()}
    if first not in joints or last not in joints:
        raise ConfigError(f"{path} has no joint {first if first not in joints else last}", field="joints",
                          value=[first, last])
    chain, name = [], last
    while True:
        chain.append(name)
        if name == first:
            break
        parent = joints[name].find("parent").get("link")
        if parent not in by_child:
            raise ConfigError(f"{path}: joint {first} is not on the chain to {last}", field="joints",
                              value=[first, last])
        name = by_child[parent]
    return tuple(n for n in reversed(chain) if joints[n].get("type") != "fixed")


def joint_limits_from_urdf(path: Path, name: str) -> dict[str, float | None]:
    """``{type, lower, upper, velocity, soft_lower, soft_upper}`` of joint ``name`` in the URDF (None if absent)."""
    joint = _joints(Path(path))[name]
    limit = joint.find("limit")
    safety = joint.find("safety_controller")

    def number(element, key):
        return None if element is None or element.get(key) is None else float(element.get(key))

    return {"type": joint.get("type"), "lower": number(limit, "lower"), "upper": number(limit, "upper"),
            "velocity": number(limit, "velocity"), "soft_lower": number(safety, "soft_lower_limit"),
            "soft_upper": number(safety, "soft_upper_limit")}


def _check_side(side: str) -> str:
    if side not in SIDES:
        raise ConfigError(f"must be one of {', '.join(SIDES)}", field="side", value=side)
    return side


def arm_joints(robot: str, side: str = "right") -> tuple[str, ...]:
    """The commanded joints of ``robot``'s arm (``side`` for PR2 and Baxter), root to tip, read from its URDF."""
    path = urdf_path(robot)
    if robot == "pr2":
        p = _check_side(side)[0]
        return chain_joints(path, f"{p}_shoulder_pan_joint", f"{p}_wrist_roll_joint")
    if robot == "baxter":
        return chain_joints(path, f"{_check_side(side)}_s0", f"{side}_w2")
    return chain_joints(path, "lbr_iiwa_joint_1", "lbr_iiwa_joint_7")


def limits_file(robot: str, side: str = "right") -> Path:
    """The plugin's limits file of ``robot``'s arm."""
    if robot == "iiwa":
        return LIMITS_DIR / "iiwa7_r800.toml"
    if robot not in ROBOTS:
        raise ConfigError(f"unknown robot (this plugin drives {', '.join(ROBOTS)})", field="robot", value=robot)
    return LIMITS_DIR / f"{robot}_{_check_side(side)}_arm.toml"


@dataclass(frozen=True)
class RosRobot:
    """One robot arm's ROS interface (what the driver and the peer agree on).

    joints: the commanded joints, in command order.  state_topic / command_topic: topic names.  state_rate: how
    often the real robot publishes its joint states (Hz; the peer's default).  command_timeout: the robot's own
    command timeout (s), None when it holds the last command.  scene: the peer's default scene.  group: the
    pinocchio robot model's joint group of the arm.
    """

    robot: str
    side: str
    joints: tuple[str, ...]
    state_topic: str
    command_topic: str
    state_rate: float
    command_timeout: float | None
    scene: str
    group: str

    @property
    def limits_file(self) -> Path:
        """The plugin's limits file of this arm."""
        return limits_file(self.robot, self.side)


def ros_robot(robot: str, side: str = "right") -> RosRobot:
    """The :class:`RosRobot` of ``robot`` (``pr2``, ``baxter``, ``iiwa``) and ``side`` (ignored for the iiwa)."""
    if robot == "pr2":
        return RosRobot("pr2", side, arm_joints("pr2", side), "/joint_states", f"/{side[0]}_arm_controller/command",
                        100.0, None, str(SCENES_DIR / "pr2-arm.toml"), f"{side}_arm")
    if robot == "baxter":
        return RosRobot("baxter", side, arm_joints("baxter", side), "/robot/joint_states",
                        f"/robot/limb/{side}/joint_command", 100.0, 0.2, "baxter-reach", f"{side}_arm")
    if robot == "iiwa":
        return RosRobot("iiwa", "", arm_joints("iiwa"), "/iiwa/state/JointPosition", "/iiwa/command/JointPosition",
                        250.0, None, "iiwa-shelf", "arm")
    raise ConfigError(f"unknown robot (this plugin drives {', '.join(ROBOTS)})", field="robot", value=robot)


def state_joints(robot: str) -> tuple[str, ...]:
    """The joints the robot's state messages name, in the robot's order: Baxter's both arms, head and torso; every
    movable joint of the PR2's URDF; the iiwa's axes (its messages carry no names)."""
    if robot == "baxter":
        return BAXTER_STATE_JOINTS
    if robot == "pr2":
        return movable_joints(urdf_path("pr2"))
    return arm_joints("iiwa")
