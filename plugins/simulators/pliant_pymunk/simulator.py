"""The simulator ``pymunk``: 2-D rigid-body dynamics for planar scenes (thesis 5.4's dynamic execution).

The robot is a dynamic body with mass and friction, driven compliantly: a kinematic *control body*
moves at the commanded velocity (plus actuation noise from :mod:`pliant.noise`) and pulls the robot
through a pivot joint and a gear joint whose forces and torques are capped (``max_force``,
``max_torque``), so the robot complies against obstacles instead of passing through them.  Static
geometry is the scene's voxel layer as boxes (:mod:`.world`).  ``simulate`` uses the same P control
law and velocity limits as the kinematic simulator, so the two agree in free space.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pliant.actuation import angular_mask, limit_velocity
from pliant.errors import DimensionError
from pliant.interfaces import SimulationBatch, Simulator, check_batch
from pliant.noise import NOISE_MODELS, ActuationNoise
from pliant.options import option
from pliant.voxelgrid import VoxelGrid

from pliant_pymunk.world import check_planar, robot_shapes, static_rectangles


@dataclass(frozen=True)
class PymunkOptions:
    """Options of :class:`PymunkSimulator`."""

    frequency: float = option(10.0, "control frequency (Hz)", minimum=1e-6)
    physics_rate: float = option(240.0, "physics steps per second (Hz)", minimum=1.0)
    kp: float = option(0.5, "proportional gain: fraction of the error commanded per control step", minimum=0.0)
    velocity_limit: float = option(1.0, "translation speed limit (m/s)", minimum=1e-9)
    angular_velocity_limit: float = option(0.125, "rotation speed limit (rad/s)", minimum=1e-9)
    noise: str = option("none", "actuation noise model (pliant.noise)", choices=NOISE_MODELS)
    noise_linear: float = option(0.0, "noise parameter of translation (bound m/s, or factor)", minimum=0.0)
    noise_angular: float = option(0.0, "noise parameter of rotation (rad/s, or factor)", minimum=0.0)
    density: float = option(100.0, "robot mass per area (kg/m^2)", minimum=1e-9)
    friction: float = option(0.5, "Coulomb friction coefficient of robot and obstacles", minimum=0.0)
    max_force: float = option(2000.0, "largest force the controller applies (N)", minimum=0.0)
    max_torque: float = option(2000.0, "largest torque the controller applies (N m)", minimum=0.0)
    reach_tolerance: float | None = option(None, "distance counting as reached; default the scene's goal "
                                           "tolerance, else one voxel")
    stuck_fraction: float = option(0.05, "stuck when a control step moves less than this fraction of what it "
                                   "commanded", minimum=0.0, maximum=1.0)


class PymunkSimulator(Simulator):
    """2-D dynamics with friction and compliant, force-limited control of an SE(2) robot."""

    Options = PymunkOptions
    example_scene = "se2-maze"

    def bind(self, context) -> None:
        super().bind(context)
        import pymunk

        self.pymunk = pymunk
        scene = self.require("scene")
        check_planar(scene)
        self.robot = self.require("robot")
        self.space = self.robot.space
        o = self.options
        self.angular = angular_mask(self.space)
        limits = np.where(self.angular, o.angular_velocity_limit, o.velocity_limit)
        self.noise = ActuationNoise(o.noise, np.where(self.angular, o.noise_angular, o.noise_linear), limits)
        self.dt = 1.0 / o.frequency
        self.substeps = max(1, round(o.physics_rate / o.frequency))
        self.reach = o.reach_tolerance if o.reach_tolerance is not None else (
            scene.goal_tolerance if scene.goal_tolerance > 0 else scene.resolution)
        self.world = pymunk.Space()
        self.world.gravity = (0.0, 0.0)
        for x0, y0, x1, y1 in static_rectangles(VoxelGrid.from_scene(scene)):
            wall = pymunk.Poly(self.world.static_body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
            wall.friction = o.friction
            self.world.add(wall)
        self._robot_objects = ()
        self._contact = False
        self.reset(scene.start)

    def _add_robot(self, q) -> None:
        """A fresh robot body, control body and joints at ``q`` (no solver state carried over)."""
        pymunk, o = self.pymunk, self.options
        if self._robot_objects:
            self.world.remove(*self._robot_objects)
        self.body = pymunk.Body()
        self.body.position = (float(q[0]), float(q[1]))
        self.body.angle = float(q[2])
        shapes = robot_shapes(self.context.scene, pymunk, self.body, o.friction)
        for shape in shapes:
            shape.density = o.density
        self.control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.control.position = self.body.position
        self.control.angle = self.body.angle
        pivot = pymunk.PivotJoint(self.control, self.body, (0, 0), (0, 0))
        pivot.max_bias = 0.0            # pull with the velocity error only: position drift is the noise's
        pivot.max_force = o.max_force
        gear = pymunk.GearJoint(self.control, self.body, 0.0, 1.0)
        gear.max_bias = 0.0
        gear.max_force = o.max_torque
        self._robot_objects = (self.body, *shapes, self.control, pivot, gear)
        self.world.add(*self._robot_objects)

    def reset(self, q):
        q = check_batch(q, self.space, "configuration")[0][0]
        self._add_robot(q)
        self._contact = False

    def configuration(self):
        return np.array([self.body.position.x, self.body.position.y,
                         (self.body.angle + math.pi) % (2 * math.pi) - math.pi])

    def in_contact(self):
        return self._contact

    def step(self, velocity, dt, rng):
        v = np.asarray(velocity, dtype=np.float64).reshape(-1)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise DimensionError("velocity must be (3,) and finite", field="velocity",
                                 value=np.asarray(velocity).tolist())
        v = limit_velocity(v[None], self.angular, self.options.velocity_limit,
                           self.options.angular_velocity_limit)[0]
        v = v + self.noise.sample(rng, v[None])[0]
        # the control body leads the robot: it starts each step where the robot is
        self.control.position = self.body.position
        self.control.angle = self.body.angle
        self.control.velocity = (float(v[0]), float(v[1]))
        self.control.angular_velocity = float(v[2])
        touched = False
        h = dt / self.substeps
        for _ in range(self.substeps):
            self.world.step(h)
            touched = touched or self._touching()
        self._contact = touched
        return self.configuration()

    def _touching(self) -> bool:
        hits = []
        self.body.each_arbiter(lambda arbiter: hits.append(arbiter))
        return bool(hits)

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
        trajectories = np.empty((n, steps + 1, 3)) if record else None
        for a in range(n):
            self.reset(starts[a])
            q = starts[a].copy()
            if record:
                trajectories[a, 0] = q
            for k in range(steps):
                command = self.options.kp * self.space.difference(targets[a], q) / self.dt
                command = limit_velocity(command[None], self.angular, self.options.velocity_limit,
                                         self.options.angular_velocity_limit)[0]
                before = q
                q = self.step(command, self.dt, rng)
                touched[a] |= self._contact
                moved = float(self.space.distance(q, before))
                stuck[a] = moved < self.options.stuck_fraction * float(np.linalg.norm(command * self.dt))
                if record:
                    trajectories[a, k + 1] = q
            final[a] = q
        reached = self.space.distance(final, targets) <= self.reach
        return SimulationBatch(final=final, in_contact=touched, stuck=stuck & ~reached, reached=reached,
                               trajectories=trajectories, steps=n * steps * self.substeps)
