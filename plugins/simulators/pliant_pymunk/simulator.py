"""The simulator ``pymunk``: 2-D rigid-body dynamics for planar scenes (thesis 5.4's dynamic execution).

The robot is a dynamic body with mass and friction, driven compliantly: a kinematic *control body*
moves at the commanded velocity (plus actuation noise from :mod:`pliant.noise`) and pulls the robot
through a pivot joint and a gear joint whose forces and torques are capped (``max_force``,
``max_torque``), so the robot complies against obstacles instead of passing through them.  Static
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
