"""Physical properties of a scene: what every dynamic simulator reads, from one place (docs/scenes.md, "Physics").

A scene states its physics next to its geometry:

- per object (``[[objects]]``): ``mass`` (kg; makes the object movable) and ``friction`` (read by
  :mod:`pliant.scene`), and here ``static_friction``, ``rolling_friction``, ``restitution``,
  ``linear_damping``, ``angular_damping`` and ``inertia`` (principal moments ``[ixx, iyy, izz]`` in the
  object's frame, kg m^2; derived from the shape and the mass by :func:`inertia_diagonal` when not given);
- for the robot (``[robot]``): ``friction``, ``restitution`` and, for a rigid robot, ``mass`` (kg, the
  whole body, spread uniformly over its parts);
- for a planar scene, the support it is seen on from above (``[physics.support]``): ``friction``, the
  Coulomb coefficient between the support and every movable object standing on it (default
  :data:`DEFAULT_SUPPORT_FRICTION`).

Two touching surfaces combine their coefficients by the product (friction ``mu_a mu_b``, restitution ``e_a e_b``):
the rule of pymunk and of Bullet alike, so no per-pair table is needed for them to agree.  Damping is the fraction of
velocity lost per second with no other force acting (``v(t) = v(0) (1 - d)^t``), Bullet's definition; pymunk's
"velocity kept per second" is ``1 - d``.  A simulator that cannot represent a stated property lists it once when it
is built (:func:`report_ignored`); it never drops one silently.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass, field, fields

import numpy as np

from pliant.validation import Fields

log = logging.getLogger("pliant.physics")

#: m/s^2: the weight of an object on a planar scene's support is ``m g``
STANDARD_GRAVITY = 9.80665
#: the support friction of a planar scene that states none (pymunk's table friction before scenes held it)
DEFAULT_SUPPORT_FRICTION = 0.5

#: object fields read here (``mass`` and ``friction`` are read by the scene reader itself)
OBJECT_FIELDS = ("static_friction", "rolling_friction", "restitution", "linear_damping", "angular_damping", "inertia")
#: of those, the ones only a movable object (one with a mass) can have
MOVABLE_ONLY = ("linear_damping", "angular_damping", "inertia")


@dataclass(frozen=True)
class BodyPhysics:
    """The physical properties of one body (an object or the robot); ``None`` where the scene states nothing.

    friction / static_friction / rolling_friction: Coulomb coefficients (>= 0; static >= dynamic);
    restitution: in [0, 1]; linear_damping / angular_damping: fraction of velocity lost per second, in [0, 1);
    mass: kg (> 0); inertia: ``(3,)`` principal moments (kg m^2) in the body's frame.
    """

    friction: float | None = None
    static_friction: float | None = None
    rolling_friction: float | None = None
    restitution: float | None = None
    linear_damping: float | None = None
    angular_damping: float | None = None
    mass: float | None = None
    inertia: np.ndarray | None = None

    def stated(self) -> list[str]:
        """The names of the properties the scene states, in field order."""
        return [f.name for f in fields(self) if getattr(self, f.name) is not None]


@dataclass(frozen=True)
class Support:
    """The surface a planar scene's movable objects slide on: its Coulomb ``friction`` with every object (the
    pair's coefficient, not combined with the object's own); ``stated``: whether the scene gives it."""

    friction: float = DEFAULT_SUPPORT_FRICTION
    stated: bool = False


@dataclass(frozen=True)
class ScenePhysics:
    """Everything physical a scene states: ``objects`` (by name), the ``robot``, and the ``support`` (planar scenes
    only, else ``None``)."""

    objects: dict[str, BodyPhysics] = field(default_factory=dict)
    robot: BodyPhysics = BodyPhysics()
    support: Support | None = None

    @property
    def support_friction(self) -> float:
        """The support's Coulomb coefficient (:data:`DEFAULT_SUPPORT_FRICTION` for a scene built without one)."""
        return DEFAULT_SUPPORT_FRICTION if self.support is None else self.support.friction

    def body(self, name: str) -> BodyPhysics:
        """The properties of object ``name`` (empty when the scene states none)."""
        return self.objects.get(name, BodyPhysics())

    def stated(self) -> list[tuple[str, str]]:
        """Every property the scene states, as ``(kind, field path)``: kind ``objects.P``, ``robot.P`` or
        ``support.P`` (P the property), path ``objects.NAME.P``, ``robot.P`` or ``physics.support.P``."""
        out = [(f"objects.{p}", f"objects.{name}.{p}") for name, body in self.objects.items() for p in body.stated()]
        out += [(f"robot.{p}", f"robot.{p}") for p in self.robot.stated()]
        if self.support is not None and self.support.stated:
            out.append(("support.friction", "physics.support.friction"))
        return out

    def ignored(self, supported: Iterable[str]) -> list[str]:
        """Field paths of the stated properties whose kind (``objects.friction``, ...) is not in ``supported``."""
        keep = set(supported)
        return [path for kind, path in self.stated() if kind not in keep]


def report_ignored(physics: ScenePhysics, simulator: str, supported: Iterable[str], why: str = "") -> list[str]:
    """Log, once, one warning listing the scene's physics properties that ``simulator`` cannot represent (kinds
    not in ``supported``, see :meth:`ScenePhysics.ignored`); returns them (empty: nothing logged).  Simulators call
    it once per build."""
    ignored = physics.ignored(supported)
    if ignored:
        keep = set(supported)
        groups: dict[str, list[str]] = {}
        for kind, path in physics.stated():
            if kind not in keep:
                groups.setdefault(kind, []).append(path.split(".")[1] if kind.startswith("objects.") else "")
        text = "; ".join(kind if not names[0] else f"{kind} ({', '.join(names)})" for kind, names in groups.items())
        log.warning("simulator %s ignores these scene physics properties%s: %s", simulator,
                    f" ({why})" if why else "", text)
    return ignored


def inertia_diagonal(shape, mass: float) -> np.ndarray:
    """Principal moments ``(3,)`` (kg m^2) of a solid, uniform ``shape`` (box, sphere, or cylinder along its z
    axis) of ``mass`` kg about its centre, in its own frame; ``ValueError`` for other shapes."""
    if shape.kind == "box":
        a, b, c = (float(v) for v in shape.size)
        return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    if shape.kind == "sphere":
        return np.full(3, 0.4 * mass * shape.radius ** 2)
    if shape.kind == "cylinder":
        r, h = float(shape.radius), float(shape.length)
        side = mass * (3 * r * r + h * h) / 12.0
        return np.array([side, side, 0.5 * mass * r * r])
    raise ValueError(f"no inertia formula for a {shape.kind}")


def footprint_mean_radius(shape) -> float:
    """Mean distance (m) of the points of ``shape``'s footprint on the support (its cross-section in the xy plane of
    its own frame: a box's rectangle, a cylinder's or a sphere's disc) from its centre: the lever arm of uniformly
    distributed Coulomb friction, so the support resists spinning with torque ``mu m g r_mean``."""
    if shape.kind in ("sphere", "cylinder"):
        return 2.0 * float(shape.radius) / 3.0
    if shape.kind != "box":
        raise ValueError(f"no footprint for a {shape.kind}")
    n = 256                                       # midpoint rule, relative error ~1e-5
    u = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    x, y = np.meshgrid(u * shape.size[0] / 2, u * shape.size[1] / 2, indexing="ij")
    return float(np.mean(np.hypot(x, y)))


def support_limits(friction: float, mass: float, mean_radius: float) -> tuple[float, float]:
    """The largest force (N) and torque (N m) a planar support of Coulomb ``friction`` opposes to an object of
    ``mass`` kg whose footprint's mean radius is ``mean_radius`` m: ``mu m g`` and ``mu m g r_mean`` (capped
    separately, a box limit surface; docs/scenes.md)."""
    force = friction * mass * STANDARD_GRAVITY
    return force, force * mean_radius


class PhysicsReader:
    """Reads the physics fields of one scene file while :mod:`pliant.scene` reads the rest (each call marks its
    keys read, so misspelt fields still fail the table's ``finish``)."""

    def __init__(self) -> None:
        self.objects: dict[str, BodyPhysics] = {}
        self.robot = BodyPhysics()

    def object(self, t: Fields, name: str, mass: float | None, friction: float | None) -> None:
        """The physics fields of object table ``t`` (``mass`` and ``friction`` already read)."""
        values = _body_fields(t, friction)
        for key in MOVABLE_ONLY:
            if values[key] is not None and mass is None:
                t.fail(key, "only a movable object (one with a mass) has this property", t.raw(key))
        self.objects[name] = BodyPhysics(friction=friction, mass=mass, **values)

    def robot_fields(self, t: Fields, kind: str) -> None:
        """The robot's ``friction``, ``restitution`` and (rigid robots) ``mass``."""
        friction = t.number("friction", None, minimum=0.0)
        restitution = t.number("restitution", None, minimum=0.0, maximum=1.0)
        mass = None
        if kind == "rigid":
            mass = t.number("mass", None, positive=True)
        elif t.has("mass"):
            t.fail("mass", "a URDF robot's masses are its links' (in the URDF); mass is for rigid robots",
                   t.raw("mass"))
        self.robot = BodyPhysics(friction=friction, restitution=restitution, mass=mass)

    def finish(self, t: Fields, planar: bool) -> ScenePhysics:
        """The scene's ``[physics]`` table ``t`` (may be empty) and everything read so far."""
        support = None
        if t.has("support") and not planar:
            t.fail("support", "only a planar scene (planar = true) has a support surface; in 3-D the objects "
                   "stand on other objects", t.raw("support"))
        s = t.table("support", default={})
        if planar:
            mu = s.number("friction", None, minimum=0.0)
            support = Support(DEFAULT_SUPPORT_FRICTION if mu is None else mu, stated=mu is not None)
        s.finish()
        t.finish()
        return ScenePhysics(objects=dict(self.objects), robot=self.robot, support=support)


def _body_fields(t: Fields, friction: float | None) -> dict:
    static = t.number("static_friction", None, minimum=0.0)
    if static is not None and friction is not None and static < friction:
        t.fail("static_friction", f"must be at least the (dynamic) friction {friction:g}", static)
    values = {
        "static_friction": static,
        "rolling_friction": t.number("rolling_friction", None, minimum=0.0),
        "restitution": t.number("restitution", None, minimum=0.0, maximum=1.0),
        "linear_damping": t.number("linear_damping", None, minimum=0.0, maximum=1.0),
        "angular_damping": t.number("angular_damping", None, minimum=0.0, maximum=1.0),
        "inertia": t.vector("inertia", 3, None, positive=True),
    }
    for key in ("linear_damping", "angular_damping"):
        if values[key] is not None and values[key] >= 1.0:
            t.fail(key, "must be below 1 (the fraction of velocity lost per second; 1 stops the body at once)",
                   values[key])
    inertia = values["inertia"]
    if inertia is not None and not math.isfinite(float(np.sum(inertia))):
        t.fail("inertia", "must be three finite positive moments [ixx, iyy, izz] (kg m^2)", inertia.tolist())
    if inertia is not None:
        a, b, c = sorted(inertia.tolist())
        if c > a + b + 1e-12 * c:
            t.fail("inertia", "principal moments must satisfy the triangle inequality (each at most the sum of the "
                   "other two), as every real body's do", inertia.tolist())
    return values
