"""The presets of the ROS 2 drivers: what an arm's ros2_control setup looks like (no ROS import here).

* **KUKA LBR iiwa 7 R800 under the lbr_fri_ros2_stack** (``iiwa-ros2``; lbr-stack/lbr_fri_ros2_stack,
  ``lbr_description/ros2_control/lbr_controllers.yaml``): namespace ``/lbr``; joints ``lbr_A1`` ... ``lbr_A7`` in
  both the ``forward_position_controller`` (``position_controllers/JointGroupPositionController``, interface
  ``position``) and the ``joint_trajectory_controller`` (command interface ``position``, state interfaces
  ``position`` and ``velocity``); the ``joint_state_broadcaster`` on ``/lbr/joint_states``; the controller manager's
  ``update_rate`` 100 Hz.  pliant's iiwa robot model names the same axes ``lbr_iiwa_joint_1`` ... ``_7``: the driver
  maps one to the other, so the iiwa pipelines bind to this driver unchanged.  Limits: the data sheet's,
  ``limits/iiwa7_r800.toml``.
"""

from __future__ import annotations

from pathlib import Path

#: the plugin's limits files (pliant.hardware.limits format)
LIMITS_DIR = Path(__file__).resolve().parent / "limits"

#: the lbr_fri_ros2_stack's joint names, axes A1..A7
LBR_JOINTS = tuple(f"lbr_A{i}" for i in range(1, 8))
#: the same axes as pliant's iiwa robot model (pybullet_data's kuka_iiwa/model.urdf) names them
IIWA_MODEL_JOINTS = tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8))

#: option defaults of the ``iiwa-ros2`` preset
IIWA_ROS2 = {
    "namespace": "/lbr",
    "joints": LBR_JOINTS,
    "pliant_joints": IIWA_MODEL_JOINTS,
    "forward_controller": "forward_position_controller",
    "trajectory_controller": "joint_trajectory_controller",
    "state_topic": "joint_states",
}
IIWA_LIMITS = LIMITS_DIR / "iiwa7_r800.toml"


def topic(namespace: str, *parts: str) -> str:
    """``/<namespace>/<part>/...`` (an absolute part is taken as is)."""
    if parts and parts[0].startswith("/"):
        return "/" + "/".join(p.strip("/") for p in parts if p.strip("/"))
    return "/" + "/".join(p.strip("/") for p in (namespace, *parts) if p.strip("/"))
