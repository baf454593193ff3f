"""A free-flying rigid robot (R^3, SE(2), SE(3)) in pybullet, pulled by a force-capped constraint.

The robot is one rigid multibody from the scene's robot parts (boxes, spheres, cylinders; mass =
``density`` x volume).  A fixed constraint pulls it toward the commanded pose with a force capped at
``max_force`` (N), its target swept along the commanded motion over the physics substeps, so the
robot yields against obstacles instead of passing through them.

Bullet caps every row of a fixed constraint with the same number, so its torque cap is ``max_force`` read in
N m: the hold's torque-to-force ratio is 1 m, far stiffer in rotation than a wrist under impedance control.
With ``max_torque`` the rotation is held separately: a point-to-point constraint (capped at ``max_force``)
pulls the reference point, and a torque capped at ``max_torque`` (N m) turns the body toward the commanded
orientation, computed each physics step as the torque that would reach it in ``ANGULAR_STEPS`` steps.  The
ratio ``max_torque / max_force`` is then the lever arm beyond which a contact turns the body, the quantity the
kinematic simulator's effort solver calls ``effort_length``.
"""

from __future__ import annotations

import math

import numpy as np
from pliant.api import SimulationError

#: physics steps in which the capped torque drive would bring the body to its commanded orientation
ANGULAR_STEPS = 2.0


def _yaw_quaternion(theta: float) -> list[float]:
    return [0.0, 0.0, math.sin(theta / 2), math.cos(theta / 2)]


def robot_collision_shape(pb, scene, density: float) -> tuple[int, float]:
    """A pybullet compound collision shape of the scene's rigid robot, and its mass (kg).

    Parts that pybullet cannot represent exactly (meshes, voxel arrays, cut-outs) are refused with a
    :class:`SimulationError` naming the part.
    """
    import pybullet

    kinds, sizes, positions, orientations, volume = [], [], [], [], 0.0
    for k, rp in enumerate(scene.robot.parts):
        part = rp.part
        if part.cutouts:
            raise SimulationError("robot parts with cut-outs cannot be represented in pybullet",
                                  source=scene.source, field=f"robot.parts[{k}].cutouts")
        s = part.shape
        if s.kind == "box":
            kinds.append(pybullet.GEOM_BOX)
            sizes.append({"halfExtents": (s.size / 2).tolist()})
            volume += float(np.prod(s.size))
        elif s.kind == "sphere":
            kinds.append(pybullet.GEOM_SPHERE)
            sizes.append({"radius": s.radius})
            volume += 4 / 3 * math.pi * s.radius ** 3
        elif s.kind == "cylinder":
            kinds.append(pybullet.GEOM_CYLINDER)
            sizes.append({"radius": s.radius, "length": s.length})
            volume += math.pi * s.radius ** 2 * s.length
        else:
            raise SimulationError(f"robot part shape '{s.kind}' cannot be represented in pybullet",
                                  source=scene.source, field=f"robot.parts[{k}].shape", value=s.kind)
        positions.append(part.pose.position.tolist())
        orientations.append(part.pose.orientation.tolist())
    shape = pb.createCollisionShapeArray(
        shapeTypes=kinds, halfExtents=[d.get("halfExtents", [0, 0, 0]) for d in sizes],
        radii=[d.get("radius", 0.0) for d in sizes], lengths=[d.get("length", 0.0) for d in sizes],
        collisionFramePositions=positions, collisionFrameOrientations=orientations)
    return shape, density * volume


class FreeFlyer:
    """The scene's rigid robot as a pybullet body held by a force-capped fixed constraint.

    ``kind`` is the space's kind (``rn`` / ``se2`` / ``se3``); ``max_force`` (N) caps the pull;
    ``max_torque`` (N m, or ``None``: the fixed constraint's own cap) caps the turn; ``friction`` is the
    Coulomb coefficient of the robot's surface; ``time_step`` is the physics step (s); ``mass`` (kg) and
    ``restitution``, when given (the scene's ``[robot]``), replace ``density`` x volume and Bullet's default.
    """

    def __init__(self, pb, scene, space, density: float, max_force: float, friction: float,
                 max_torque: float | None = None, time_step: float = 1 / 240, mass: float | None = None,
                 restitution: float | None = None) -> None:
        self.pb = pb
        self.space = space
        self.kind = scene.robot.space
        self.max_force = max_force
        self.max_torque = max_torque
        self.time_step = time_step
        self.friction = friction
        self.shape, self.mass = robot_collision_shape(pb, scene, density)
        if mass is not None:
            self.mass = mass
        self.restitution = restitution
        self.body = self.hold = None
        self._orientation = None

    def _pose(self, q):
        if self.kind == "se3":
            return q[:3].tolist(), q[3:7].tolist()
        if self.kind == "se2":
            return [q[0], q[1], 0.0], _yaw_quaternion(q[2])
        return q[:3].tolist(), [0.0, 0.0, 0.0, 1.0]

    def configuration(self) -> np.ndarray:
        """The body's pose as a configuration ``(d,)`` (SE(3) quaternions with ``qw >= 0``)."""
        pos, quat = self.pb.getBasePositionAndOrientation(self.body)
        if self.kind == "se3":
            q = np.array([*pos, *quat])
            return q if q[6] >= 0 else np.concatenate([q[:3], -q[3:]])
        if self.kind == "se2":
            yaw = 2 * math.atan2(quat[2], quat[3])
            return np.array([pos[0], pos[1], (yaw + math.pi) % (2 * math.pi) - math.pi])
        return np.array(pos)

    def reset(self, q: np.ndarray) -> None:
        """Rebuild the body at ``q`` at rest (no solver state survives from a previous particle)."""
        if self.body is not None:
            self.pb.removeConstraint(self.hold)
            self.pb.removeBody(self.body)
        position, orientation = self._pose(q)
        self.body = self.pb.createMultiBody(self.mass, self.shape, basePosition=position, baseOrientation=orientation)
        self.pb.changeDynamics(self.body, -1, lateralFriction=self.friction, linearDamping=0.0, angularDamping=0.0)
        if self.restitution is not None:
            self.pb.changeDynamics(self.body, -1, restitution=self.restitution)
        if self.max_torque is None:
            self.hold = self.pb.createConstraint(self.body, -1, -1, -1, self.pb.JOINT_FIXED, [0, 0, 0], [0, 0, 0],
                                                 position, childFrameOrientation=orientation)
            self.pb.changeConstraint(self.hold, position, orientation, maxForce=self.max_force)
        else:
            self.hold = self.pb.createConstraint(self.body, -1, -1, -1, self.pb.JOINT_POINT2POINT, [0, 0, 0],
                                                 [0, 0, 0], position)
            self.pb.changeConstraint(self.hold, position, maxForce=self.max_force)
            info = self.pb.getDynamicsInfo(self.body, -1)
            self._inertia = np.asarray(info[2], dtype=np.float64)
            self._inertial_frame = np.asarray(self.pb.getMatrixFromQuaternion(info[4])).reshape(3, 3)
            self._orientation = orientation

    def command(self, q: np.ndarray, motion: np.ndarray, fraction: float, dt: float) -> None:
        """Move the constraint's target to ``fraction`` of the tangent ``motion`` (over ``dt`` s) from ``q``."""
        position, orientation = self._pose(self.space.retract(q, motion * fraction))
        if self.max_torque is None:
            self.pb.changeConstraint(self.hold, position, orientation, maxForce=self.max_force)
            return
        self.pb.changeConstraint(self.hold, position, maxForce=self.max_force)
        self.pb.applyExternalTorque(self.body, -1, self._turning_torque(orientation).tolist(), self.pb.WORLD_FRAME)

    def _turning_torque(self, target: list[float]) -> np.ndarray:
        """The world-frame torque (N m, norm at most ``max_torque``) that turns the body toward ``target``."""
        _, quat = self.pb.getBasePositionAndOrientation(self.body)
        _, omega = self.pb.getBaseVelocity(self.body)
        current = np.asarray(self.pb.getMatrixFromQuaternion(quat)).reshape(3, 3)
        goal = np.asarray(self.pb.getMatrixFromQuaternion(target)).reshape(3, 3)
        error = _rotation_vector(goal @ current.T)                     # world frame
        h = self.time_step
        wanted = error / (ANGULAR_STEPS * h)
        frame = current @ self._inertial_frame
        inertia = frame @ np.diag(self._inertia) @ frame.T
        torque = inertia @ (wanted - np.asarray(omega)) / h
        norm = float(np.linalg.norm(torque))
        return torque if norm <= self.max_torque else torque * (self.max_torque / norm)

    def pulling_force(self) -> float:
        """Magnitude (N) of the constraint's force in the last physics step."""
        return float(np.linalg.norm(self.pb.getConstraintState(self.hold)[:3]))

    def touching(self) -> bool:
        """Whether the robot touches another body now."""
        return bool(self.pb.getContactPoints(bodyA=self.body))


def _rotation_vector(rotation: np.ndarray) -> np.ndarray:
    """The axis-angle vector ``(3,)`` (rad) of a rotation matrix (the logarithm map of SO(3))."""
    cos = np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0)
    angle = math.acos(cos)
    axis = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0], rotation[1, 0] - rotation[0, 1]])
    if angle < 1e-9:
        return axis / 2.0
    if math.pi - angle < 1e-6:                                     # half a turn: the axis from the diagonal
        k = int(np.argmax(np.diag(rotation)))
        v = (rotation[:, k] + np.eye(3)[k]) / math.sqrt(2.0 * (1.0 + rotation[k, k]))
        return angle * v
    return angle * axis / (2.0 * math.sin(angle))
