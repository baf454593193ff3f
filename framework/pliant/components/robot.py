"""The robot kind: a configuration space, body points, forward kinematics and (for URDF robots) collisions.
"""

from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass
from typing import Any

import numpy as np

from pliant.components.base import Component
from pliant.spaces import Space


@dataclass
class SelfContacts:
    """Contacts between a robot's own links at one configuration (``c`` contacts, ``d`` joints).

    point_a / point_b: ``(c, 3)`` world points (m) on the two links; normal: ``(c, 3)`` unit, from
    link a toward link b; depth: ``(c,)`` penetration (m, >= 0); mass_a / mass_b: ``(c,)`` mass (kg)
    of each link with everything it carries further down the chain (thesis app. B); jacobian_a /
    jacobian_b: ``(c, 3, d)`` Jacobians of the two points.
    """

    point_a: np.ndarray
    point_b: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    mass_a: np.ndarray
    mass_b: np.ndarray
    jacobian_a: np.ndarray
    jacobian_b: np.ndarray

    def __len__(self) -> int:
        return len(self.depth)


@dataclass(frozen=True)
class UrdfDescription:
    """How to load an articulated robot into a simulator that reads URDF (e.g. pybullet).

    urdf: the URDF file (a path).  package_dirs: directories that ``package://`` mesh paths are
    relative to.  joint_names: the planned joints, in the order of the configuration vector ``(d,)``.
    posture: the fixed value (rad or m) of every other single-DoF joint, by name.
    velocity_limits / effort_limits: ``(d,)`` per planned joint (rad/s or m/s; N m or N).
    base_position / base_orientation: where the URDF's root link frame stands in the world, ``(3,)`` m and a
    quaternion ``(x, y, z, w)`` (a scene's task may place the base; default the world origin).
    """

    urdf: Any
    package_dirs: tuple[Any, ...]
    joint_names: tuple[str, ...]
    posture: dict[str, float]
    velocity_limits: np.ndarray
    effort_limits: np.ndarray
    base_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)


class RobotModel(Component):
    """A robot: its configuration space and the points of its body.

    The body is a set of ``m`` sample points (voxel centres at the scene resolution, thesis 3.2.1),
    each with a deformability and a sensitivity.
    """

    kind = "robot"

    @property
    @abstractmethod
    def space(self) -> Space:
        """The configuration space (bounds from joint limits or the scene)."""

    @abstractmethod
    def body_points(self, q: np.ndarray, indices: np.ndarray | None = None) -> np.ndarray:
        """World positions of the body points, ``(n, m, 3)`` for ``q`` ``(n, d)``; metres.

        ``indices`` ``(k,)`` selects a subset of the points (then ``(n, k, 3)``).  Each call returns a new array that
        the caller may keep: a later call never writes into it (the kinematic simulator keeps the points of a step's
        end for the next step).
        """

    @abstractmethod
    def point_materials(self) -> np.ndarray:
        """``(m, 2)``: deformability and sensitivity of each body point."""

    @abstractmethod
    def point_jacobians(self, q: np.ndarray, indices: np.ndarray | None = None) -> np.ndarray:
        """``(n, m, 3, t)``: d(point position)/d(tangent motion) at each configuration.

        ``indices`` ``(k,)`` selects a subset of the points (then ``(n, k, 3, t)``).
        """

    def surface_indices(self) -> np.ndarray:
        """Indices of the body points on the body's surface (contact happens there first).

        The default is every point; robots that know their interior override it.
        """
        return np.arange(self.point_count())

    def surface_faces(self) -> np.ndarray | None:
        """Which body-frame axis directions leave the body at each surface point, or ``None``.

        Bool ``(k, 6)`` in the order of :meth:`surface_indices`, columns ``-x, +x, -y, +y, -z, +z``
        (body frame): the outward normals of the faces the point lies on (one for a point inside a face,
        two on an edge, three at a corner).  Contact resolution uses them to tell a robot face sliding
        past an obstacle's edge from a robot corner hitting a face (thesis app. B).  The default,
        ``None``, means the robot cannot tell (the simulator then traces points along their motion only).
        """
        return None

    def point_count(self) -> int:
        return len(self.point_materials())

    def self_contacts(self, q: np.ndarray) -> SelfContacts | None:
        """Contacts between the robot's own links at one configuration ``(d,)``; ``None`` if it has no links."""
        return None

    def rigid_placement(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """For a single rigid body: ``(R (n, 3, 3), t (n, 3), local (m, 3))`` with points ``R @ local + t``.

        Lets hot paths (cost evaluation, simulation) fuse the transform into their kernels.
        Articulated robots return ``None`` (the default) and are used through :meth:`body_points`.
        """
        return None

    def collisions(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: whether the robot's own collision model (its geometry, not its body points) collides at
        configurations ``(n, d)`` with the scene's obstacles or with itself.

        The core's validity checker (:mod:`pliant.planning.validity`) checks every robot's body points against the
        scene's voxels, and calls this too when a robot overrides it (URDF robots: their collision meshes and
        self-collision).  The default, never, is for robots whose body points are their whole geometry.
        """
        return np.zeros(len(np.atleast_2d(q)), dtype=bool)

    def inverse_kinematics(self, frame: str, position, orientation=None, *, rng: np.random.Generator,
                           solutions: int = 4, position_tolerance: float = 1e-3,
                           orientation_tolerance: float = 1e-2, valid=None) -> np.ndarray:
        """Up to ``solutions`` diverse configurations ``(k, d)`` placing ``frame`` at ``position`` (m, world) and,
        when given, ``orientation`` (quaternion ``(qx, qy, qz, qw)``) within the tolerances (m, rad) and the joint
        limits, accepted by ``valid`` (``(n, d) -> bool (n,)``); ``k`` may be 0.  The default: this robot has no
        inverse kinematics (URDF robots have, :mod:`pliant_pinocchio.ik`)."""
        from pliant.errors import ConfigError

        raise ConfigError(f"{type(self).__name__} has no inverse kinematics: give the goal as a configuration",
                          field="goal.pose", value=frame)

    def urdf_description(self) -> UrdfDescription | None:
        """The URDF, joint order and fixed posture of an articulated robot; ``None`` (the default) otherwise.

        Dynamic simulators load the same robot from it, so the configuration vector means the same
        joints in every backend.
        """
        return None
