"""The simulator ``pymunk``: 2-D rigid-body dynamics for planar scenes (thesis 5.4's dynamic execution).

The robot is a dynamic body with mass and friction, driven compliantly at the commanded velocity (plus
actuation noise from :mod:`pliant.execution.noise`): it turns through a gear joint to a kinematic control body whose
torque is capped at ``max_torque``, and translates under a force-limited velocity servo on its frame's
origin (:meth:`PymunkSimulator._apply_servo`, force capped in norm at ``max_force``), so the robot complies
against obstacles instead of passing through them.  (Not a pivot joint with a capped force: pymunk's solver
accumulates its impulse against a persistent contact and spends the whole force limit pushing into it, so
a robot pressed on a surface could not slide along it, not even frictionless; the servo's force follows the
velocity error.)  Static
geometry is the voxel layer of the static objects as boxes (:mod:`.world`); movable objects (a scene
``mass``) are dynamic bodies held back by the scene's support friction (:mod:`.objects`), put back at their scene
pose at rest by every ``reset``.  The physical properties (masses, friction, restitution, damping, inertia, the
support's friction, the robot's mass and friction) are the scene's (:mod:`pliant.physics`); the options hold the
numerics and the controller's caps.  What pymunk cannot represent (static and rolling friction) is listed once when
the simulator is built.  ``simulate`` uses the same P control law and velocity limits as the
kinematic simulator, so the two agree in free space.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

import numpy as np
from pliant.api import (
    SimulationError,
    SteppedOptions,
    SteppedSimulator,
    VoxelGrid,
    check_batch,
    option,
    report_ignored,
)

from pliant_pymunk.objects import add_object, planar_objects
from pliant_pymunk.world import check_planar, robot_shapes, static_walls

BLOCK_SPEED = 0.1       # m/s: velocity error into a contact at which the servo pushes with its whole force
#: the scene physics pymunk represents (pliant.physics.ScenePhysics.stated kinds); the rest is reported once
SUPPORTED_PHYSICS = ("objects.friction", "objects.mass", "objects.restitution", "objects.linear_damping",
                     "objects.angular_damping", "objects.inertia", "robot.friction", "robot.mass",
                     "robot.restitution", "support.friction")


@dataclass(frozen=True)
class PymunkOptions(SteppedOptions):
    """Options of :class:`PymunkSimulator` (the shared ones: :class:`pliant.execution.stepping.SteppedOptions`)."""

    density: float = option(100.0, "robot mass per area (kg/m^2) when the scene's [robot] gives no mass",
                            minimum=1e-9)
    max_force: float = option(2000.0, "largest force the controller applies (N)", minimum=0.0)
    max_torque: float = option(2000.0, "largest torque the controller applies (N m)", minimum=0.0)
    table_friction: float | None = option(None, "deprecated: the scene's [physics.support] friction (this option, "
                                          "when given, overrides it with a warning)", minimum=0.0,
                                          deprecated="set the scene's [physics.support] friction")
    placed_tolerance: float = option(1.0, "deepest a movable object placed by set_object_poses may lie in the robot "
                                     "when the next step starts (voxels): the contact solver pushes it out; deeper "
                                     "is refused",
                                     minimum=0.0, maximum=2.0)


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
        report_ignored(scene.physics, "pymunk", SUPPORTED_PHYSICS, "a 2-D world has one friction coefficient "
                       "per surface and nothing rolls")
        self.table_friction = _support_friction(scene, o)
        robot = scene.physics.robot
        self.robot_friction = o.friction if robot.friction is None else robot.friction
        for mu, (x0, y0, x1, y1) in static_walls(scene, o.friction):
            wall = pymunk.Poly(self.world.static_body, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
            wall.friction = mu
            self.world.add(wall)
        self.objects = planar_objects(scene)
        self._object_parts: list[tuple] = []
        self._robot_objects = ()
        self._contact = False
        # starts are measured against the static walls' voxels and the walls closing the bounds (the movable objects
        # are bodies the robot pushes; a reset puts them back at their scene poses, where the next placement moves them)
        self.setup_start_check(VoxelGrid.from_scene(scene, static_only=True), outside_solid=True)
        self.reset(scene.start)

    def _add_robot(self, q) -> None:
        """A fresh robot body, control body and gear joint at ``q``, at rest (no solver state carried over)."""
        pymunk, o = self.pymunk, self.options
        if self._robot_objects:
            self.world.remove(*self._robot_objects)
        self.body = pymunk.Body()
        self.body.position = (float(q[0]), float(q[1]))
        self.body.angle = float(q[2])
        robot = self.context.scene.physics.robot
        shapes = robot_shapes(self.context.scene, pymunk, self.body, self.robot_friction)
        density = o.density if robot.mass is None else robot.mass / sum(shape.area for shape in shapes)
        for shape in shapes:
            shape.density = density
            if robot.restitution is not None:
                shape.elasticity = robot.restitution
        # rotation: a gear joint to a kinematic control body turning at the commanded rate, torque capped (a
        # scalar constraint, solved together with the contacts)
        self.control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.control.angle = self.body.angle
        self.gear = pymunk.GearJoint(self.control, self.body, 0.0, 1.0)
        self.gear.max_bias = 0.0            # hold the rate only: heading drift is the noise's
        self.gear.max_force = o.max_torque
        self._robot_objects = (self.body, *shapes, self.control, self.gear)
        self._servo = (0.0, 0.0)            # the commanded velocity (vx, vy) of the frame's origin in this step
        self.servo_force = 0.0              # |force| (N) the translation servo applied in the last substep
        self._normals: list[tuple[float, float]] = []    # the contacts' normals in the last substep
        self.world.add(*self._robot_objects)            # (pymunk sets the mass properties from the shapes here)
        r2 = self.body.center_of_gravity.length_squared     # the origin's squared distance from the centre of mass
        self._servo_gain = 1.0 - math.sqrt(self.body.mass * r2 / (self.body.moment + self.body.mass * r2))

    def _add_objects(self) -> None:
        """Fresh bodies for the movable objects at their scene poses, at rest."""
        o = self.options
        for parts in self._object_parts:
            self.world.remove(*parts)
        self._object_parts = [add_object(self.world, self.pymunk, spec, o.friction, self.table_friction)
                              for spec in self.objects]

    def reset(self, q):
        """Place the robot at ``q`` ``(d,)`` at rest and the movable objects at their scene poses.  The core refuses,
        before this runs, a robot whose surface points lie more than ``start_tolerance`` voxels inside a static
        wall or outside the scene's bounds (:meth:`setup_start_check`): the solver would push it out at an arbitrary
        side, or let it pass through."""
        q = check_batch(q, self.space, "configuration")[0][0]
        self._add_objects()
        self._add_robot(q)
        self._contact = False
        self._placed = False                # no object placed by set_object_poses since (see step)

    def object_poses(self) -> dict[str, np.ndarray]:
        """The movable objects' current poses ``(x, y, theta)`` (m, rad; theta in [-pi, pi)), by name."""
        return {spec.name: spec.pose(parts[0]) for spec, parts in zip(self.objects, self._object_parts)}

    can_place_objects = True

    def set_object_poses(self, poses: dict[str, np.ndarray]) -> None:
        """Place the named movable objects at ``(x, y, theta)`` (m, rad), at rest, as fresh bodies; the robot and the
        other objects stay.  An unknown name, a pose that is not three finite numbers, or one that puts the object
        more than ``start_tolerance`` voxels into a static wall, the scene's bounds or another movable object
        (:meth:`_check_placement`) is a :class:`~pliant.errors.SimulationError` naming it (nothing is moved then).
        An object placed on the robot is refused by the next ``step`` (a ``reset`` may move the robot away first,
        as object-space planners do: put the objects back, then the pusher)."""
        index = {spec.name: k for k, spec in enumerate(self.objects)}
        checked = {}
        for name, pose in poses.items():
            if name not in index:
                raise SimulationError(f"no movable object of that name (movable: {', '.join(index) or 'none'})",
                                      field="set_object_poses", value=name)
            pose = np.asarray(pose, dtype=np.float64).reshape(-1)
            if pose.shape != (3,) or not np.all(np.isfinite(pose)):
                raise SimulationError("an object pose must be three finite numbers (x, y, theta)",
                                      field=f"set_object_poses.{name}", value=np.asarray(pose).tolist())
            checked[index[name]] = pose
        self._check_placement(checked)
        o = self.options
        for k, pose in checked.items():
            self.world.remove(*self._object_parts[k])
            spec = dataclasses.replace(self.objects[k], position=pose[:2].copy(), angle=float(pose[2]))
            self._object_parts[k] = add_object(self.world, self.pymunk, spec, o.friction, self.table_friction)
        self._placed = self._placed or bool(checked)

    def _check_placement(self, placed: dict[int, np.ndarray]) -> None:
        """Refuse object poses ``placed`` (object index -> ``(x, y, theta)``) that put an object more than
        ``start_tolerance`` (m) into the static walls or the bounds (its outline's depth in their voxels, as for
        the robot's starts) or into another movable object (each outline in the other); the solver would
        otherwise throw them apart, or let one pass through the other."""
        tolerance = self.start_tolerance
        step = 0.25 * self.context.scene.resolution
        z = 0.5 * (self.context.scene.lower[2] + self.context.scene.upper[2])
        poses = {k: spec.pose(parts[0]) for k, (spec, parts) in enumerate(zip(self.objects, self._object_parts))}
        poses.update(placed)
        outlines = {k: _outline(self.objects[k], poses[k], step) for k in poses}
        for k in placed:
            spec, pose, outline = self.objects[k], poses[k], outlines[k]
            found = [(float(self.starts.depth(np.column_stack([outline, np.full(len(outline), z)])).max()),
                      self.starts.describe_points(np.column_stack([outline, np.full(len(outline), z)])))]
            for j in poses:
                if j != k:
                    other = self.objects[j]
                    found.append((max(_depth_in_object(other, poses[j], outline).max(initial=0.0),
                                      _depth_in_object(spec, pose, outlines[j]).max(initial=0.0)),
                                  f"movable object '{other.name}'"))
            depth, what = max(found, key=lambda item: item[0])
            if depth > tolerance:
                raise SimulationError(f"places object '{spec.name}' {depth:.4g} m inside {what} (this simulator "
                                      f"tolerates {tolerance:.4g} m of contact)", field=f"set_object_poses.{spec.name}",
                                      value=np.asarray(pose).tolist())

    def _check_robot_clear_of_placed_objects(self) -> None:
        """Refuse to step a robot that lies more than ``placed_tolerance`` voxels inside a movable object placed by
        :meth:`set_object_poses` since the last ``reset`` (the robot's surface points in the object, the object's
        outline in the robot's convex pieces); the solver would throw them apart."""
        step = 0.25 * self.context.scene.resolution
        robot_points = self.robot.body_points(self.configuration()[None], self.starts.surface)[0][:, :2]
        pieces = self._robot_pieces()
        tolerance = self.options.placed_tolerance * self.context.scene.resolution
        for spec, parts in zip(self.objects, self._object_parts):
            pose = spec.pose(parts[0])
            depth = max(_depth_in_object(spec, pose, robot_points).max(initial=0.0),
                        _depth_in_pieces(pieces, _outline(spec, pose, step)).max(initial=0.0))
            if depth > tolerance:
                raise SimulationError(f"the robot starts {depth:.4g} m inside movable object '{spec.name}' (placed "
                                      f"there by set_object_poses; this simulator tolerates "
                                      f"{tolerance:.4g} m, option placed_tolerance); reset the robot elsewhere first",
                                      field="step", value=self.configuration().tolist())

    def _robot_pieces(self) -> list[tuple]:
        """The robot's shapes in the world now: ``("poly", vertices (m, 2) counter-clockwise)`` or
        ``("circle", centre (2,), radius)``."""
        pieces = []
        body = self.body
        for shape in self._robot_objects:
            if isinstance(shape, self.pymunk.Poly):
                pieces.append(("poly", np.array([tuple(body.local_to_world(v)) for v in shape.get_vertices()])))
            elif isinstance(shape, self.pymunk.Circle):
                pieces.append(("circle", np.array(tuple(body.local_to_world(shape.offset))), shape.radius))
        return pieces

    def configuration(self):
        return np.array([self.body.position.x, self.body.position.y,
                         (self.body.angle + math.pi) % (2 * math.pi) - math.pi])

    def in_contact(self):
        return self._contact

    def step(self, velocity, dt, rng):
        if self._placed:
            self._check_robot_clear_of_placed_objects()
            self._placed = False
        v = self.actuate(velocity, rng)
        self._servo = (float(v[0]), float(v[1]))
        self.control.angle = self.body.angle
        self.control.angular_velocity = float(v[2])
        touched = False
        h = dt / self.substeps
        for _ in range(self.substeps):
            self._apply_servo(h)
            self.world.step(h)
            touched = touched or self._touching()
        self._contact = touched
        return self.configuration()

    def _apply_servo(self, h: float) -> None:
        """Apply the capped force at the frame's origin that drives the origin toward the commanded velocity.

        A stiff velocity servo, as the constraint it replaces: in free directions ``F = g m dv / h`` (``dv``
        the origin's velocity error; ``g = 1 - c``, ``c = sqrt(m r^2 / I_o)``, ``r`` the origin's distance
        from the centre of mass, ``I_o`` the moment of inertia about the origin: the largest gain for which
        the force, which also turns the body when ``r > 0``, cannot overshoot, the whole error in one substep
        for a body driven at its centre of mass); along the normal of a contact the command pushes into (from
        the last substep), the gain that saturates at ``BLOCK_SPEED`` (0.1 m/s) of error, so a blocked robot pushes
        with its full force however light it is.  The norm is capped at ``max_force``.
        """
        body, o = self.body, self.options
        vx, vy = self._servo
        v0 = body.velocity_at_local_point((0.0, 0.0))
        ex, ey = vx - v0.x, vy - v0.y
        free = self._servo_gain * body.mass / h
        fx, fy = free * ex, free * ey
        blocked = max(((ex * nx + ey * ny, nx, ny) for nx, ny in self._normals), default=(0.0, 0.0, 0.0))
        if blocked[0] > 0.0:                  # the command pushes into a contact: stiff along its normal
            extra = max(o.max_force / BLOCK_SPEED - free, 0.0) * blocked[0]
            fx, fy = fx + extra * blocked[1], fy + extra * blocked[2]
        norm = math.hypot(fx, fy)
        if norm > o.max_force:
            fx, fy = fx * o.max_force / norm, fy * o.max_force / norm
        body.apply_force_at_world_point((fx, fy), body.local_to_world((0.0, 0.0)))
        self.servo_force = math.hypot(fx, fy)

    def _touching(self) -> bool:
        """Whether the robot touches anything; keeps the contact normals (unit, from the robot outward)."""
        normals = []

        def collect(arbiter):
            n = arbiter.normal if arbiter.shapes[0].body is self.body else -arbiter.normal
            normals.append((float(n.x), float(n.y)))

        self.body.each_arbiter(collect)
        self._normals = normals
        return bool(normals)


def _support_friction(scene, options) -> float:
    """The Coulomb coefficient between movable objects and the table: the scene's ``[physics.support] friction``,
    or the deprecated option ``table_friction`` when a pipeline still gives it (its warning: pliant.options)."""
    return scene.physics.support_friction if options.table_friction is None else options.table_friction


def _outline(spec, pose: np.ndarray, step: float) -> np.ndarray:
    """Points ``(m, 2)`` along the outline of movable object ``spec`` at ``pose`` ``(x, y, theta)``, at most ``step``
    (m) apart, corners included (two convex shapes overlap only where one's outline enters the other)."""
    if spec.kind == "box":
        hx, hy = spec.half_extents
        corners = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy], [-hx, -hy]])
        local = np.vstack([np.linspace(a, b, max(2, math.ceil(np.linalg.norm(b - a) / step) + 1))[:-1]
                           for a, b in itertools.pairwise(corners)])
    else:
        count = max(8, math.ceil(2 * math.pi * spec.radius / step))
        angle = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
        local = spec.radius * np.column_stack([np.cos(angle), np.sin(angle)])
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return local @ np.array([[c, s], [-s, c]]) + pose[:2]


def _depth_in_object(spec, pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Depth (m) of points ``(m, 2)`` inside movable object ``spec`` at ``pose``: the distance to its outline, 0
    outside."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    local = (np.asarray(points) - pose[:2]) @ np.array([[c, -s], [s, c]])
    if spec.kind == "box":
        return np.maximum(np.minimum(spec.half_extents[0] - np.abs(local[:, 0]),
                                     spec.half_extents[1] - np.abs(local[:, 1])), 0.0)
    return np.maximum(spec.radius - np.linalg.norm(local, axis=1), 0.0)


def _depth_in_pieces(pieces: list[tuple], points: np.ndarray) -> np.ndarray:
    """Depth (m) of points ``(m, 2)`` inside the robot's convex pieces (:meth:`PymunkSimulator._robot_pieces`): the
    largest over the pieces of the distance to that piece's outline, 0 outside all."""
    depth = np.zeros(len(points))
    for piece in pieces:
        if piece[0] == "circle":
            depth = np.maximum(depth, piece[2] - np.linalg.norm(points - piece[1], axis=1))
            continue
        vertices = piece[1]
        edges = np.roll(vertices, -1, axis=0) - vertices
        inward = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
        if np.sum(edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]) < 0:
            inward = -inward                                  # clockwise vertices: the left normal points out
        signed = np.einsum("ec,mec->me", inward, points[:, None, :] - vertices[None])
        depth = np.maximum(depth, signed.min(axis=1))
    return np.maximum(depth, 0.0)
