"""URDF robots through pinocchio (kinematics) and coal (collision geometry).

Configurations are the values of one joint group (rad for revolute and continuous joints, m for
prismatic ones); every other joint stays at a fixed posture.  The body is represented by points
sampled on every collision geometry's surface at the scene resolution (thesis 3.2.1), each attached
to its joint, so that the voxel cost model and the kinematic simulator can use any URDF robot.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pliant.errors import DimensionError, PlanningError, PluginError
from pliant.interfaces import RobotModel, check_batch
from pliant.options import option
from pliant.spaces import RealVectorSpace

from pliant_pinocchio.catalog import RobotEntry, named_robot
from pliant_pinocchio.sampling import surface_points


@dataclass(frozen=True)
class PinocchioOptions:
    """Options of :class:`PinocchioRobot`."""

    group: str | None = option(None, "joint group to plan for (default: the scene's robot.group, else 'all')")
    resolution: float | None = option(None, "spacing of body surface points (m); default the scene resolution",
                                      minimum=1e-4)
    posture: tuple[float, ...] = option((), "values of all single-DoF joints in model order for the joints "
                                        "outside the group (default: zero, or the limits' middle if 0 is out)")
    acceleration_factor: float = option(4.0, "acceleration limits = this (1/s) x velocity limits; vendors do "
                                        "not publish them", minimum=1e-6)
    jerk_factor: float = option(20.0, "jerk limits = this (1/s) x acceleration limits", minimum=1e-6)
    body: str = option("moving", "which links carry body points: moving (those the group moves; static links "
                       "can neither cause nor resolve a new contact) or all", choices=("moving", "all"))
    deformability: float = option(0.0, "deformability of the robot's points (thesis eq. 3.1)", minimum=0.0,
                                  maximum=1.0)
    sensitivity: float = option(1.0, "sensitivity of the robot's points (thesis eq. 3.1)", minimum=0.0)


class PinocchioRobot(RobotModel):
    """A URDF robot (``pr2``, ``baxter``, ``iiwa`` or a ``.urdf`` path) with pinocchio kinematics.

    Provides, batched over configurations ``(n, d)``: body points ``(n, m, 3)`` and their Jacobians
    ``(n, m, 3, d)`` (from the joint Jacobians in the world-aligned frame), self-collision through
    coal with the SRDF's allowed pairs removed, distance to the scene's primitive objects, joint
    position / velocity / acceleration / jerk limits.
    """

    Options = PinocchioOptions
    example_scene = "iiwa-shelf"

    def bind(self, context) -> None:
        super().bind(context)
        import pinocchio as pin

        self.pin = pin
        scene = self.require("scene")
        spec = scene.robot
        if spec.kind != "urdf":
            raise PlanningError("the pinocchio robot needs a scene whose [robot] kind is 'urdf'", source=scene.source,
                                field="robot.kind", value=spec.kind)
        entry = self._entry(spec.model, scene)
        self.model_name = spec.model
        try:
            self.model = pin.buildModelFromUrdf(str(entry.urdf))
            self.geometry = pin.buildGeomFromUrdf(self.model, str(entry.urdf), pin.GeometryType.COLLISION,
                                                  package_dirs=[str(p) for p in entry.package_dirs])
        except (ValueError, RuntimeError) as exc:
            raise PluginError(f"cannot load the URDF: {exc}", source=scene.source, field="robot.model",
                              value=str(entry.urdf)) from None
        self.geometry.addAllCollisionPairs()
        if entry.srdf is not None:
            pin.removeCollisionPairs(self.model, self.geometry, str(entry.srdf))
        else:
            self._remove_adjacent_pairs()
        self.data = self.model.createData()
        self.geometry_data = pin.GeometryData(self.geometry)
        self._joints(entry, self.options.group or spec.group or "all", scene.source)
        self._sample_body(self.options.resolution or scene.resolution)
        self._space = RealVectorSpace(self.lower, self.upper, spec.weights)

    # --- construction -------------------------------------------------------------------------

    @staticmethod
    def _entry(model: str, scene) -> RobotEntry:
        path = Path(model)
        if path.suffix == ".urdf":
            full = path if path.is_absolute() else Path(scene.source).parent / path
            if not full.is_file():
                raise PluginError("URDF file not found", source=scene.source, field="robot.model", value=model)
            return RobotEntry(full, None, (full.parent, full.parent.parent))
        return named_robot(model)

    def _remove_adjacent_pairs(self) -> None:
        """Without an SRDF, allow contact between geometries of the same or adjacent (parent/child) joints."""
        parents = self.model.parents
        for k in reversed(range(len(self.geometry.collisionPairs))):
            pair = self.geometry.collisionPairs[k]
            a = self.geometry.geometryObjects[pair.first].parentJoint
            b = self.geometry.geometryObjects[pair.second].parentJoint
            if a == b or parents[a] == b or parents[b] == a:
                self.geometry.removeCollisionPair(pair)

    def _joints(self, entry: RobotEntry, group: str, source: str) -> None:
        model = self.model
        single = [j for j in range(1, model.njoints) if model.joints[j].nv == 1]
        names = [model.names[j] for j in single]
        groups = {"all": tuple(names), **entry.groups}
        if group not in groups:
            raise PluginError(f"unknown joint group (groups: {', '.join(sorted(groups))})", source=source,
                              field="robot.group", value=group)
        missing = [n for n in groups[group] if n not in names]
        if missing:
            raise PluginError("the group names joints the URDF does not have", source=source, field="robot.group",
                              value=missing)
        self.group = group
        self.joint_names = list(groups[group])
        self.joint_ids = [int(model.getJointId(n)) for n in self.joint_names]
        self.idx_q = np.array([model.joints[j].idx_q for j in self.joint_ids])
        self.idx_v = np.array([model.joints[j].idx_v for j in self.joint_ids])
        self.continuous = np.array([model.joints[j].nq == 2 for j in self.joint_ids])
        lower = np.array([model.lowerPositionLimit[i] for i in self.idx_q])
        upper = np.array([model.upperPositionLimit[i] for i in self.idx_q])
        unbounded = self.continuous | ~np.isfinite(lower) | ~np.isfinite(upper) | (upper <= lower)
        self.lower = np.where(unbounded, -np.pi, lower)
        self.upper = np.where(unbounded, np.pi, upper)
        velocity = np.array([model.velocityLimit[i] for i in self.idx_v])
        velocity = np.array([entry.velocity_limits.get(n, v) for n, v in zip(self.joint_names, velocity)])
        self.velocity_limits = velocity
        self.acceleration_limits = velocity * self.options.acceleration_factor
        self.jerk_limits = self.acceleration_limits * self.options.jerk_factor
        # the posture of the other joints
        base = self.pin.neutral(model)
        posture = self.options.posture
        if posture and len(posture) != len(single):
            raise DimensionError(f"posture needs one value per single-DoF joint ({len(single)})",
                                 field="robot.posture", value=list(posture))
        for k, j in enumerate(single):
            joint = model.joints[j]
            lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
            value = posture[k] if posture else 0.0
            if not posture and joint.nq == 1 and np.isfinite(lo) and np.isfinite(hi) and not lo <= 0.0 <= hi:
                value = 0.5 * (lo + hi)
            self._set(base, joint.idx_q, joint.nq == 2, value)
        self.base_configuration = base

    @staticmethod
    def _set(full: np.ndarray, idx: int, continuous: bool, value: float) -> None:
        if continuous:
            full[idx], full[idx + 1] = np.cos(value), np.sin(value)
        else:
            full[idx] = value

    def moving_joints(self) -> set[int]:
        """Joint ids whose placement depends on the group's joints (the group's joints and their descendants)."""
        moving = set()
        for j in range(1, self.model.njoints):
            k = j
            while k > 0:
                if k in self.joint_ids:
                    moving.add(j)
                    break
                k = self.model.parents[k]
        return moving

    def _sample_body(self, spacing: float) -> None:
        pts, joints = [], []
        moving = self.moving_joints() if self.options.body == "moving" else None
        for geom in self.geometry.geometryObjects:
            if moving is not None and geom.parentJoint not in moving:
                continue
            local = surface_points(geom.geometry, spacing)
            if len(local) == 0:
                continue
            placement = geom.placement
            pts.append(local @ np.asarray(placement.rotation).T + np.asarray(placement.translation))
            joints.append(np.full(len(local), geom.parentJoint))
        self.local_points = np.concatenate(pts)
        self.point_joint = np.concatenate(joints).astype(np.int64)
        self._materials = np.tile([self.options.deformability, self.options.sensitivity], (len(self.local_points), 1))

    # --- RobotModel ---------------------------------------------------------------------------

    @property
    def space(self):
        return self._space

    def point_materials(self):
        return self._materials

    def full_configuration(self, q: np.ndarray) -> np.ndarray:
        """The pinocchio configuration (``model.nq``) of one group configuration ``(d,)``."""
        full = self.base_configuration.copy()
        for k in range(len(q)):
            self._set(full, self.idx_q[k], self.continuous[k], q[k])
        return full

    def _placements(self, full: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.pin.forwardKinematics(self.model, self.data, full)
        rot = np.array([self.data.oMi[j].rotation for j in range(self.model.njoints)])
        pos = np.array([self.data.oMi[j].translation for j in range(self.model.njoints)])
        return rot, pos

    def _select(self, indices):
        if indices is None:
            return self.local_points, self.point_joint
        return self.local_points[indices], self.point_joint[indices]

    def body_points(self, q, indices=None):
        q, _ = check_batch(q, self._space)
        local, joint = self._select(indices)
        out = np.empty((len(q), len(local), 3))
        for a, x in enumerate(q):
            rot, pos = self._placements(self.full_configuration(x))
            out[a] = np.einsum("mij,mj->mi", rot[joint], local) + pos[joint]
        return out

    def point_jacobians(self, q, indices=None):
        q, _ = check_batch(q, self._space)
        pin = self.pin
        local, joint = self._select(indices)
        used = np.unique(joint)
        out = np.empty((len(q), len(local), 3, len(self.joint_ids)))
        for a, x in enumerate(q):
            full = self.full_configuration(x)
            pin.computeJointJacobians(self.model, self.data, full)
            rot = np.array([self.data.oMi[j].rotation for j in range(self.model.njoints)])
            origin = np.array([self.data.oMi[j].translation for j in range(self.model.njoints)])
            lin = np.zeros((self.model.njoints, 3, len(self.joint_ids)))
            ang = np.zeros_like(lin)
            for j in used:
                jac = pin.getJointJacobian(self.model, self.data, int(j), pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
                lin[j] = jac[:3, self.idx_v]
                ang[j] = jac[3:, self.idx_v]
            world = np.einsum("mij,mj->mi", rot[joint], local) + origin[joint]
            r = world - origin[joint]
            # v_p = v_o + w x r for every joint column
            out[a] = lin[joint] + np.cross(np.swapaxes(ang[joint], 1, 2), r[:, None, :]).swapaxes(1, 2)
        return out

    # --- extras -------------------------------------------------------------------------------

    def frame_position(self, q: np.ndarray, frame: str) -> np.ndarray:
        """World position ``(n, 3)`` of a named frame (link or joint) at configurations ``(n, d)``."""
        q, _ = check_batch(q, self._space)
        if not self.model.existFrame(frame):
            raise PluginError("no frame of that name in the model", field="frame", value=frame)
        fid = self.model.getFrameId(frame)
        out = np.empty((len(q), 3))
        for a, x in enumerate(q):
            self.pin.framesForwardKinematics(self.model, self.data, self.full_configuration(x))
            out[a] = self.data.oMf[fid].translation
        return out

    def jacobian_at(self, q: np.ndarray, frame: str, point: np.ndarray) -> np.ndarray:
        """``(3, d)`` Jacobian of a world point ``(3,)`` rigidly attached to ``frame``, at configuration ``(d,)``."""
        pin = self.pin
        q, _ = check_batch(q, self._space)
        if not self.model.existFrame(frame):
            raise PluginError("no frame of that name in the model", field="frame", value=frame)
        joint = int(self.model.frames[self.model.getFrameId(frame)].parentJoint)
        pin.computeJointJacobians(self.model, self.data, self.full_configuration(q[0]))
        jac = pin.getJointJacobian(self.model, self.data, joint, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        r = np.asarray(point, dtype=np.float64) - self.data.oMi[joint].translation
        lin, ang = jac[:3, self.idx_v], jac[3:, self.idx_v]
        return lin + np.cross(ang.T, r).T

    def self_collision(self, q: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: whether any non-allowed pair of the robot's geometries collides."""
        q, _ = check_batch(q, self._space)
        return np.array([self.pin.computeCollisions(self.model, self.data, self.geometry, self.geometry_data,
                                                    self.full_configuration(x), True) for x in q])

    def environment_distance(self, q: np.ndarray) -> np.ndarray:
        """Smallest distance (m) between the robot and the scene's box/sphere/cylinder objects, ``(n,)``."""
        import coal

        q, _ = check_batch(q, self._space)
        obstacles = self._obstacles(coal)
        out = np.full(len(q), np.inf)
        request, result = coal.DistanceRequest(), coal.DistanceResult()
        for a, x in enumerate(q):
            self.pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data,
                                              self.full_configuration(x))
            for k, geom in enumerate(self.geometry.geometryObjects):
                placement = self.geometry_data.oMg[k]
                tf = coal.Transform3s(placement.rotation, placement.translation)
                for shape, obstacle_tf in obstacles:
                    result.clear()
                    out[a] = min(out[a], coal.distance(geom.geometry, tf, shape, obstacle_tf, request, result))
        return out

    def _obstacles(self, coal):
        if getattr(self, "_obstacle_cache", None) is None:
            shapes = []
            for obj in self.require("scene").objects:
                s = obj.part.shape
                if s.kind == "box":
                    geom = coal.Box(*s.size)
                elif s.kind == "sphere":
                    geom = coal.Sphere(s.radius)
                elif s.kind == "cylinder":
                    geom = coal.Cylinder(s.radius, s.length)
                else:
                    continue
                shapes.append((geom, coal.Transform3s(obj.part.pose.rotation, obj.part.pose.position)))
            self._obstacle_cache = shapes
        return self._obstacle_cache
