"""Movable scene objects (``mass`` set in the scene) as dynamic pybullet bodies.

Boxes, spheres and cylinders are represented exactly; any other shape, or a shape with cut-outs, is refused with
a :class:`SimulationError` naming the object, never approximated. Static objects are not here: the simulator
builds them from the voxel grid.

Their physics is the scene's (:mod:`pliant.physics`): mass, inertia (Bullet's own from the shape when the scene
gives none, the same uniform-density moments as :func:`pliant.physics.inertia_diagonal`), friction, rolling
friction, restitution and damping. The scene's damping (the fraction of velocity lost per second) is applied
before every physics step as ``v *= (1 - d)^h``, not as Bullet's own damping: a pybullet multibody's damping
force is ``d m v (1 + |v|)``, which loses 5 % more distance than the scene's definition at 0.2 m/s. In a planar
scene seen from above (no gravity) the support is modelled as in pymunk: before every physics step each object
gets the friction force and torque that would stop it within the step, capped at ``mu m g`` and ``mu m g
r_mean`` (:func:`pliant.physics.support_limits`), and is kept in the plane (its velocity along z and its tilting
rates are zeroed), as pymunk's bodies are.
"""

from __future__ import annotations

import numpy as np
from pliant.api import SimulationError, footprint_mean_radius, support_limits


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

    ``friction`` is the default Coulomb coefficient (an object's own ``friction`` wins); ``damping`` is Bullet's own
    linear and angular damping of objects whose scene states none (the deprecated option ``object_damping``, else 0);
    ``support_friction`` the planar support's coefficient (``None``: no support, e.g. a 3-D scene).
    """

    def __init__(self, pb, scene, friction: float, damping: float, support_friction: float | None = None) -> None:
        self.pb = pb
        self.planar = bool(scene.planar)
        self.objects = [obj for obj in scene.objects if obj.movable]
        indices = [k for k, obj in enumerate(scene.objects) if obj.movable]
        self.shapes = [_collision_shape(pb, obj, k, scene.source) for obj, k in zip(self.objects, indices)]
        self.friction = friction
        self.damping = damping
        self.physics = [scene.physics.body(obj.name) for obj in self.objects]
        self.support = None
        if self.planar and support_friction:
            self.support = [support_limits(support_friction, obj.mass, footprint_mean_radius(obj.part.shape))
                            for obj in self.objects]
        self.bodies: list[int] = []
        self._izz_cache: dict[int, float] = {}

    @property
    def names(self) -> list[str]:
        return [obj.name for obj in self.objects]

    def reset(self) -> None:
        """Rebuild every object at its scene pose, at rest (no solver state survives a reset)."""
        for body in self.bodies:
            self.pb.removeBody(body)
        self.bodies = []
        for obj, shape, physics in zip(self.objects, self.shapes, self.physics):
            body = self.pb.createMultiBody(obj.mass, shape, basePosition=obj.part.pose.position.tolist(),
                                           baseOrientation=obj.part.pose.orientation.tolist())
            friction = obj.friction if obj.friction is not None else self.friction
            linear = self.damping if physics.linear_damping is None else 0.0       # the scene's: in before_step
            angular = self.damping if physics.angular_damping is None else 0.0
            extra = {}
            if physics.inertia is not None:
                extra["localInertiaDiagonal"] = physics.inertia.tolist()
            if physics.restitution is not None:
                extra["restitution"] = physics.restitution
            if physics.rolling_friction is not None:
                extra["rollingFriction"] = physics.rolling_friction
            self.pb.changeDynamics(body, -1, lateralFriction=friction, linearDamping=linear, angularDamping=angular,
                                   **extra)
            self.bodies.append(body)

    def before_step(self, h: float) -> None:
        """Before a physics step of ``h`` s: apply the scene's damping; keep the planar objects in the plane and
        apply the support's friction (the force and torque that stop each object within the step, capped at its
        limits)."""
        for k, body in enumerate(self.bodies):
            physics = self.physics[k]
            if not (self.planar or physics.linear_damping or physics.angular_damping):
                continue
            v, w = (np.array(x, dtype=np.float64) for x in self.pb.getBaseVelocity(body))
            v *= (1.0 - (physics.linear_damping or 0.0)) ** h
            w *= (1.0 - (physics.angular_damping or 0.0)) ** h
            if self.planar:
                v[2] = w[0] = w[1] = 0.0
            self.pb.resetBaseVelocity(body, v.tolist(), w.tolist())
            (vx, vy, _), wz = v, w[2]
            if not self.planar or self.support is None:
                continue
            force_cap, torque_cap = self.support[k]
            mass = self.objects[k].mass
            speed = float(np.hypot(vx, vy))
            if speed > 0.0:
                f = min(force_cap, mass * speed / h) / speed
                position, _ = self.pb.getBasePositionAndOrientation(body)
                self.pb.applyExternalForce(body, -1, [-f * vx, -f * vy, 0.0], position, self.pb.WORLD_FRAME)
            if wz != 0.0:
                izz = self._izz(k)
                tau = min(torque_cap, izz * abs(wz) / h)
                self.pb.applyExternalTorque(body, -1, [0.0, 0.0, -np.copysign(tau, wz)], self.pb.WORLD_FRAME)

    def _izz(self, k: int) -> float:
        """Object ``k``'s moment of inertia about its (vertical) z axis (kg m^2), as Bullet holds it."""
        if k not in self._izz_cache:
            self._izz_cache[k] = float(self.pb.getDynamicsInfo(self.bodies[k], -1)[2][2])
        return self._izz_cache[k]

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
