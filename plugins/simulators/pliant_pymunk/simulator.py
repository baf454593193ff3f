"""The simulator ``pymunk``: 2-D rigid-body dynamics for planar scenes (thesis 5.4's dynamic execution).

The robot is a dynamic body with mass and friction, driven compliantly by a force-limited velocity
servo: before every physics substep, the force at the robot frame's origin and the torque that would bring
the frame to the commanded velocity (plus actuation noise from :mod:`pliant.noise`) within that substep are
computed from the body's mass and inertia, the force capped in norm at ``max_force`` and the torque at
``max_torque``, and applied; contacts and friction then act on the body, so the robot complies against
obstacles instead of passing through them.  (Not pymunk's pivot and gear joints to a kinematic control
body with capped forces: their solver accumulates impulses against a persistent contact and spends the
whole force limit pushing into it, so a robot pressed on a surface could not slide along it or turn,
not even frictionless; the servo's force follows the velocity error.)  Static
geometry is the voxel layer of the static objects as boxes (:mod:`.world`); movable objects (a scene
``mass``) are dynamic bodies held back by table friction (:mod:`.objects`), put back at their scene
pose at rest by every ``reset``.  ``simulate`` uses the same P control law and velocity limits as the
kinematic simulator, so the two agree in free space.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pliant.interfaces import check_batch
from pliant.options import option
from pliant.stepping import SteppedOptions, SteppedSimulator

from pliant_pymunk.objects import add_object, planar_objects
from pliant_pymunk.world import check_planar, robot_shapes, static_walls


@dataclass(frozen=True)
class PymunkOptions(SteppedOptions):
    """Options of :class:`PymunkSimulator` (the shared ones: :class:`pliant.stepping.SteppedOptions`)."""

    density: float = option(100.0, "robot mass per area (kg/m^2)", minimum=1e-9)
    max_force: float = option(2000.0, "largest force the controller applies (N)", minimum=0.0)
    max_torque: float = option(2000.0, "largest torque the controller applies (N m)", minimum=0.0)
    table_friction: float = option(0.5, "Coulomb friction coefficient between movable objects and the table "
                                   "(force mu m g, torque mu m g r_mean); 0 lets them glide", minimum=0.0)


class PymunkSimulator(SteppedSimulator):
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
        o = self.options
        self.setup_actuation(scene)
        self.world = pymunk.Space()
        self.world.gravity = (0.0, 0.0)
        self.world.collision_slop = 0.01 * scene.resolution     # allowed overlap (m); pymunk's 0.1 is for pixels
        for mu, (x0, y0, x1, y1) in static_walls(scene, o.friction):
            wall = pymunk.Poly(self.world.static_body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
            wall.friction = mu
            self.world.add(wall)
        self.objects = planar_objects(scene)
        self._object_parts: list[tuple] = []
        self._robot_objects = ()
        self._contact = False
        self.reset(scene.start)

    def _add_robot(self, q) -> None:
        """A fresh robot body at ``q``, at rest (no solver state carried over)."""
        pymunk, o = self.pymunk, self.options
        if self._robot_objects:
            self.world.remove(*self._robot_objects)
        self.body = pymunk.Body()
        self.body.position = (float(q[0]), float(q[1]))
        self.body.angle = float(q[2])
        shapes = robot_shapes(self.context.scene, pymunk, self.body, o.friction)
        for shape in shapes:
            shape.density = o.density
        self._robot_objects = (self.body, *shapes)
        self._servo = (0.0, 0.0, 0.0)       # the commanded frame velocity (vx, vy, omega) of the current step
        self.servo_effort = (0.0, 0.0)      # |force| (N) and |torque| (N m) the servo applied in the last substep
        self.world.add(*self._robot_objects)            # (pymunk sets the mass properties from the shapes here)
        r2 = self.body.center_of_gravity.length_squared     # the origin's squared distance from the centre of mass
        inertia = self.body.moment + self.body.mass * r2    # about the origin
        self._servo_gain = (1.0 - math.sqrt(self.body.mass * r2 / inertia), inertia)

    def _add_objects(self) -> None:
        """Fresh bodies for the movable objects at their scene poses, at rest."""
        o = self.options
        for parts in self._object_parts:
            self.world.remove(*parts)
        self._object_parts = [add_object(self.world, self.pymunk, spec, o.friction, o.table_friction)
                              for spec in self.objects]

    def reset(self, q):
        q = check_batch(q, self.space, "configuration")[0][0]
        self._add_objects()
        self._add_robot(q)
        self._contact = False

    def object_poses(self) -> dict[str, np.ndarray]:
        """The movable objects' current poses ``(x, y, theta)`` (m, rad; theta in [-pi, pi)), by name."""
        return {spec.name: spec.pose(parts[0]) for spec, parts in zip(self.objects, self._object_parts)}

    def configuration(self):
        return np.array([self.body.position.x, self.body.position.y,
                         (self.body.angle + math.pi) % (2 * math.pi) - math.pi])

    def in_contact(self):
        return self._contact

    def step(self, velocity, dt, rng):
        v = self.actuate(velocity, rng)
        self._servo = (float(v[0]), float(v[1]), float(v[2]))
        touched = False
        h = dt / self.substeps
        for _ in range(self.substeps):
            self._apply_servo(h)
            self.world.step(h)
            touched = touched or self._touching()
        self._contact = touched
        return self.configuration()

    def _apply_servo(self, h: float) -> None:
        """Apply the capped force at the frame's origin and the capped torque that drive the frame toward the
        commanded velocity.

        The two are independent, as the kinematic simulator's effort limits are (force on the frame's
        translation, torque on its rotation): ``F = g m dv / h`` with ``dv`` the origin's velocity error,
        capped at ``|F| <= max_force``, and ``tau = g I_o dw / h`` (``I_o`` the moment of inertia about the
        origin), capped at ``max_torque``.  The gain ``g = 1 - c`` with ``c = sqrt(m r^2 / I_o)`` (``r`` the
        origin's distance from the centre of mass) is the largest for which the decoupled servo cannot
        overshoot the coupled body: the whole error in one substep for a body driven at its centre of mass.
        """
        body, o = self.body, self.options
        vx, vy, w = self._servo
        gain, inertia = self._servo_gain
        origin = body.local_to_world((0.0, 0.0))
        v0 = body.velocity_at_local_point((0.0, 0.0))
        fx = gain * body.mass * (vx - v0.x) / h
        fy = gain * body.mass * (vy - v0.y) / h
        norm = math.hypot(fx, fy)
        if norm > o.max_force:
            fx, fy = fx * o.max_force / norm, fy * o.max_force / norm
        tau = gain * inertia * (w - body.angular_velocity) / h
        tau = max(-o.max_torque, min(o.max_torque, tau))
        body.apply_force_at_world_point((fx, fy), origin)
        body.torque += tau
        self.servo_effort = (math.hypot(fx, fy), abs(tau))

    def _touching(self) -> bool:
        hits = []
        self.body.each_arbiter(lambda arbiter: hits.append(arbiter))
        return bool(hits)
