"""The named robots: where their URDF / SRDF live, their joint groups, and published limits.

PR2 and Baxter come from the ``example-robot-data`` package (data only, installed under the cmeel
prefix ``<site-packages>/cmeel.prefix/share/example-robot-data/robots``); the KUKA LBR iiwa 7 R800
from ``pybullet_data`` (``kuka_iiwa/model.urdf``).  The iiwa URDF's velocity limits (10 rad/s) are
placeholders: the robot's data sheet gives 98, 98, 100, 130, 140, 180, 180 deg/s, used here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from pliant.api import SceneError, example_robot_data_dir

NAMED_ROBOTS = ("baxter", "iiwa", "pr2")

#: LBR iiwa 7 R800 axis speeds from the KUKA data sheet, deg/s (axes A1..A7)
IIWA_VELOCITY_LIMITS_DEG = (98.0, 98.0, 100.0, 130.0, 140.0, 180.0, 180.0)

#: the PR2's arms tucked in front of its body (the pr2_tuckarm posture: shoulder pan, lift, upper-arm roll, elbow,
#: forearm roll, wrist flex, wrist roll; rad)
PR2_TUCK_RIGHT = (-0.023593, 1.1072800, -1.5566882, -2.124408, -1.4175, -1.8417, 0.21436)
PR2_TUCK_LEFT = (0.06024, 1.248526, 1.789070, -1.683386, -1.7343417, -0.0962141, -0.0864407)
#: Baxter's untucked neutral arm (s0, s1, e0, e1, w0, w1, w2; rad), the same for either arm
BAXTER_NEUTRAL = (0.0, -0.55, 0.0, 0.75, 0.0, 1.26, 0.0)


@dataclass(frozen=True)
class RobotEntry:
    """A named robot's description.

    urdf / srdf: files (``srdf`` None: adjacent links are the allowed collision pairs).
    package_dirs: directories searched for ``package://`` mesh paths.
    groups: joint groups by name (``"all"`` is added by the robot for every single-DoF joint).
    velocity_limits: per-joint overrides of the URDF's velocity limits, rad/s.
    postures: named configurations per group (group -> name -> joint values in the group's order, rad), the
    robots' customary ones (a scene task's ``start = "tuck"``).
    """

    urdf: Path
    srdf: Path | None
    package_dirs: tuple[Path, ...]
    groups: dict[str, tuple[str, ...]] = field(default_factory=dict)
    velocity_limits: dict[str, float] = field(default_factory=dict)
    postures: dict[str, dict[str, tuple[float, ...]]] = field(default_factory=dict)


def _prefixed(prefix: str, names: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(prefix + n for n in names)


def named_robot(name: str, source: str | None = None) -> RobotEntry:
    """The catalogue entry of ``pr2``, ``baxter`` or ``iiwa``; raises :class:`SceneError` otherwise."""
    if name == "baxter":
        base = example_robot_data_dir(source)
        arm = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")
        return RobotEntry(base / "baxter_description/urdf/baxter.urdf",
                          base / "baxter_description/srdf/baxter_manipulation.srdf",
                          (base.parent.parent, base.parent, base),
                          {"left_arm": _prefixed("left_", arm), "right_arm": _prefixed("right_", arm)},
                          postures={side: {"neutral": BAXTER_NEUTRAL} for side in ("left_arm", "right_arm")})
    if name == "pr2":
        base = example_robot_data_dir(source)
        arm = ("shoulder_pan_joint", "shoulder_lift_joint", "upper_arm_roll_joint", "elbow_flex_joint",
               "forearm_roll_joint", "wrist_flex_joint", "wrist_roll_joint")
        return RobotEntry(base / "pr2_description/urdf/pr2.urdf", base / "pr2_description/srdf/pr2.srdf",
                          (base.parent.parent, base.parent, base),
                          {"left_arm": _prefixed("l_", arm), "right_arm": _prefixed("r_", arm)},
                          postures={"left_arm": {"tuck": PR2_TUCK_LEFT}, "right_arm": {"tuck": PR2_TUCK_RIGHT}})
    if name == "iiwa":
        try:
            import pybullet_data
        except ImportError:
            raise SceneError("pybullet (its pybullet_data package) is not installed; it provides the iiwa URDF",
                             source=source, field="robot.model", value=name) from None
        data = Path(pybullet_data.getDataPath())
        joints = tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8))
        return RobotEntry(data / "kuka_iiwa/model.urdf", None, (data, data / "kuka_iiwa"), {"arm": joints},
                          {j: math.radians(v) for j, v in zip(joints, IIWA_VELOCITY_LIMITS_DEG)},
                          postures={"arm": {"zero": (0.0,) * 7}})
    raise SceneError(f"unknown robot (named robots: {', '.join(NAMED_ROBOTS)}; or give a .urdf file path)",
                     source=source, field="robot.model", value=name)
