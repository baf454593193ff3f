"""Movable scene objects (``mass`` set in the scene) as dynamic pybullet bodies.

Boxes, spheres and cylinders are represented exactly; any other shape, or a shape with cut-outs,
is refused with a :class:`SimulationError` naming the object, never approximated.  Static objects are
not here: the simulator builds them from the voxel grid.
"""

from __future__ import annotations

import numpy as np
from pliant.api import SimulationError


def _collision_shape(pb, obj, index: int, source: str) -> int:
    import pybullet

    part = obj.part
    where = f"objects[{index}]"
    if part.cutouts:
        raise SimulationError(f"movable object '{obj.name}' has cut-outs, which a pybullet rigid body cannot "
                              "represent", source=source, field=f"{where}.cutouts")
    s = part.shape
    if s.kind == "box":
        return pb.createCollisionShape(pybullet.GEOM_BOX, halfExtents=(s.size / 2).tolist())
    if s.kind == "sphere":
        return pb.createCollisionShape(pybullet.GEOM_SPHERE, radius=s.radius)
    if s.kind == "cylinder":
        return pb.createCollisionShape(pybullet.GEOM_CYLINDER, radius=s.radius, height=s.length)
    raise SimulationError(f"movable object '{obj.name}' is a {s.kind}; pybullet moves boxes, spheres and "
                          "cylinders only", source=source, field=f"{where}.shape", value=s.kind)


class MovableObjects:
    """The scene's movable objects in a pybullet client: built, reset to their scene poses, read back.

    ``friction`` is the default Coulomb coefficient (an object's own ``friction`` wins); ``damping``
    (1/s) is pybullet's linear and angular damping of the objects (a stand-in for table friction when
    gravity is off).
    """

    def __init__(self, pb, scene, friction: float, damping: float) -> None:
        self.pb = pb
        self.planar = bool(scene.planar)
        self.objects = [obj for obj in scene.objects if obj.movable]
        indices = [k for k, obj in enumerate(scene.objects) if obj.movable]
        self.shapes = [_collision_shape(pb, obj, k, scene.source) for obj, k in zip(self.objects, indices)]
        self.friction = friction
        self.damping = damping
        self.bodies: list[int] = []

    @property
    def names(self) -> list[str]:
        return [obj.name for obj in self.objects]

    def reset(self) -> None:
        """Rebuild every object at its scene pose, at rest (no solver state survives a reset)."""
        for body in self.bodies:
            self.pb.removeBody(body)
        self.bodies = []
        for obj, shape in zip(self.objects, self.shapes):
            body = self.pb.createMultiBody(obj.mass, shape, basePosition=obj.part.pose.position.tolist(),
                                           baseOrientation=obj.part.pose.orientation.tolist())
            friction = obj.friction if obj.friction is not None else self.friction
            self.pb.changeDynamics(body, -1, lateralFriction=friction, linearDamping=self.damping,
                                   angularDamping=self.damping)
            self.bodies.append(body)

    def poses(self) -> dict[str, np.ndarray]:
        """Each object's pose: ``(x, y, theta)`` (m, rad) in a planar scene, else ``(7,)`` position (m) and
        quaternion ``(qx, qy, qz, qw)`` with ``qw >= 0``."""
        out = {}
        for obj, body in zip(self.objects, self.bodies):
            position, quaternion = self.pb.getBasePositionAndOrientation(body)
            if self.planar:
                yaw = self.pb.getEulerFromQuaternion(quaternion)[2]
                out[obj.name] = np.array([position[0], position[1], yaw], dtype=np.float64)
                continue
            q = np.array([*position, *quaternion], dtype=np.float64)
            out[obj.name] = q if q[6] >= 0 else np.concatenate([q[:3], -q[3:]])
        return out
