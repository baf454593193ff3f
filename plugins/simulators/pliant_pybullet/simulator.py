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
from pliant.actuation import angular_mask, limit_velocity
from pliant.errors import DimensionError, SimulationError
from pliant.interfaces import SimulationBatch, Simulator, check_batch
from pliant.noise import NOISE_MODELS, ActuationNoise
from pliant.options import option
from pliant.voxelgrid import VoxelGrid


@dataclass(frozen=True)
class PybulletOptions:
    """Options of :class:`PybulletSimulator`."""

    frequency: float = option(10.0, "control frequency (Hz)", minimum=1e-6)
    physics_rate: float = option(240.0, "physics steps per second (Hz)", minimum=1.0)
    kp: float = option(0.5, "proportional gain: fraction of the error commanded per control step", minimum=0.0)
    velocity_limit: float = option(1.0, "translation speed limit (m/s)", minimum=1e-9)
    angular_velocity_limit: float = option(0.125, "rotation speed limit (rad/s)", minimum=1e-9)
    noise: str = option("none", "actuation noise model (pliant.noise)", choices=NOISE_MODELS)
    noise_linear: float = option(0.0, "noise parameter of translation (bound m/s, or factor)", minimum=0.0)
    noise_angular: float = option(0.0, "noise parameter of rotation (rad/s, or factor)", minimum=0.0)
    density: float = option(100.0, "robot mass per volume (kg/m^3)", minimum=1e-9)
    friction: float = option(0.5, "lateral friction coefficient", minimum=0.0)
    max_force: float = option(200.0, "largest force the controller's constraint applies (N)", minimum=0.0)
    gravity: float = option(0.0, "gravity along -z (m/s^2)", minimum=0.0)
    reach_tolerance: float | None = option(None, "distance counting as reached; default the scene's goal "
                                           "tolerance, else one voxel")
    stuck_fraction: float = option(0.05, "stuck when a control step moves less than this fraction of what it "
                                   "commanded", minimum=0.0, maximum=1.0)


def _yaw_quaternion(theta: float) -> list[float]:
    return [0.0, 0.0, math.sin(theta / 2), math.cos(theta / 2)]


class PybulletSimulator(Simulator):
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
        self.space = self.robot.space
        self.kind = scene.robot.space
        o = self.options
        self.angular = angular_mask(self.space)
        limits = np.where(self.angular, o.angular_velocity_limit, o.velocity_limit)
        self.noise = ActuationNoise(o.noise, np.where(self.angular, o.noise_angular, o.noise_linear), limits)
        self.dt = 1.0 / o.frequency
        self.substeps = max(1, round(o.physics_rate / o.frequency))
        self.reach = o.reach_tolerance if o.reach_tolerance is not None else (
            scene.goal_tolerance if scene.goal_tolerance > 0 else scene.resolution)
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
        v = np.asarray(velocity, dtype=np.float64).reshape(-1)
        if v.shape != (self.space.tangent_dim,) or not np.all(np.isfinite(v)):
            raise DimensionError(f"velocity must be ({self.space.tangent_dim},) and finite", field="velocity",
                                 value=np.asarray(velocity).tolist())
        v = limit_velocity(v[None], self.angular, self.options.velocity_limit, self.options.angular_velocity_limit)[0]
        v = v + self.noise.sample(rng, v[None])[0]
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

    def simulate(self, starts, targets, rng, duration, record=False):
        starts, _ = check_batch(starts, self.space, "starts")
        targets = np.broadcast_to(check_batch(targets, self.space, "targets")[0], starts.shape)
        if not (math.isfinite(duration) and duration > 0):
            raise DimensionError("duration must be a positive number of seconds", field="duration", value=duration)
        steps = max(1, round(duration * self.options.frequency))
        n = len(starts)
        final = np.empty_like(starts)
        touched = np.zeros(n, dtype=bool)
        stuck = np.zeros(n, dtype=bool)
        trajectories = np.empty((n, steps + 1, self.space.dim)) if record else None
        for a in range(n):
            self.reset(starts[a])
            q = self.configuration()
            if record:
                trajectories[a, 0] = q
            for k in range(steps):
                command = self.options.kp * self.space.difference(targets[a], q) / self.dt
                command = limit_velocity(command[None], self.angular, self.options.velocity_limit,
                                         self.options.angular_velocity_limit)[0]
                before = q
                q = self.step(command, self.dt, rng)
                touched[a] |= self._contact
                stuck[a] = float(self.space.distance(q, before)) < (
                    self.options.stuck_fraction * float(np.linalg.norm(command * self.dt)))
                if record:
                    trajectories[a, k + 1] = q
            final[a] = q
        reached = self.space.distance(final, targets) <= self.reach
        return SimulationBatch(final=final, in_contact=touched, stuck=stuck & ~reached, reached=reached,
                               trajectories=trajectories, steps=n * steps * self.substeps)

    def __del__(self):
        try:
            self.pb.disconnect()
        except Exception:  # the client may already be gone at interpreter exit
            pass
