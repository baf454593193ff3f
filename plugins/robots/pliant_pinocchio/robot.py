"""URDF robots through pinocchio (kinematics) and coal (collision geometry).

Configurations are the values of one joint group, ``(d,)`` or ``(n, d)``: radians for revolute and
continuous joints, metres for prismatic ones; every other joint stays at a fixed posture (zero, or the
middle of its range when zero is outside it; the ``posture`` option overrides any joint by name).
The body is represented by points sampled on every collision geometry's surface at the scene
resolution (thesis 3.2.1), each attached to its joint, so that the voxel cost model and the
kinematic simulator can use any URDF robot as they use a rigid body.

Point Jacobians: after ``computeJointJacobians`` the columns of ``data.J`` are the joints' motion
subspaces as world-frame twists ``(v_O, w)`` (``v_O`` the velocity of the body point at the world
origin), so a point ``p`` carried by joint ``j`` moves with ``v_O + w x p`` for every column whose
joint supports ``j`` — equal to ``J_lin - [p - o]x J_ang`` of the link frame in LOCAL_WORLD_ALIGNED,
and vectorised over all points at once.  ``body_points`` and ``point_jacobians`` compute the same batched
over configurations, without pinocchio calls (:mod:`pliant_pinocchio.kinematics`: revolute and prismatic
group joints, every other joint at its posture); frame and contact queries call pinocchio per configuration.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
from pliant.api import (
    ConfigError,
    DimensionError,
    PlanningError,
    ProcessMemo,
    RealVectorSpace,
    RobotModel,
    SceneError,
    SelfContacts,
    UrdfDescription,
    check_batch,
    option,
)

from pliant_pinocchio.catalog import RobotEntry, named_robot
from pliant_pinocchio.kinematics import JointChain
from pliant_pinocchio.sampling import surface_points

#: selections of body points a robot remembers (:meth:`PinocchioRobot._select`); more are rare: a planner's and a
#: simulator's surface points, a metric's subset
SELECTIONS_KEPT = 8
#: URDFs a process keeps parsed, with the body points sampled on them: a test session, an experiment or a planner's
#: pool creates the same robot many times, and parsing the meshes and sampling them took most of its creation
PARSED_KEPT = 4
_parsed = ProcessMemo(PARSED_KEPT)          # file key -> (model, geometry), the collision pairs chosen
_sampled = ProcessMemo(PARSED_KEPT)         # (file key, joints, spacing) -> (local points, their joints)


def _file_key(entry: RobotEntry) -> tuple:
    """What a parsed URDF depends on: the URDF's and SRDF's paths, sizes and modification times, and the package
    directories its meshes are found in (a mesh edited while a process runs is not seen: create it in a new one)."""
    files = [entry.urdf] if entry.srdf is None else [entry.urdf, entry.srdf]
    stats = tuple((str(f), os.stat(f).st_mtime_ns, os.stat(f).st_size) for f in files)
    return stats, tuple(str(p) for p in entry.package_dirs)


@dataclass(frozen=True)
class PinocchioOptions:
    """Options of :class:`PinocchioRobot` (units in each ``doc``)."""

    model: str | None = option(None, "the URDF robot: a name (baxter, pr2, iiwa) or a .urdf path; default the "
                               "scene's robot.model (another model needs the scene's start and goal to fit its group)")
    group: str | None = option(None, "joint group to plan for (default: the scene's robot.group, else 'all')")
    resolution: float | None = option(None, "spacing of the body's surface points (m); default the scene "
                                      "resolution", minimum=1e-4)
    posture: dict[str, float] = option(None, "values (rad or m) of joints outside the group, by name; "  # noqa: RUF009
                                       "unnamed joints sit at 0 (or mid-range when 0 is outside their limits)",
                                       default_factory=dict)
    continuous_range: float = option(math.pi, "continuous joints are bounded to [-this, this] (rad)",
                                     minimum=1e-3, maximum=100.0)
    acceleration_factor: float = option(4.0, "acceleration limits = this x velocity limits (1/s): full speed in "
                                        "1/this s; vendors publish no acceleration limits", minimum=1e-6)
    jerk_factor: float = option(20.0, "jerk limits = this x acceleration limits (1/s): full acceleration in "
                                "1/this s", minimum=1e-6)
    acceleration_limits: tuple[float, ...] = option((), "explicit per-group-joint acceleration limits "
                                                    "(rad/s^2 or m/s^2); replaces acceleration_factor")
    jerk_limits: tuple[float, ...] = option((), "explicit per-group-joint jerk limits (rad/s^3 or m/s^3); "
                                            "replaces jerk_factor")
    body: str = option("moving", "which links carry body points: moving (those the group moves; static links "
                       "can neither cause nor resolve a new contact) or all", choices=("moving", "all"))
    deformability: float | None = option(None, "deformability of the robot's points in [0, 1] (thesis eq. 3.1); "
                                         "default the scene robot's material (0)", minimum=0.0, maximum=1.0)
    sensitivity: float | None = option(None, "sensitivity of the robot's points (>= 0, thesis eq. 3.1); default "
                                       "the scene robot's material (1)", minimum=0.0)


@dataclass
class _Obstacle:
    """A scene object as coal sees it: its geometry and world placement (cut-outs ignored)."""

    name: str
    geometry: object            # a coal collision geometry
    transform: object           # coal.Transform3s, world placement


class PinocchioRobot(RobotModel):
    """A URDF robot (``pr2``, ``baxter``, ``iiwa`` or a ``.urdf`` path) with pinocchio kinematics.

    Bound to a scene whose ``[robot]`` has ``kind = "urdf"``.  Batched over configurations
    ``(n, d)``: body points ``(n, m, 3)`` (m) and their Jacobians ``(n, m, 3, d)`` (m/rad, m/m);
    frame placements and point Jacobians of named frames; self-collision through coal with the
    SRDF's allowed pairs removed (adjacent links for robots without an SRDF); distance (m) to the
    scene's objects.  Attributes after binding:

    - ``joint_names`` (d,), ``lower`` / ``upper`` (d,) position limits (rad or m),
    - ``velocity_limits`` (rad/s), ``acceleration_limits`` (rad/s^2), ``jerk_limits`` (rad/s^3), each (d,),
    - ``groups``: the joint groups of this robot by name,
    - ``model`` / ``geometry``: the pinocchio model and collision model.
    """

    Options = PinocchioOptions
    example_scene = "iiwa-shelf"

    def bind(self, context) -> None:
        """Load the robot of the context's scene, choose the group, sample the body, build the space."""
        super().bind(context)
        scene = self.require("scene")
        spec = scene.robot
        self._source = scene.source
        if spec.kind != "urdf":
            raise PlanningError("the pinocchio robot needs a scene whose [robot] kind is 'urdf'", source=scene.source,
                                field="robot.kind", value=spec.kind)
        model = self.options.model or spec.model
        swapped = model != spec.model
        entry = self._entry(model, scene.source)
        self.model_name = model
        self.entry = entry
        #: the scene task's table for this model (pliant.task.RobotTask: group, tool, start, base), or None
        self.task = scene.task.for_robot(model, scene.source) if scene.task is not None else None
        self._load(entry, scene.source, model)
        if self.task is not None and self.task.placed:
            self._place_base(self.task.base_position, self.task.base_orientation)
        group = self.options.group or (self.task.group if self.task is not None else None) or spec.group or "all"
        self._choose_group(entry, group, from_option=bool(self.options.group))
        self._set_limits(entry)
        self.base_configuration = self._posture()
        self._sample_body(self.options.resolution or scene.resolution, spec.material)
        #: self-penetration (m) the validity check tolerates: a quarter voxel, the contact slop of the kinematic
        #: simulator's states
        self.self_tolerance = 0.25 * scene.resolution
        #: batched forward kinematics of the joints carrying points; None: a joint on the chain is not
        #: a plain revolute / prismatic one, and body points fall back to the per-configuration loop
        self._chain = JointChain.build(self.model, self.joint_ids, self._used, self.base_configuration)
        self._space = self._make_space(None if swapped else spec.weights)
        self._obstacles = self._build_obstacles(scene)
        #: per joint id: which group joints move it (d,), and its subtree mass (kg; constant, for self-contacts)
        self._joint_support = self._support_mask(range(self.model.njoints))
        pin.computeSubtreeMasses(self.model, self.data)
        self._subtree_mass = np.array(self.data.mass, dtype=np.float64)
        self._broad_phase = None            # built on the first self-collision query
        for key in ("start", "goal"):
            if scene.task is not None and scene.task.robot is None:
                break                       # a task not yet resolved for this robot (pliant.task.resolve_task)
            try:
                self._check_scene_configuration(key, getattr(scene, key))
            except SceneError as exc:
                if not swapped:
                    raise
                raise SceneError(f"scene '{scene.name}' is set up for {spec.model}; its {key} is not a configuration "
                                 f"of {model}'s group '{self.group}' ({exc.field}: {exc.message})",
                                 source=scene.source, field="robot.model", value=model) from None

    # --- construction -------------------------------------------------------------------------

    @staticmethod
    def _entry(model: str, source: str) -> RobotEntry:
        """The catalogue entry of a named robot, or an entry for a URDF file (relative to the scene file)."""
        path = Path(model).expanduser()
        if path.suffix.lower() == ".urdf" or path.is_absolute() or "/" in model:
            full = path if path.is_absolute() else Path(source).parent / path
            if not full.is_file() and path.is_file():
                full = path
            if not full.is_file():
                raise SceneError("URDF file not found", source=source, field="robot.model", value=model)
            return RobotEntry(full.resolve(), None, (full.parent, full.parent.parent))
        return named_robot(model, source)

    def _load(self, entry: RobotEntry, source: str, model_name: str) -> None:
        """Parse the URDF (once per process: later robots of the same files copy the models) and choose the
        collision pairs checked."""
        try:
            self._file_key = _file_key(entry)
        except OSError as exc:
            raise SceneError(f"cannot load the URDF {entry.urdf}: {exc}", source=source, field="robot.model",
                             value=model_name) from None
        parsed = _parsed.get(self._file_key, lambda: self._parse(entry, source, model_name))
        # copies: a robot moves its own base (_place_base) and keeps its own data; the coal shapes are shared, and
        # nothing changes them
        self.model, self.geometry = parsed[0].copy(), parsed[1].copy()
        self.data = self.model.createData()
        self.geometry_data = pin.GeometryData(self.geometry)

    def _parse(self, entry: RobotEntry, source: str, model_name: str) -> tuple:
        """The URDF's model and collision model, with the collision pairs checked: the SRDF's, or every pair but
        adjacent links'."""
        try:
            self.model = pin.buildModelFromUrdf(str(entry.urdf))
            self.geometry = pin.buildGeomFromUrdf(self.model, str(entry.urdf), pin.GeometryType.COLLISION,
                                                  package_dirs=[str(p) for p in entry.package_dirs])
        except (ValueError, RuntimeError, OSError) as exc:
            raise SceneError(f"cannot load the URDF {entry.urdf}: {exc}", source=source, field="robot.model",
                             value=model_name) from None
        self.geometry.addAllCollisionPairs()
        if entry.srdf is not None:
            pin.removeCollisionPairs(self.model, self.geometry, str(entry.srdf))
        else:
            self._remove_adjacent_pairs()
        return self.model, self.geometry

    def _place_base(self, position, orientation) -> None:
        """Move the robot's base to a world placement (the scene task's ``base``): every joint, frame and geometry
        attached to the world is placed through it, so kinematics, body points and collisions all see it."""
        base = pin.SE3(pin.Quaternion(float(orientation[3]), float(orientation[0]), float(orientation[1]),
                                      float(orientation[2])).normalized().matrix(), np.asarray(position, np.float64))
        model = self.model
        for j in range(1, model.njoints):
            if model.parents[j] == 0:
                model.jointPlacements[j] = base * model.jointPlacements[j]
        for k in range(len(model.frames)):
            frame = model.frames[k]
            if frame.parentJoint == 0 and frame.name != "universe":
                frame.placement = base * frame.placement
                model.frames[k] = frame
        for k in range(len(self.geometry.geometryObjects)):
            geom = self.geometry.geometryObjects[k]
            if geom.parentJoint == 0:
                geom.placement = base * geom.placement
        self.data = model.createData()
        self.geometry_data = pin.GeometryData(self.geometry)

    def _remove_adjacent_pairs(self) -> None:
        """Without an SRDF, allow contact between geometries of the same or adjacent (parent/child) joints."""
        parents = self.model.parents
        for k in reversed(range(len(self.geometry.collisionPairs))):
            pair = self.geometry.collisionPairs[k]
            a = self.geometry.geometryObjects[pair.first].parentJoint
            b = self.geometry.geometryObjects[pair.second].parentJoint
            if a == b or parents[a] == b or parents[b] == a:
                self.geometry.removeCollisionPair(pair)

    def _choose_group(self, entry: RobotEntry, group: str, from_option: bool) -> None:
        model = self.model
        single = [j for j in range(1, model.njoints) if model.joints[j].nv == 1]
        self._single = single
        names = [model.names[j] for j in single]
        self.groups = {"all": tuple(names), **entry.groups}
        where = dict(source="<options>", field="robot.options.group") if from_option else dict(
            source=self._source, field="robot.group")
        if group not in self.groups:
            raise ConfigError(f"unknown joint group for {self.model_name} (groups: {', '.join(sorted(self.groups))})",
                              value=group, **where)
        missing = [n for n in self.groups[group] if n not in names]
        if missing:
            raise ConfigError("the group names joints the URDF does not have", value=missing, **where)
        self.group = group
        self.joint_names = list(self.groups[group])
        self.joint_ids = np.array([int(model.getJointId(n)) for n in self.joint_names], dtype=np.int64)
        self.idx_q = np.array([model.joints[int(j)].idx_q for j in self.joint_ids], dtype=np.int64)
        self.idx_v = np.array([model.joints[int(j)].idx_v for j in self.joint_ids], dtype=np.int64)
        #: joints with an unbounded angle (pinocchio stores them as (cos, sin))
        self.continuous = np.array([model.joints[int(j)].nq == 2 for j in self.joint_ids], dtype=bool)

    def _set_limits(self, entry: RobotEntry) -> None:
        model, o = self.model, self.options
        lower = model.lowerPositionLimit[self.idx_q].astype(np.float64)
        upper = model.upperPositionLimit[self.idx_q].astype(np.float64)
        unbounded = self.continuous | ~np.isfinite(lower) | ~np.isfinite(upper) | (upper <= lower)
        self.lower = np.where(unbounded, -o.continuous_range, lower)
        self.upper = np.where(unbounded, o.continuous_range, upper)
        velocity = model.velocityLimit[self.idx_v].astype(np.float64)
        self.velocity_limits = np.array([entry.velocity_limits.get(n, v) for n, v in zip(self.joint_names, velocity)])
        if np.any(~np.isfinite(self.velocity_limits)) or np.any(self.velocity_limits <= 0):
            raise SceneError("the URDF's velocity limits of the group must be positive", source=self._source,
                             field="robot.model", value=dict(zip(self.joint_names, self.velocity_limits.tolist())))
        self.acceleration_limits = self._explicit("acceleration_limits", o.acceleration_limits,
                                                  self.velocity_limits * o.acceleration_factor)
        self.jerk_limits = self._explicit("jerk_limits", o.jerk_limits, self.acceleration_limits * o.jerk_factor)

    def _explicit(self, name: str, values: tuple[float, ...], derived: np.ndarray) -> np.ndarray:
        if not values:
            return derived
        arr = np.asarray(values, dtype=np.float64)
        if arr.shape != derived.shape:
            raise ConfigError(f"needs one value per joint of the group ({len(derived)})", source="<options>",
                              field=f"robot.options.{name}", value=list(values))
        if np.any(~np.isfinite(arr)) or np.any(arr <= 0):
            raise ConfigError("limits must be positive and finite", source="<options>",
                              field=f"robot.options.{name}", value=list(values))
        return arr

    def _posture(self) -> np.ndarray:
        """The full pinocchio configuration (``model.nq``) holding the joints outside the group."""
        model = self.model
        base = pin.neutral(model)
        posture = dict(self.options.posture or {})
        known = {model.names[j] for j in self._single}
        unknown = sorted(set(posture) - known)
        if unknown:
            raise ConfigError("posture names joints the model does not have", source="<options>",
                              field="robot.options.posture", value=unknown)
        for name, value in posture.items():
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError("posture values must be finite numbers (rad or m)", source="<options>",
                                  field=f"robot.options.posture.{name}", value=value)
        for j in self._single:
            joint = model.joints[j]
            lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
            value = float(posture.get(model.names[j], 0.0))
            if model.names[j] not in posture and joint.nq == 1 and np.isfinite(lo) and np.isfinite(hi) \
                    and not lo <= 0.0 <= hi:
                value = 0.5 * (lo + hi)
            if joint.nq == 2:
                base[joint.idx_q], base[joint.idx_q + 1] = math.cos(value), math.sin(value)
            else:
                base[joint.idx_q] = value
        return base

    def moving_joints(self) -> set[int]:
        """Joint ids whose placement depends on the group's joints (the group's joints and their descendants)."""
        group = {int(j) for j in self.joint_ids}
        return {j for j in range(1, self.model.njoints) if group & {int(s) for s in self.model.supports[j]}}

    def _sample_body(self, spacing: float, material) -> None:
        moving = self.moving_joints() if self.options.body == "moving" else None
        key = (self._file_key, None if moving is None else tuple(sorted(int(j) for j in moving)), float(spacing))
        sampled = _sampled.get(key, lambda: self._sample_geometries(spacing, moving))
        #: body points in their joint's frame (m), and the joint that carries each
        self.local_points, self.point_joint = sampled[0].copy(), sampled[1].copy()
        self._used, self._slot = np.unique(self.point_joint, return_inverse=True)
        self._selections: dict = {}                 # _select's memory: (shape, index bytes) -> (points, slots)
        self._used_support = self._support_mask(self._used)
        o = self.options
        deformability = material.deformability if o.deformability is None else o.deformability
        sensitivity = material.sensitivity if o.sensitivity is None else o.sensitivity
        self._materials = np.tile(np.array([deformability, sensitivity], dtype=np.float64),
                                  (len(self.local_points), 1))

    def _sample_geometries(self, spacing: float, moving) -> tuple[np.ndarray, np.ndarray]:
        """Points on the collision geometries of the joints ``moving`` (None: all), about ``spacing`` m apart, in
        their joint's frame ``(k, 3)``, and the joint carrying each ``(k,)``."""
        pts, joints = [], []
        for geom in self.geometry.geometryObjects:
            if moving is not None and geom.parentJoint not in moving:
                continue
            local = surface_points(geom.geometry, spacing)
            if len(local) == 0:
                continue
            placement = geom.placement      # geometry frame in its parent joint's frame
            pts.append(local @ np.asarray(placement.rotation).T + np.asarray(placement.translation))
            joints.append(np.full(len(local), geom.parentJoint, dtype=np.int64))
        if not pts:
            raise SceneError("the URDF has no collision geometry to sample body points from", source=self._source,
                             field="robot.model", value=self.model_name)
        return np.ascontiguousarray(np.concatenate(pts), dtype=np.float64), np.concatenate(joints)

    def _support_mask(self, joints) -> np.ndarray:
        """Float ``(len(joints), d)``: 1 where the group joint of the column moves the given joint."""
        mask = np.zeros((len(joints), len(self.joint_ids)))
        for r, j in enumerate(joints):
            support = set(int(s) for s in self.model.supports[int(j)])
            mask[r] = [float(int(g) in support) for g in self.joint_ids]
        return mask

    def _make_space(self, weights) -> RealVectorSpace:
        if weights is not None and np.asarray(weights).shape != (len(self.joint_names),):
            raise SceneError(f"needs one weight per joint of group '{self.group}' ({len(self.joint_names)})",
                             source=self._source, field="robot.weights", value=np.asarray(weights).tolist())
        return RealVectorSpace(self.lower, self.upper, weights)

    def _check_scene_configuration(self, key: str, q) -> None:
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (self._space.dim,):
            raise SceneError(f"needs one value per joint of group '{self.group}' ({self._space.dim}: "
                             f"{', '.join(self.joint_names)})", source=self._source, field=key, value=q.tolist())
        if not np.all(np.isfinite(q)):
            raise SceneError("must be finite", source=self._source, field=key, value=q.tolist())
        if not self._space.is_valid(q):
            bad = [n for n, v, lo, hi in zip(self.joint_names, q, self.lower, self.upper) if not lo <= v <= hi]
            raise SceneError(f"outside the joint limits at {', '.join(bad)}", source=self._source, field=key,
                             value=q.tolist())

    def _build_obstacles(self, scene) -> list[_Obstacle]:
        out = []
        for obj in scene.objects:
            s = obj.part.shape
            if s.kind == "box":
                geom = coal.Box(*np.asarray(s.size, dtype=np.float64))
            elif s.kind == "sphere":
                geom = coal.Sphere(float(s.radius))
            elif s.kind == "cylinder":
                geom = coal.Cylinder(float(s.radius), float(s.length))
            elif s.kind == "mesh":
                tris = np.asarray(s.triangles, dtype=np.float64)
                geom = coal.BVHModelOBBRSS()
                geom.beginModel(len(tris), 3 * len(tris))
                geom.addVertices(np.ascontiguousarray(tris.reshape(-1, 3)))
                geom.addTriangles(np.arange(3 * len(tris), dtype=np.int64).reshape(-1, 3))
                geom.endModel()
            else:                       # voxel arrays have no coal counterpart here
                continue
            pose = obj.part.pose
            out.append(_Obstacle(obj.name, geom, coal.Transform3s(pose.rotation, pose.position)))
        return out

    # --- configurations -----------------------------------------------------------------------

    @property
    def space(self) -> RealVectorSpace:
        """The group's joint space: joint limits as bounds, the scene's per-joint weights (else 1)."""
        return self._space

    def _batch(self, q, field: str = "configurations") -> np.ndarray:
        arr, _ = check_batch(q, self._space, field)
        return arr

    def full_configurations(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio configurations ``(n, model.nq)`` of group configurations ``(n, d)`` (or ``(d,)``)."""
        q = self._batch(q)
        full = np.repeat(self.base_configuration[None], len(q), axis=0)
        plain = ~self.continuous
        full[:, self.idx_q[plain]] = q[:, plain]
        full[:, self.idx_q[self.continuous]] = np.cos(q[:, self.continuous])
        full[:, self.idx_q[self.continuous] + 1] = np.sin(q[:, self.continuous])
        return full

    def distance(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Weighted joint-space distance ``|| w * (a - b) ||`` (broadcast), via :attr:`space`."""
        return self._space.distance(self._batch(a, "a"), self._batch(b, "b"))

    @property
    def postures(self) -> dict[str, np.ndarray]:
        """The robot's named configurations of the planned group (``pr2``: ``tuck``; ``baxter``: ``neutral``;
        ``iiwa``: ``zero``), by name, each ``(d,)``."""
        return {name: np.array(values, dtype=np.float64)
                for name, values in self.entry.postures.get(self.group, {}).items()}

    # --- RobotModel ---------------------------------------------------------------------------

    def urdf_description(self) -> UrdfDescription:
        """The URDF, the group's joints in configuration order, the posture of every other joint, and the base's
        placement in the world (the scene's task's, else the origin)."""
        model, base = self.model, self.base_configuration
        group = set(self.joint_names)
        posture = {}
        for j in self._single:
            name = model.names[j]
            if name in group:
                continue
            joint = model.joints[j]
            value = base[joint.idx_q]
            if joint.nq == 2:
                value = math.atan2(base[joint.idx_q + 1], base[joint.idx_q])
            posture[name] = float(value)
        effort = model.effortLimit[self.idx_v].astype(np.float64)
        return UrdfDescription(urdf=self.entry.urdf, package_dirs=tuple(self.entry.package_dirs),
                               joint_names=tuple(self.joint_names), posture=posture,
                               velocity_limits=self.velocity_limits.copy(), effort_limits=effort,
                               **self._base_placement())

    def _base_placement(self) -> dict:
        if self.task is None or not self.task.placed:
            return {}
        return {"base_position": tuple(float(v) for v in self.task.base_position),
                "base_orientation": tuple(float(v) for v in self.task.base_orientation)}

    def point_materials(self) -> np.ndarray:
        """``(m, 2)``: deformability and sensitivity of each body point."""
        return self._materials

    def _select(self, indices):
        """The body points ``indices`` select, in their joint's frame, and their joints' slots (read-only).

        Callers ask for the same selection again and again (a simulator's surface points on every microstep: five
        selections per control period of a peer's arm, which copied 48 us each), so the last few are remembered,
        keyed by the indices' values."""
        if indices is None:
            return self.local_points, self._slot
        indices = np.asarray(indices, dtype=np.int64)
        key = (indices.shape, indices.tobytes())
        selected = self._selections.get(key)
        if selected is not None:
            return selected
        if indices.ndim != 1 or (indices.size and (indices.min() < -len(self.local_points)
                                                   or indices.max() >= len(self.local_points))):
            raise DimensionError(f"point indices must be a 1-d array within [0, {len(self.local_points)})",
                                 field="indices", value=indices.tolist() if indices.size < 50 else indices.shape)
        selected = (self.local_points[indices], self._slot[indices])
        for array in selected:
            array.flags.writeable = False
        if len(self._selections) >= SELECTIONS_KEPT:
            self._selections.clear()
        self._selections[key] = selected
        return selected

    def _placements(self, joints) -> tuple[np.ndarray, np.ndarray]:
        """Rotations ``(u, 3, 3)`` and origins ``(u, 3)`` of joints after a kinematics call."""
        oMi = self.data.oMi
        rot = np.array([oMi[int(j)].rotation for j in joints])
        pos = np.array([oMi[int(j)].translation for j in joints])
        return rot, pos

    def body_points(self, q, indices=None):
        """World positions ``(n, m, 3)`` (m) of the body points at configurations ``(n, d)`` (rad or m).

        ``indices`` (optional, ``(m,)``) selects body points.  Batched over the configurations by
        :class:`~pliant_pinocchio.kinematics.JointChain` (the per-configuration pinocchio loop,
        :meth:`_body_points_reference`, when the chain has a joint it does not support).
        """
        if self._chain is None:
            return self._body_points_reference(q, indices)
        q = self._batch(q)
        local, slot = self._select(indices)
        return self._chain.points(q, local, slot)

    def point_jacobians(self, q, indices=None):
        """``(n, m, 3, d)``: d(point position)/d(joint value) (m/rad or m/m) at configurations ``(n, d)``.

        Zero in the columns of group joints that do not move the point's joint.  Batched like
        :meth:`body_points` (fallback :meth:`_point_jacobians_reference`).
        """
        if self._chain is None:
            return self._point_jacobians_reference(q, indices)
        q = self._batch(q)
        local, slot = self._select(indices)
        return self._chain.jacobians(q, local, slot, self._used_support)

    def _body_points_reference(self, q, indices=None):
        """:meth:`body_points` with pinocchio's ``forwardKinematics`` per configuration (fallback, tests)."""
        full = self.full_configurations(q)
        local, slot = self._select(indices)
        out = np.empty((len(full), len(local), 3))
        for a, x in enumerate(full):
            pin.forwardKinematics(self.model, self.data, x)
            rot, pos = self._placements(self._used)
            out[a] = np.einsum("mij,mj->mi", rot[slot], local) + pos[slot]
        return out

    def _point_jacobians_reference(self, q, indices=None):
        """:meth:`point_jacobians` with pinocchio's ``computeJointJacobians`` per configuration (fallback, tests)."""
        full = self.full_configurations(q)
        local, slot = self._select(indices)
        mask = self._used_support[slot][:, None, :]                       # (m, 1, d)
        out = np.empty((len(full), len(local), 3, len(self.joint_ids)))
        for a, x in enumerate(full):
            pin.computeJointJacobians(self.model, self.data, x)           # also the forward kinematics
            rot, pos = self._placements(self._used)
            world = np.einsum("mij,mj->mi", rot[slot], local) + pos[slot]
            out[a] = self._point_columns(world) * mask
        return out

    def _point_columns(self, world: np.ndarray) -> np.ndarray:
        """``(k, 3, d)``: ``v_O + w x p`` of every group column at world points ``(k, 3)`` (after Jacobians)."""
        jac = self.data.J[:, self.idx_v]                                  # (6, d) world-frame twists
        lin, ang = jac[:3], jac[3:]
        # (w x p)_i for each column: cross of ang (d, 3) with p (k, 1, 3) -> (k, d, 3)
        cross = np.cross(ang.T[None, :, :], world[:, None, :])
        return lin[None] + cross.transpose(0, 2, 1)

    # --- frames -------------------------------------------------------------------------------

    def _frame(self, frame: str) -> int:
        if not isinstance(frame, str) or not self.model.existFrame(frame):
            raise ConfigError("no link, joint or frame of that name in the model", field="frame", value=frame)
        return int(self.model.getFrameId(frame))

    def frame_placements(self, q: np.ndarray, frame: str) -> np.ndarray:
        """Homogeneous world placements ``(n, 4, 4)`` (m) of a named link / joint frame at configurations ``(n, d)``."""
        fid = self._frame(frame)
        full = self.full_configurations(q)
        out = np.empty((len(full), 4, 4))
        for a, x in enumerate(full):
            pin.forwardKinematics(self.model, self.data, x)
            out[a] = pin.updateFramePlacement(self.model, self.data, fid).homogeneous
        return out

    def frame_position(self, q: np.ndarray, frame: str, offset=(0.0, 0.0, 0.0)) -> np.ndarray:
        """World position ``(n, 3)`` (m) of the point at ``offset`` (m, frame coordinates) in a named frame."""
        placement = self.frame_placements(q, frame)
        return placement[:, :3, :3] @ np.asarray(offset, dtype=np.float64) + placement[:, :3, 3]

    def frame_jacobians(self, q: np.ndarray, frame: str, offset=(0.0, 0.0, 0.0)) -> np.ndarray:
        """``(n, 3, d)``: linear Jacobian (m/rad) of the point at ``offset`` (m, frame coordinates) in ``frame``."""
        fid = self._frame(frame)
        offset = np.asarray(offset, dtype=np.float64)
        if offset.shape != (3,) or not np.all(np.isfinite(offset)):
            raise DimensionError("offset must be 3 finite numbers (m)", field="offset", value=offset.tolist())
        joint = int(self.model.frames[fid].parentJoint)
        mask = self._support_mask([joint])                                 # (1, d)
        full = self.full_configurations(q)
        out = np.empty((len(full), 3, len(self.joint_ids)))
        for a, x in enumerate(full):
            pin.computeJointJacobians(self.model, self.data, x)
            placement = pin.updateFramePlacement(self.model, self.data, fid)
            world = placement.rotation @ offset + placement.translation
            out[a] = self._point_columns(world[None])[0] * mask
        return out

    def inverse_kinematics(self, frame: str, position, orientation=None, *, rng: np.random.Generator,
                           solutions: int = 4, position_tolerance: float = 1e-3,
                           orientation_tolerance: float = 1e-2, valid=None) -> np.ndarray:
        """Diverse joint configurations placing ``frame`` at a pose (:func:`pliant_pinocchio.ik.solve_ik`)."""
        from pliant_pinocchio.ik import solve_ik

        return solve_ik(self, frame, position, orientation, rng=rng, solutions=solutions,
                        position_tolerance=position_tolerance, orientation_tolerance=orientation_tolerance,
                        valid=valid).solutions

    # --- collision ----------------------------------------------------------------------------

    def self_collision(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: whether any pair of the robot's collision geometries not allowed by the SRDF collides."""
        full = self.full_configurations(q)
        return np.array([bool(self._colliding_pairs(x, first_only=True)) for x in full], dtype=bool)

    def _colliding_pairs(self, full: np.ndarray, first_only: bool = False) -> list[int]:
        """Indices of the non-allowed pairs in contact at the pinocchio configuration ``full`` (their coal results
        are in ``self._pair_data.collisionResults``).

        A sweep-and-prune manager (coal's SSaP, through pinocchio) over the geometries' bounding boxes collects
        the pairs whose boxes overlap; only those get the narrow phase.  Baxter's right arm: 15 us per
        configuration and ~10 candidates of 547 pairs, against 110 us for every pair's narrow phase plus
        150 us to read every pair's result back in Python (tested equal to the full pass).
        """
        if self._broad_phase is None:
            self._pair_data = pin.GeometryData(self.geometry)
            self._broad_phase = pin.BroadPhaseManager_SSaPCollisionManager(self.model, self.geometry, self._pair_data)
            self._candidates = pin.CollisionCallBackCollect(self.geometry, self._pair_data)
        self._candidates.init()
        pin.computeCollisions(self.model, self.data, self._broad_phase, self._candidates, full)
        out = []
        for k in self._candidates.pair_indexes:
            if pin.computeCollision(self.geometry, self._pair_data, int(k)):
                out.append(int(k))
                if first_only:
                    break
        return out

    def self_contacts(self, q: np.ndarray) -> SelfContacts:
        """Contacts between non-allowed pairs of the robot's geometries at one configuration ``(d,)``.

        From coal's collision results: nearest points on both geometries, the normal from the first
        toward the second, the penetration depth; masses are pinocchio's subtree masses of the two
        joints (the link and everything after it, as thesis app. B prescribes).
        """
        full = self.full_configurations(np.atleast_2d(q))[0]
        d = len(self.joint_ids)
        pairs = sorted(self._colliding_pairs(full))
        if not pairs:
            empty = np.zeros((0, 3))
            return SelfContacts(empty, empty, empty, np.zeros(0), np.zeros(0), np.zeros(0), np.zeros((0, 3, d)),
                                np.zeros((0, 3, d)))
        rows = []
        for k in pairs:
            pair = self.geometry.collisionPairs[k]
            contact = self._pair_data.collisionResults[k].getContact(0)
            rows.append((self.geometry.geometryObjects[pair.first].parentJoint,
                         self.geometry.geometryObjects[pair.second].parentJoint,
                         np.array(contact.getNearestPoint1()), np.array(contact.getNearestPoint2()),
                         np.array(contact.normal), max(0.0, -float(contact.penetration_depth))))
        pin.computeJointJacobians(self.model, self.data, full)
        ja, jb = [r[0] for r in rows], [r[1] for r in rows]
        pa, pb = np.array([r[2] for r in rows]), np.array([r[3] for r in rows])
        jac_a = self._point_columns(pa) * self._joint_support[ja][:, None, :]
        jac_b = self._point_columns(pb) * self._joint_support[jb][:, None, :]
        normal = np.array([r[4] for r in rows])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        return SelfContacts(pa, pb, normal, np.array([r[5] for r in rows]), self._subtree_mass[ja],
                            self._subtree_mass[jb], jac_a, jac_b)

    def environment_distance(self, q: np.ndarray) -> np.ndarray:
        """Smallest distance (m) between the robot's collision geometry and the scene's objects, ``(n,)``.

        Boxes, spheres, cylinders and meshes count (cut-outs are ignored, so a part with cut-outs is
        treated as solid; voxel-array objects are skipped).  Negative or zero where they overlap
        (then coal's penetration estimate); ``inf`` when the scene has no such object.
        """
        full = self.full_configurations(q)
        out = np.full(len(full), np.inf)
        if not self._obstacles:
            return out
        request, result = coal.DistanceRequest(), coal.DistanceResult()
        geoms = self.geometry.geometryObjects
        for a, x in enumerate(full):
            pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data, x)
            best = np.inf
            for k, geom in enumerate(geoms):
                placement = self.geometry_data.oMg[k]
                tf = coal.Transform3s(placement.rotation, placement.translation)
                for obstacle in self._obstacles:
                    result.clear()
                    best = min(best, coal.distance(geom.geometry, tf, obstacle.geometry, obstacle.transform,
                                                   request, result))
            out[a] = best
        return out

    def collisions(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: the robot's collision model collides with itself, two non-allowed geometries (coal, after
        the SRDF's allowed pairs) overlapping by more than :attr:`self_tolerance` (a quarter voxel), or by an
        unknown depth (coal reports 0 for mesh pairs).

        The core's validity checker (:mod:`pliant.planning.validity`) calls it after checking the body points --
        sampled on every collision geometry's surface at the scene resolution -- against the scene's voxels, which
        is how collisions with the scene are checked: coal's exact distance to the scene's shapes costs 30-120 ms
        per configuration (iiwa, Baxter, PR2) and sees an object with cut-outs as solid (baxter-reach's goal is
        0.084 m "into" the free opening of its shelf).
        """
        full = self.full_configurations(q)
        out = np.zeros(len(full), dtype=bool)
        for a, x in enumerate(full):
            for k in self._colliding_pairs(x):
                result = self._pair_data.collisionResults[k]
                depth = max((abs(float(result.getContact(c).penetration_depth)) for c in range(result.numContacts())),
                            default=0.0)
                if depth == 0.0 or depth > self.self_tolerance:
                    out[a] = True
                    break
        return out

    def in_collision(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: self-collision, or touching / penetrating a scene object (distance <= 0)."""
        return self.self_collision(q) | (self.environment_distance(q) <= 0.0)
