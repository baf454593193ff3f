"""A URDF robot in pybullet with compliant joint position control (PD with torque limits).

The robot model (``pinocchio``, or any :class:`~pliant.interfaces.RobotModel` that offers
:meth:`~pliant.interfaces.RobotModel.urdf_description`) says which URDF, which joints are planned (in
configuration order) and where the other joints are held, so the configuration vector means the same
joints here as in the kinematic simulator.  The base is fixed where the description places it (a scene's task may
place it; else the world origin), as in the robot model.

Every joint is driven by pybullet's position motor: a PD law whose torque is capped at the joint's
effort limit (N m or N) times ``effort_scale``, so a robot pushed into an obstacle stops there with a
bounded force.  The motors' targets sweep along the commanded motion over the physics substeps.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from pliant.api import SimulationError


@contextlib.contextmanager
def _captured_native_output():
    """Capture what pybullet's C++ code prints (it writes to the process's stdout / stderr directly).

    Yields a function returning the captured text, so loading errors can quote pybullet's reasons.
    """
    with tempfile.TemporaryFile(mode="w+b") as sink:
        saved = [os.dup(1), os.dup(2)]
        try:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            text: list[str] = []
            yield lambda: "".join(text)
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            sink.seek(0)
            text.append(sink.read().decode("utf-8", "replace"))


def _links_with_collisions(urdf: Path, source: str) -> dict[str, list[str]]:
    """For each URDF link with collision geometry: the geometry descriptions (mesh files or shape kinds)."""
    try:
        root = ET.parse(urdf).getroot()
    except (OSError, ET.ParseError) as exc:
        raise SimulationError(f"pybullet cannot load the URDF: {exc}", source=source, field="robot.model",
                              value=str(urdf)) from None
    links: dict[str, list[str]] = {}
    for link in root.iter("link"):
        found = []
        for collision in link.findall("collision"):
            for geometry in collision.findall("geometry"):
                for shape in geometry:
                    found.append(shape.get("filename", shape.tag))
        if found:
            links[link.get("name", "?")] = found
    return links


def _reasons(log: str) -> str:
    lines = [ln.strip() for ln in log.splitlines() if ("rror" in ln or "cannot" in ln or "annot" in ln)
             and "inertial" not in ln]
    return "; ".join(dict.fromkeys(lines))[:400]


class ArticulatedRobot:
    """A fixed-base URDF robot in a pybullet client, its planned joints under compliant position control.

    ``description`` is the robot model's :class:`~pliant.interfaces.UrdfDescription`; ``lower`` /
    ``upper`` ``(d,)`` bound the motors' targets (the robot model's joint limits); ``effort_scale``
    scales the URDF's effort limits (a joint with none, or a non-positive one, is refused: the torque
    cap would be meaningless); ``position_gain`` / ``velocity_gain`` are pybullet's motor gains;
    ``self_collision`` lets links collide with each other (parents excluded).
    """

    def __init__(self, pb, description, lower, upper, *, effort_scale: float, position_gain: float,
                 velocity_gain: float, friction: float, self_collision: bool, source: str) -> None:
        self.pb = pb
        self.lower = np.asarray(lower, dtype=np.float64)
        self.upper = np.asarray(upper, dtype=np.float64)
        self.position_gain = position_gain
        self.velocity_gain = velocity_gain
        self.self_collision = self_collision
        urdf = Path(description.urdf)
        self.body = self._load(urdf, description.package_dirs, self_collision, source,
                               getattr(description, "base_position", (0.0, 0.0, 0.0)),
                               getattr(description, "base_orientation", (0.0, 0.0, 0.0, 1.0)))
        index = {}
        for j in range(pb.getNumJoints(self.body)):
            info = pb.getJointInfo(self.body, j)
            index[info[1].decode()] = j
            pb.changeDynamics(self.body, j, lateralFriction=friction, linearDamping=0.0, angularDamping=0.0)
        missing = [n for n in (*description.joint_names, *description.posture) if n not in index]
        if missing:
            raise SimulationError("pybullet's model of the URDF lacks joints the robot model plans or holds",
                                  source=source, field="robot.model", value=missing)
        self.joints = [index[n] for n in description.joint_names]
        self.held = [index[n] for n in description.posture]
        self.posture = np.array([description.posture[n] for n in description.posture], dtype=np.float64)
        efforts = np.asarray(description.effort_limits, dtype=np.float64) * effort_scale
        bad = [n for n, e in zip(description.joint_names, efforts) if not (np.isfinite(e) and e > 0)]
        if bad:
            raise SimulationError("these joints have no positive effort limit in the URDF, so their torque cannot "
                                  "be capped; give them one", source=source, field="robot.model", value=bad)
        self.efforts = efforts
        held_efforts = [pb.getJointInfo(self.body, j)[10] for j in self.held]
        self.held_efforts = np.array([e if e > 0 else float(efforts.max()) for e in held_efforts]) * effort_scale

    def _load(self, urdf: Path, package_dirs, self_collision: bool, source: str, position=(0.0, 0.0, 0.0),
              orientation=(0.0, 0.0, 0.0, 1.0)) -> int:
        pb = self.pb
        # visual meshes are never drawn here (a DIRECT connection) and take no part in the physics; Baxter's took
        # 1.7 of the 1.75 s its URDF took to load
        flags = pb.URDF_IGNORE_VISUAL_SHAPES
        if self_collision:
            flags |= pb.URDF_USE_SELF_COLLISION | pb.URDF_USE_SELF_COLLISION_EXCLUDE_ALL_PARENTS
        expected = _links_with_collisions(urdf, source)
        body, log = -1, ""
        for directory in package_dirs or (urdf.parent,):
            pb.setAdditionalSearchPath(str(directory))
            with _captured_native_output() as output:
                try:
                    body = pb.loadURDF(str(urdf), basePosition=list(position), baseOrientation=list(orientation),
                                       useFixedBase=True, flags=flags)
                except pb.error:
                    body = -1
            log = output()
            if body >= 0:
                break
        if body < 0:
            raise SimulationError(f"pybullet cannot load the URDF ({_reasons(log) or 'no reason given'})",
                                  source=source, field="robot.model", value=str(urdf))
        names = {pb.getJointInfo(body, j)[12].decode(): j for j in range(pb.getNumJoints(body))}
        names[pb.getBodyInfo(body)[0].decode()] = -1
        unread = {link: shapes for link, shapes in expected.items()
                  if link in names and not pb.getCollisionShapeData(body, names[link])}
        if unread:
            pb.removeBody(body)
            link, shapes = next(iter(unread.items()))
            raise SimulationError(f"pybullet could not read the collision geometry of {len(unread)} link(s), e.g. "
                                  f"link '{link}': {', '.join(shapes)} ({_reasons(log) or 'no reason given'}); "
                                  "the robot would pass through obstacles there", source=source,
                                  field="robot.model", value=str(urdf))
        return body

    def reset(self, q: np.ndarray) -> None:
        """Place the planned joints at ``q`` ``(d,)`` and the others at their posture, at rest."""
        for j, value in zip(self.joints, q):
            self.pb.resetJointState(self.body, j, float(value), 0.0)
        for j, value in zip(self.held, self.posture):
            self.pb.resetJointState(self.body, j, float(value), 0.0)
        if self.held:
            self.pb.setJointMotorControlArray(self.body, self.held, self.pb.POSITION_CONTROL,
                                              targetPositions=self.posture.tolist(),
                                              forces=self.held_efforts.tolist())
        self._drive(np.asarray(q, dtype=np.float64), np.zeros(len(self.joints)))

    def _drive(self, target: np.ndarray, velocity: np.ndarray) -> None:
        self.pb.setJointMotorControlArray(
            self.body, self.joints, self.pb.POSITION_CONTROL, targetPositions=target.tolist(),
            targetVelocities=velocity.tolist(), forces=self.efforts.tolist(),
            positionGains=[self.position_gain] * len(self.joints),
            velocityGains=[self.velocity_gain] * len(self.joints))

    def configuration(self) -> np.ndarray:
        """The planned joints' positions ``(d,)`` (rad or m)."""
        return np.array([s[0] for s in self.pb.getJointStates(self.body, self.joints)], dtype=np.float64)

    def command(self, q: np.ndarray, motion: np.ndarray, fraction: float, dt: float) -> None:
        """Aim the motors at ``fraction`` of the joint ``motion`` (rad or m over ``dt`` s) from ``q``."""
        target = np.clip(q + motion * fraction, self.lower, self.upper)
        self._drive(target, motion / dt)

    def joint_efforts(self) -> np.ndarray:
        """Magnitudes ``(d,)`` of the torques (N m) or forces (N) the planned joints' motors applied last step."""
        return np.abs(np.array([s[3] for s in self.pb.getJointStates(self.body, self.joints)], dtype=np.float64))

    def touching(self) -> bool:
        """Whether the robot touches another body (or itself, when self-collision is on) now."""
        for contact in self.pb.getContactPoints(bodyA=self.body):
            if contact[2] != self.body or self.self_collision:
                return True
        return False
