"""The simulator ``pybullet``: 3-D rigid-body dynamics of a robot among the scene's objects (headless).

Static geometry is the scene's voxel grid merged into exact boxes (:meth:`VoxelGrid.boxes`), so
cut-outs and meshes are represented at the scene's resolution.  The robot is either

- a free-flying rigid body (R^3 / SE(2) / SE(3)) built from the scene's robot parts and pulled toward
  the commanded pose by a force-capped constraint (:mod:`pliant_pybullet.free_flyer`), or
- a URDF robot (PR2, Baxter, iiwa or a file) loaded from the robot model's description, its planned
  joints under compliant position control with torque limits (:mod:`pliant_pybullet.articulated`).

Either way the robot yields against obstacles instead of passing through them; actuation noise comes
from :mod:`pliant.execution.noise` and ``simulate`` uses the kinematic simulator's P law and velocity limits
(:mod:`pliant.execution.stepping`), so a pipeline can swap ``kinematic`` for ``pybullet`` by name (thesis 5.4
executes in a dynamic simulator; 3.3.4 validates the deformation cost in Bullet).

The physical properties are the scene's (:mod:`pliant.physics`): the objects' masses, inertias, friction, rolling
friction, restitution and damping, the static objects' friction, the robot's mass and friction, and a planar scene's
support friction (:mod:`pliant_pybullet.objects`); the options hold the numerics, the controllers' caps and gains.
What Bullet cannot represent (a static friction apart from the dynamic one) is listed once when the simulator is
built.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import FREE_VOXEL as FREE
from pliant.api import (
    SimulationError,
    SteppedOptions,
    SteppedSimulator,
    VoxelGrid,
    check_batch,
    option,
    report_ignored,
)

#: the scene physics Bullet represents (pliant.physics.ScenePhysics.stated kinds); the rest is reported once
SUPPORTED_PHYSICS = ("objects.friction", "objects.rolling_friction", "objects.mass", "objects.restitution",
                     "objects.linear_damping", "objects.angular_damping", "objects.inertia", "robot.friction",
                     "robot.mass", "robot.restitution", "support.friction")


@dataclass(frozen=True)
class PybulletOptions(SteppedOptions):
    """Options of :class:`PybulletSimulator` (the shared ones: :class:`pliant.execution.stepping.SteppedOptions`)."""

    density: float = option(100.0, "free-flying robot's mass per volume (kg/m^3) when the scene's [robot] gives "
                            "no mass", minimum=1e-9)
    max_force: float = option(200.0, "largest force the free-flying robot's pulling constraint applies (N)",
                              minimum=0.0)
    max_torque: float | None = option(None, "free-flying robot: largest torque turning it toward the commanded "
                                      "orientation (N m); default: max_force read in N m "
                                      "(pliant_pybullet.free_flyer)",
                                      minimum=0.0)
    gravity: float = option(0.0, "gravity along -z (m/s^2)", minimum=0.0)
    effort_scale: float = option(1.0, "URDF robots: joint torque caps = this x the URDF's effort limits",
                                 minimum=1e-9)
    position_gain: float = option(0.3, "URDF robots: pybullet position-motor gain (the P of the PD law)",
                                  minimum=0.0, maximum=1.0)
    velocity_gain: float = option(1.0, "URDF robots: pybullet position-motor velocity gain (the D of the PD law)",
                                  minimum=0.0, maximum=1.0)
    self_collision: bool = option(False, "URDF robots: links collide with each other (parents excluded)")
    object_damping: float | None = option(None, "deprecated: the scene objects' linear_damping and angular_damping "
                                          "(this option, when given, applies to objects whose scene states none, "
                                          "with a warning)", minimum=0.0,
                                          deprecated="set linear_damping and angular_damping on the scene's "
                                                     "movable objects")


class PybulletSimulator(SteppedSimulator):
    """Rigid-body dynamics in pybullet (DIRECT mode, its own client) of a free-flying or URDF robot."""

    Options = PybulletOptions
    example_scene = "se3-peg-in-hole"

    def bind(self, context) -> None:
        super().bind(context)
        import pybullet
        from pybullet_utils.bullet_client import BulletClient

        scene = self.require("scene")
        self.robot = self.require("robot")
        o = self.options
        self.setup_actuation(scene)
        self.pb = BulletClient(connection_mode=pybullet.DIRECT)
        self.pb.setTimeStep(self.dt / self.substeps)
        self.pb.setGravity(0, 0, -o.gravity)
        physics = scene.physics
        report_ignored(physics, "pybullet", SUPPORTED_PHYSICS if scene.robot.kind == "rigid" else
                       [kind for kind in SUPPORTED_PHYSICS if kind not in ("robot.mass", "robot.restitution")],
                       "Bullet has one friction coefficient per surface")
        for mu, (lo, hi) in _static_boxes(scene, o.friction):
            shape = self.pb.createCollisionShape(pybullet.GEOM_BOX, halfExtents=((hi - lo) / 2).tolist())
            wall = self.pb.createMultiBody(0, shape, basePosition=((hi + lo) / 2).tolist())
            self.pb.changeDynamics(wall, -1, lateralFriction=mu)
        self.robot_friction = o.friction if physics.robot.friction is None else physics.robot.friction
        if scene.robot.kind == "rigid":
            from pliant_pybullet.free_flyer import FreeFlyer

            self.body = FreeFlyer(self.pb, scene, self.space, o.density, o.max_force, self.robot_friction,
                                  max_torque=o.max_torque, time_step=self.dt / self.substeps,
                                  mass=physics.robot.mass, restitution=physics.robot.restitution)
        else:
            self.body = self._articulated(scene)
        from pliant_pybullet.objects import MovableObjects

        damping = 0.0 if o.object_damping is None else o.object_damping     # deprecated (its warning: pliant.options)
        self.objects = MovableObjects(self.pb, scene, o.friction, damping,
                                      physics.support_friction if scene.planar else None)
        self._contact = False
        # starts are measured against every object's voxels: the static walls are built from them, and every reset
        # puts the movable objects back at their scene poses; no walls close the bounds here
        self.setup_start_check(VoxelGrid.from_scene(scene), outside_solid=False)
        self.reset(scene.start)

    def _articulated(self, scene):
        from pliant_pybullet.articulated import ArticulatedRobot

        description = self.robot.urdf_description()
        if description is None:
            raise SimulationError("the robot model offers no URDF description, so pybullet cannot load it; use a "
                                  "robot that implements RobotModel.urdf_description (e.g. 'pinocchio')",
                                  source=scene.source, field="robot", value=type(self.robot).__name__)
        o = self.options
        return ArticulatedRobot(self.pb, description, self.space.lower, self.space.upper, effort_scale=o.effort_scale,
                                position_gain=o.position_gain, velocity_gain=o.velocity_gain,
                                friction=self.robot_friction,
                                self_collision=o.self_collision, source=scene.source)

    def configuration(self):
        return self.body.configuration()

    def reset(self, q):
        """Place the robot at ``q`` ``(d,)`` at rest, and every movable object back at its scene pose.  The core
        refuses, before this runs, a start deeper than ``start_tolerance`` voxels inside an object
        (:meth:`start_penetration`)."""
        q = check_batch(q, self.space, "configuration")[0][0]
        self.objects.reset()
        self.body.reset(q)
        self._contact = False

    def start_penetration(self, configurations):
        """Depth (m) of the robot's deepest surface point inside an object (static or movable, at its scene pose) at
        each configuration ``(n, d)``; with ``self_collision``, also the deepest contact between the robot's own
        links (the robot model's :meth:`~pliant.interfaces.RobotModel.self_contacts`)."""
        depth = super().start_penetration(configurations)
        if self.options.self_collision:
            for k, q in enumerate(np.atleast_2d(configurations)):
                contacts = self.robot.self_contacts(q)
                if contacts is not None and len(contacts):
                    depth[k] = max(depth[k], float(np.max(contacts.depth)))
        return depth

    def contact_points(self) -> np.ndarray:
        """Contacts of the robot after the last physics step, ``(k, 7)``: point on the robot (m), unit normal
        from the other body toward the robot, normal force (N)."""
        rows = [[*c[5], *c[7], c[9]] for c in self.pb.getContactPoints(bodyA=self.body.body)
                if c[2] != self.body.body or self.options.self_collision]
        return np.array(rows, dtype=np.float64).reshape(-1, 7)

    def object_poses(self) -> dict:
        """Poses of the scene's movable objects by name: ``(x, y, theta)`` in planar scenes, else ``(7,)``."""
        return self.objects.poses()

    def in_contact(self):
        return self._contact

    def step(self, velocity, dt, rng):
        v = self.actuate(velocity, rng)
        q = self.configuration()
        n = self.substeps
        touched = False
        for k in range(1, n + 1):
            # the target sweeps from the current configuration to the commanded one over the step
            self.body.command(q, v * dt, k / n, dt)
            self.objects.before_step(dt / n)
            self.pb.stepSimulation()
            touched = touched or self.body.touching()
        self._contact = touched
        return self.configuration()

    def __del__(self):
        try:
            self.pb.disconnect()
        except Exception:  # the client may already be gone at interpreter exit
            pass


def _static_boxes(scene, default_friction: float) -> list[tuple[float, tuple[np.ndarray, np.ndarray]]]:
    """The static objects' voxels merged into boxes, as ``(friction, (lower, upper))``: objects with the same
    friction (their own, else ``default_friction``) are merged together, so a scene without per-object friction gives
    the boxes of its whole voxel layer."""
    grid = VoxelGrid.from_scene(scene, static_only=True)
    friction = np.array([default_friction if o.friction is None else o.friction for o in scene.objects])
    static = [not o.movable for o in scene.objects]
    values = sorted(set(friction[static].tolist())) if len(friction) else []
    if len(values) <= 1:
        mu = values[0] if values else float(default_friction)
        return [(mu, box) for box in grid.boxes()]
    out = []
    for mu in values:
        mask = np.isin(grid.object_id, np.nonzero(friction == mu)[0])
        sub = VoxelGrid(grid.lower, grid.resolution, grid.deformability, grid.sensitivity,
                        np.where(mask, grid.object_id, FREE).astype(np.int32), grid.object_names)
        out.extend((mu, box) for box in sub.boxes())
    return out
