"""The named robots: where their URDF / SRDF live, their joint groups, and published limits.

PR2 and Baxter come from the ``example-robot-data`` package (data only, installed under the cmeel
prefix); the KUKA LBR iiwa 7 R800 from ``pybullet_data``.  The iiwa URDF's velocity limits (10 rad/s)
are placeholders: the robot's data sheet gives 98, 98, 100, 130, 140, 180, 180 deg/s.
"""

from __future__ import annotations

import importlib.metadata
import math
from dataclasses import dataclass, field
from pathlib import Path

from pliant.errors import PluginError


@dataclass(frozen=True)
class RobotEntry:
    """A named robot: files, package directories for meshes, joint groups, velocity limits (rad/s)."""

    urdf: Path
    srdf: Path | None
    package_dirs: tuple[Path, ...]
    groups: dict[str, tuple[str, ...]] = field(default_factory=dict)
    velocity_limits: dict[str, float] = field(default_factory=dict)


def _example_robot_data() -> Path:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise PluginError("example-robot-data is not installed (it provides the PR2 and Baxter URDFs)",
                          field="robot.model", value="example-robot-data") from None
    robots = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    if not robots.is_dir():
        raise PluginError("example-robot-data is installed but its robots directory is missing",
                          field="robot.model", value=str(robots))
    return robots


def _arm(prefix: str, names: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(prefix + n for n in names)


def named_robot(name: str) -> RobotEntry:
    """The catalogue entry of ``pr2``, ``baxter`` or ``iiwa``; raises :class:`PluginError` otherwise."""
    if name == "baxter":
        base = _example_robot_data()
        arm = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")
        return RobotEntry(base / "baxter_description/urdf/baxter.urdf",
                          base / "baxter_description/srdf/baxter_manipulation.srdf",
                          (base.parent.parent, base.parent),
                          {"left_arm": _arm("left_", arm), "right_arm": _arm("right_", arm)})
    if name == "pr2":
        base = _example_robot_data()
        arm = ("shoulder_pan_joint", "shoulder_lift_joint", "upper_arm_roll_joint", "elbow_flex_joint",
               "forearm_roll_joint", "wrist_flex_joint", "wrist_roll_joint")
        return RobotEntry(base / "pr2_description/urdf/pr2.urdf", base / "pr2_description/srdf/pr2.srdf",
                          (base.parent.parent, base.parent),
                          {"left_arm": _arm("l_", arm), "right_arm": _arm("r_", arm)})
    if name == "iiwa":
        import pybullet_data

        data = Path(pybullet_data.getDataPath())
        joints = tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8))
        published = (98, 98, 100, 130, 140, 180, 180)     # deg/s, LBR iiwa 7 R800 data sheet
        return RobotEntry(data / "kuka_iiwa/model.urdf", None, (data, data / "kuka_iiwa"), {"arm": joints},
                          {j: math.radians(v) for j, v in zip(joints, published)})
    raise PluginError("unknown robot (named robots: baxter, iiwa, pr2; or give a .urdf path)", field="robot.model",
                      value=name)
