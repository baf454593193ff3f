"""Movable scene objects (those with a ``mass``) as planar rigid bodies in pymunk.

A movable object becomes a dynamic pymunk body whose shape is the object's cross-section in the scene's voxel
layer (the plane ``z = layer centre``): a box rotated about z is a rectangle, a cylinder along z or a sphere
is a circle. Its mass, friction, restitution, damping and moment of inertia are the scene's
(:mod:`pliant.physics`; the moment about z from the shape and the mass, uniform density, when the scene gives
no ``inertia``). What has no exact planar cross-section of that kind — a mesh, a voxel array, cut-outs, a
rotation out of the plane, a shape that misses the layer, an overlap with the static geometry — is refused
with a :class:`~pliant.errors.SimulationError` naming the field.

The table (the scene's support, ``[physics.support]``): the scene is seen from above with zero gravity, so the
friction between an object and the table it stands on is modelled by a pivot joint and a gear joint to the
static body that hold the object's velocity and spin at zero with capped force ``mu m g`` and torque ``mu m g
r_mean`` (``r_mean``: the mean distance of the footprint from its centre, the torque of uniformly distributed
Coulomb friction). Force and torque are capped separately: a simple limit surface, documented in
docs/plugins/pymunk.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pliant.api import Scene, SimulationError, VoxelGrid, support_limits


@dataclass(frozen=True)
class PlanarObject:
    """A movable scene object's planar body.

    index: the object's index in ``scene.objects``; name: its name.
    position: ``(2,)`` centre (m); angle: yaw (rad).
    kind: ``"box"`` (``half_extents`` ``(2,)`` m) or ``"circle"`` (``radius`` m).
    mass: kg; friction: the surface's Coulomb coefficient, ``None`` for the simulator's default.
    restitution: ``None`` for pymunk's default (0); linear_damping / angular_damping: fraction of velocity lost per
    second (0: none); moment: about z (kg m^2), ``None`` to derive it from the shape.
    """

    index: int
    name: str
    position: np.ndarray
    angle: float
    kind: str
    half_extents: np.ndarray | None
    radius: float | None
    mass: float
    friction: float | None
    restitution: float | None = None
    linear_damping: float = 0.0
    angular_damping: float = 0.0
    moment: float | None = None

    def mean_radius(self) -> float:
        """Mean distance (m) of the footprint's points from its centre (uniform pressure on the table)."""
        if self.kind == "circle":
            return 2.0 * self.radius / 3.0
        n = 256                                   # midpoint rule, relative error ~1e-5
        u = (np.arange(n) + 0.5) / n * 2.0 - 1.0
        x, y = np.meshgrid(u * self.half_extents[0], u * self.half_extents[1], indexing="ij")
        return float(np.mean(np.hypot(x, y)))

    def pose(self, body) -> np.ndarray:
        """``(x, y, theta)`` of ``body`` (this object's pymunk body), theta wrapped to [-pi, pi)."""
        return np.array([body.position.x, body.position.y, (body.angle + math.pi) % (2 * math.pi) - math.pi])


def planar_objects(scene: Scene) -> list[PlanarObject]:
    """The movable objects of a planar scene as planar bodies; raises :class:`SimulationError` for any it
    cannot represent exactly."""
    movable = [k for k, obj in enumerate(scene.objects) if obj.movable]
    if not movable:
        return []
    walls = VoxelGrid.from_scene(scene, static_only=True)
    return [_planar_object(scene, k, walls) for k in movable]


def _refuse(scene: Scene, k: int, key: str, reason: str, value) -> None:
    raise SimulationError(f"movable object '{scene.objects[k].name}': {reason}", source=scene.source,
                          field=f"objects[{k}].{key}", value=value)


def _planar_object(scene: Scene, k: int, walls: VoxelGrid) -> PlanarObject:
    """Object ``k``'s cross-section in the layer ``z = layer centre``, checked (see the module docstring)."""
    obj = scene.objects[k]
    part = obj.part
    kind = part.shape.kind
    if kind not in ("box", "cylinder", "sphere"):
        _refuse(scene, k, "shape", "pymunk simulates movable boxes, cylinders and spheres only (a mesh or voxel "
                "array has no exact planar body)", kind)
    if part.cutouts:
        _refuse(scene, k, "cutouts", "a movable object with cut-outs cannot be represented in pymunk",
                len(part.cutouts))
    q = part.pose.orientation
    if abs(q[0]) > 1e-9 or abs(q[1]) > 1e-9:
        _refuse(scene, k, "orientation", "a movable object in a planar scene may only rotate about z (it must "
                "be prismatic along z)", q.tolist())
    z_layer = 0.5 * (scene.lower[2] + scene.upper[2])
    dz = z_layer - part.pose.position[2]
    position = part.pose.position.tolist()
    half = radius = None
    if kind == "sphere":
        if abs(dz) >= part.shape.radius:
            _refuse(scene, k, "position", f"the sphere does not cut the scene's layer z = {z_layer}", position)
        radius = math.sqrt(part.shape.radius ** 2 - dz ** 2)
    else:
        height = part.shape.size[2] if kind == "box" else part.shape.length
        if abs(dz) > 0.5 * height:
            _refuse(scene, k, "position", f"the object does not reach the scene's layer z = {z_layer}", position)
        if kind == "box":
            half = np.asarray(part.shape.size[:2], dtype=np.float64) / 2
        else:
            radius = float(part.shape.radius)
    if _overlaps(walls, obj):
        _refuse(scene, k, "position", "the movable object starts inside static geometry", position)
    physics = scene.physics.body(obj.name)
    return PlanarObject(index=k, name=obj.name, position=np.array(part.pose.position[:2], dtype=np.float64),
                        angle=float(2 * math.atan2(q[2], q[3])), kind="box" if kind == "box" else "circle",
                        half_extents=half, radius=radius, mass=float(obj.mass), friction=obj.friction,
                        restitution=physics.restitution, linear_damping=physics.linear_damping or 0.0,
                        angular_damping=physics.angular_damping or 0.0,
                        moment=None if physics.inertia is None else float(physics.inertia[2]))


def _overlaps(walls: VoxelGrid, obj) -> bool:
    """Whether a static voxel's centre lies inside ``obj``."""
    idx = np.argwhere(walls.occupied)
    return bool(len(idx)) and bool(obj.contains(walls.centres(idx)).any())


def add_object(world, pymunk, spec: PlanarObject, friction: float, table_friction: float) -> tuple:
    """Add a fresh body for ``spec`` at its scene pose, at rest, with its table-friction joints.

    ``friction``: the surface coefficient when the object has none; ``table_friction``: the Coulomb
    coefficient between object and table (0: no table friction).  Returns everything added (the body
    first), so that it can be removed again.
    """
    body = pymunk.Body() if spec.moment is None else pymunk.Body(spec.mass, spec.moment)
    body.position = (float(spec.position[0]), float(spec.position[1]))
    body.angle = spec.angle
    if spec.kind == "box":
        hx, hy = spec.half_extents
        shape = pymunk.Poly(body, [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)])
    else:
        shape = pymunk.Circle(body, spec.radius)
    if spec.moment is None:
        shape.mass = spec.mass                 # the moment follows from the shape (uniform density)
    shape.friction = spec.friction if spec.friction is not None else friction
    if spec.restitution is not None:
        shape.elasticity = spec.restitution    # pymunk multiplies the two shapes' elasticities, as Bullet does
    if spec.linear_damping or spec.angular_damping:
        body.velocity_func = _damped(pymunk, 1.0 - spec.linear_damping, 1.0 - spec.angular_damping)
    added = [body, shape]
    if table_friction > 0:
        force, torque = support_limits(table_friction, spec.mass, spec.mean_radius())
        slide = pymunk.PivotJoint(world.static_body, body, (0.0, 0.0), (0.0, 0.0))
        slide.max_bias = 0.0                   # resist velocity only; never pull back to a position
        slide.max_force = force
        spin = pymunk.GearJoint(world.static_body, body, 0.0, 1.0)
        spin.max_bias = 0.0
        spin.max_force = torque
        added += [slide, spin]
    world.add(*added)
    return tuple(added)


def _damped(pymunk, keep_linear: float, keep_angular: float):
    """A body velocity function that integrates as pymunk does, then keeps ``keep ** dt`` of the linear and the
    angular velocity (the scene's damping ``d`` is the fraction lost per second: keep = 1 - d)."""

    def update(body, gravity, damping, dt):
        pymunk.Body.update_velocity(body, gravity, damping, dt)
        body.velocity = body.velocity * keep_linear ** dt
        body.angular_velocity = body.angular_velocity * keep_angular ** dt

    return update
