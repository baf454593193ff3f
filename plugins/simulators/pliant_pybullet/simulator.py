"""The simulator ``pybullet``: 3-D rigid-body dynamics of a free-flying robot among the scene's objects.

Static geometry is the scene's voxel grid merged into exact boxes (:meth:`VoxelGrid.boxes`), so
cut-outs and meshes are represented at the scene's resolution.  The robot is one rigid multibody
built from its parts (boxes, spheres, cylinders; mass from ``density``).  Control is compliant: a
fixed constraint pulls the robot toward the commanded pose with a capped force (``max_force``), so it
yields against obstacles instead of passing through them; actuation noise comes from
:mod:`pliant.noise` and ``simulate`` uses the kinematic simulator's P law and velocity limits
(:mod:`pliant.actuation`).  Gravity is off by default (the thesis's robots hold their pose).

Not yet: URDF robots and soft bodies (thesis 3.3.4) — the scene is refused with a SimulationError.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pliant.errors import SimulationError
from pliant.interfaces import check_batch
from pliant.options import option
from pliant.stepping import SteppedOptions, SteppedSimulator
from pliant.voxelgrid import VoxelGrid


@dataclass(frozen=True)
class PybulletOptions(SteppedOptions):
    """Options of :class:`PybulletSimulator` (the shared ones: :class:`pliant.stepping.SteppedOptions`)."""

    density: float = option(100.0, "robot mass per volume (kg/m^3)", minimum=1e-9)
    max_force: float = option(200.0, "largest force the controller's constraint applies (N)", minimum=0.0)
    gravity: float = option(0.0, "gravity along -z (m/s^2)", minimum=0.0)


def _yaw_quaternion(theta: float) -> list[float]:
    return [0.0, 0.0, math.sin(theta / 2), math.cos(theta / 2)]


class PybulletSimulator(SteppedSimulator):
    """Rigid-body dynamics of a free-flying R^3 / SE(2) / SE(3) robot in pybullet (DIRECT mode)."""

    Options = PybulletOptions
    example_scene = "se3-peg-in-hole"

    def bind(self, context) -> None:
        super().bind(context)
        import pybullet
        from pybullet_utils.bullet_client import BulletClient

        scene = self.require("scene")
        if scene.robot.kind != "rigid":
            raise SimulationError("the pybullet backend simulates rigid free-flying robots only for now",
                                  source=scene.source, field="robot.kind", value=scene.robot.kind)
        self.robot = self.require("robot")
        self.kind = scene.robot.space
        o = self.options
        self.setup_actuation(scene)
        self.pb = BulletClient(connection_mode=pybullet.DIRECT)
        self.pb.setTimeStep(self.dt / self.substeps)
        self.pb.setGravity(0, 0, -o.gravity)
        for lo, hi in VoxelGrid.from_scene(scene).boxes():
            shape = self.pb.createCollisionShape(pybullet.GEOM_BOX, halfExtents=((hi - lo) / 2).tolist())
            wall = self.pb.createMultiBody(0, shape, basePosition=((hi + lo) / 2).tolist())
            self.pb.changeDynamics(wall, -1, lateralFriction=o.friction)
        self._shape, self._mass = self._robot_shape(scene, pybullet)
        self._body = self._hold = None
        self._contact = False
        self.reset(scene.start)

    def _robot_shape(self, scene, pybullet):
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
        shape = self.pb.createCollisionShapeArray(
            shapeTypes=kinds, halfExtents=[d.get("halfExtents", [0, 0, 0]) for d in sizes],
            radii=[d.get("radius", 0.0) for d in sizes], lengths=[d.get("length", 0.0) for d in sizes],
            collisionFramePositions=positions, collisionFrameOrientations=orientations)
        return shape, self.options.density * volume

    # --- poses ---------------------------------------------------------------------------------

    def _pose(self, q):
        if self.kind == "se3":
            return q[:3].tolist(), q[3:7].tolist()
        if self.kind == "se2":
            return [q[0], q[1], 0.0], _yaw_quaternion(q[2])
        return q[:3].tolist(), [0.0, 0.0, 0.0, 1.0]

    def configuration(self):
        pos, quat = self.pb.getBasePositionAndOrientation(self._body)
        if self.kind == "se3":
            q = np.array([*pos, *quat])
            return q if q[6] >= 0 else np.concatenate([q[:3], -q[3:]])
        if self.kind == "se2":
            yaw = 2 * math.atan2(quat[2], quat[3])
            return np.array([pos[0], pos[1], (yaw + math.pi) % (2 * math.pi) - math.pi])
        return np.array(pos)

    def reset(self, q):
        q = check_batch(q, self.space, "configuration")[0][0]
        if self._body is not None:
            self.pb.removeConstraint(self._hold)
            self.pb.removeBody(self._body)
        position, orientation = self._pose(q)
        self._body = self.pb.createMultiBody(self._mass, self._shape, basePosition=position,
                                             baseOrientation=orientation)
        self.pb.changeDynamics(self._body, -1, lateralFriction=self.options.friction, linearDamping=0.0,
                               angularDamping=0.0)
        self._hold = self.pb.createConstraint(self._body, -1, -1, -1, self.pb.JOINT_FIXED, [0, 0, 0], [0, 0, 0],
                                              position, childFrameOrientation=orientation)
        self.pb.changeConstraint(self._hold, position, orientation, maxForce=self.options.max_force)
        self._contact = False

    def in_contact(self):
        return self._contact

    def step(self, velocity, dt, rng):
        v = self.actuate(velocity, rng)
        q = self.configuration()
        n = self.substeps
        touched = False
        for k in range(1, n + 1):
            # the constraint's target sweeps from the current pose to the commanded one over the step
            position, orientation = self._pose(self.space.retract(q, v * dt * k / n))
            self.pb.changeConstraint(self._hold, position, orientation, maxForce=self.options.max_force)
            self.pb.stepSimulation()
            touched = touched or bool(self.pb.getContactPoints(bodyA=self._body))
        self._contact = touched
        return self.configuration()

    def __del__(self):
        try:
            self.pb.disconnect()
        except Exception:  # the client may already be gone at interpreter exit
            pass
