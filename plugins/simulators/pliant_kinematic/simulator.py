"""The simulator ``kinematic``: batched, compliant, contact-resolving kinematic simulation (thesis app. B).

Each control step (``1 / frequency`` s) a P/PD law commands a tangent displacement toward the target
(eq. 8.1-8.2: ``dq = kp e + kd de``), limited to the velocity limits; actuation noise (eq. 8.3's
``F(dq)``, :mod:`pliant.execution.noise`) is drawn per microstep.  The step is cut into microsteps so that no
body point moves more than ``step_fraction`` of a voxel; after each, RESOLVECOLLISIONS (eq. 8.4-8.5)
pushes penetrating points out along the face they entered through (:mod:`.contact`) and maps the
push-outs to the configuration.  The default ``solver = "effort"`` takes the displacement of least
dissipation against the controller's force and torque limits, ``min ||dq_v|| + l ||dq_w||`` subject to
``n_i . J_i dq >= depth_i`` (:func:`.rigid_kernel.effort_correction`): eq. 8.5's least squares,
``dq = J^+ [dp_1; dp_2; ...]`` (``solver = "least-squares"``, or ``"qp"`` with first-order penetration
forbidden), explains push-outs at a corner by large rotations against the command, which a compliant
robot with a torque limit does not make when the lever arm is shorter than ``l = T / F``.  When the
corrections do not converge, the microstep is reverted and the particle's step is halved (adaptive
step scaling against oscillation); after ``max_halvings`` it stays where it is for the rest of the step.

All particles advance together (batch first); ``simulate`` reports, per particle, the final
configuration, whether it touched anything, whether it is stuck, and whether it reached the target.  For rigid
bodies one compiled call takes every particle through a whole control step (:func:`.rigid_kernel.fused_advance`,
the microsteps' noise drawn first in the same order); its broad phase only skips points that cannot collide, so the
particles are the same as the generic path's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pliant.api import (
    NOISE_MODELS,
    ActuationNoise,
    ControlLaw,
    DimensionError,
    SimulationBatch,
    Simulator,
    VoxelGrid,
    VoxelStartCheck,
    actuator_limits,
    angular_mask,
    check_batch,
    checkpoint,
    limit_velocity,
    option,
    report_ignored,
    spatial_runs,
)

from pliant_kinematic.contact import FACE_NORMALS, ContactModel
from pliant_kinematic.rigid_kernel import (
    KIND_R3,
    KIND_SE2,
    KIND_SE3,
    SEGMENT_POINTS,
    SEGMENT_RADIUS,
    SOLVE_EFFORT,
    SOLVE_LEAST_SQUARES,
    effort_correction,
    fused_advance,
    placed_points_hit,
)


@dataclass(frozen=True)
class KinematicOptions:
    """Options of :class:`KinematicSimulator` (defaults: the se2-maze / peg experiments of thesis ch. 5)."""

    frequency: float = option(10.0, "control frequency (Hz)", minimum=1e-6)
    kp: float = option(0.5, "proportional gain: fraction of the error commanded per control step (eq. 8.2)",
                       minimum=0.0)
    kd: float = option(0.0, "derivative gain on the change of the error per control step (eq. 8.2)", minimum=0.0)
    velocity_limit: float = option(1.0, "speed limit of translation (m/s), or of every joint (rad/s) for "
                                   "joint-space robots", minimum=1e-9)
    angular_velocity_limit: float = option(0.125, "rotation speed limit (rad/s) of SE(2)/SE(3) bodies", minimum=1e-9)
    joint_velocity_limits: tuple[float, ...] = option((), "per-actuator speed limits (rad/s or m/s); "
                                                      "overrides the two limits above when given")
    noise: str = option("none", "actuation noise model (pliant.execution.noise)", choices=NOISE_MODELS)
    noise_linear: float = option(0.0, "noise parameter of translational / joint actuators: bound (m/s) for "
                                 "'bounded', factor for 'proportional' and 'floor'", minimum=0.0)
    noise_angular: float = option(0.0, "noise parameter of rotational actuators (rad/s or factor)", minimum=0.0)
    step_fraction: float = option(0.5, "largest motion of any body point per microstep, in voxels", minimum=1e-3,
                                  maximum=1.0)
    max_corrections: int = option(8, "collision-resolution iterations per microstep", minimum=1)
    max_halvings: int = option(4, "adaptive step scaling: halvings before a particle gives up", minimum=0)
    clearance: float = option(0.01, "points are pushed this far past the surface, in voxels", minimum=0.0)
    solver: str = option("effort", "contact correction: effort (minimum dissipation against the controller's "
                         "force and torque limits), least-squares (eq. 8.5) or qp (eq. 8.5, no first-order "
                         "penetration)",
                         choices=("effort", "least-squares", "qp"))
    effort_length: float | None = option(None, "effort solver, rigid bodies: the controller's torque limit over "
                                         "its force limit (m), the lever arm beyond which contact turns the body; "
                                         "default: the body's radius of gyration about its reference point",
                                         minimum=1e-9)
    reach_tolerance: float | None = option(None, "distance to the target that counts as reached (space "
                                           "metric); default: the scene's goal tolerance, else one voxel")
    stuck_fraction: float = option(0.05, "stuck when a control step moves less than this fraction of what it "
                                   "commanded", minimum=0.0, maximum=1.0)
    fused_kernel: bool = option(True, "use the fused numba kernel for rigid bodies (effort and least-squares solvers)")
    self_collision: bool = option(True, "resolve contacts between a multi-link robot's own links (app. B's "
                                  "momentum model); robots without links ignore it")
    damping: float = option(1e-6, "Levenberg-Marquardt damping of eq. 8.5, relative to the mean diagonal of "
                            "J^T J (keeps redundant robots from moving in their null space)", minimum=0.0)
    start_tolerance: float = option(0.25, "deepest a start's surface points may lie inside an obstacle (or outside "
                                    "the grid), in voxels: contact, which the first step resolves; a deeper start is "
                                    "refused by reset, simulate and step", minimum=0.0, maximum=0.5)


class KinematicSimulator(Simulator):
    """Fast kinematic simulation with contact and compliance for batches of particles (thesis app. B).

    Works with any :class:`~pliant.interfaces.RobotModel` (body points and point Jacobians) in the
    scene's voxelised environment.  Multi-link robots that report self-contacts
    (:meth:`~pliant.interfaces.RobotModel.self_contacts`) also have their own links resolved apart, by app. B's
    momentum model (:meth:`_resolve_self_collision`).
    """

    Options = KinematicOptions
    example_scene = "se2-maze"

    def bind(self, context) -> None:
        super().bind(context)
        scene = self.require("scene")
        self.robot = self.require("robot")
        self.space = self.robot.space
        # no dynamics here: masses, friction, restitution, damping and the support do not apply (movable objects are
        # obstacles fixed at their scene poses; contacts push out without friction)
        report_ignored(scene.physics, "kinematic", (), "it has no dynamics: movable objects are fixed obstacles and "
                       "contacts are frictionless")
        self.grid = VoxelGrid.from_scene(scene)
        # an SE(2) body in a one-layer grid never leaves the layer: the grid's z faces are no walls to it
        self.contact = ContactModel(self.grid, planar=self.space.kind == "se2" and self.grid.shape[2] == 1)
        self.surface = self.robot.surface_indices()
        self._placed = (b"", None)      # the surface points last placed: (configurations' bytes, points)
        faces = self.robot.surface_faces()
        self.surface_faces = None if faces is None else np.ascontiguousarray(faces, dtype=np.bool_)
        if self.surface_faces is not None and self.surface_faces.shape != (len(self.surface), 6):
            raise DimensionError("surface_faces() must be (k, 6), one row per surface point",
                                 field="robot.surface_faces", value=list(self.surface_faces.shape))
        # the fused kernel takes each point's faces as bits (bit e: direction e leaves the body)
        self._face_bits = np.zeros(len(self.surface), dtype=np.int64) if self.surface_faces is None else \
            (self.surface_faces.astype(np.int64) << np.arange(6)).sum(axis=1)
        o = self.options
        self.angular = angular_mask(self.space)
        self.limits = actuator_limits(self.space, o.velocity_limit, o.angular_velocity_limit, o.joint_velocity_limits)
        scale = np.where(self.angular, o.noise_angular, o.noise_linear)
        self.noise = ActuationNoise(o.noise, scale, self.limits)
        placement = self.robot.rigid_placement(np.asarray(scene.start, dtype=np.float64)[None])
        self.per_actuator = bool(o.joint_velocity_limits) or placement is None
        kinds = {"rn": KIND_R3, "se2": KIND_SE2, "se3": KIND_SE3}
        #: a rigid body's placement convention for the compiled kernels (None: a robot with joints)
        self.placement_kind = kinds.get(self.space.kind) if placement is not None else None
        self.kernel_kind = self.placement_kind if o.fused_kernel and o.solver != "qp" else None
        self.reach_radius = None
        self.self_collision = o.self_collision and self.robot.self_contacts(
            np.asarray(scene.start, dtype=np.float64)) is not None
        if placement is not None:
            self.surface_local = np.ascontiguousarray(placement[2][self.surface])
            self.reach_radius = float(np.max(np.linalg.norm(self.surface_local, axis=1)))
            # the compiled kernels walk the surface in a spatial order, so that their broad phase's runs are long
            # (the peg's: 15 points instead of 3); the contact sums are still taken in the surface's own order
            self._walk, starts, centres, _, radii = spatial_runs(self.surface_local,
                                                                SEGMENT_RADIUS * self.grid.resolution, SEGMENT_POINTS)
            self._segments = (starts, centres, radii)
            self._walked_local = np.ascontiguousarray(self.surface_local[self._walk])
            self._walked_faces = np.ascontiguousarray(self._face_bits[self._walk])
            # the start check's broad phase: a planar grid's clearance ignores its z faces, which an SE(2) body's
            # points (their height fixed in the body) never cross unless they lie outside the layer from the start
            k, z = len(self.surface_local), self.surface_local[:, 2]
            layer = (self.grid.lower[2] <= z) & (z < self.grid.lower[2] + self.grid.shape[2] * self.grid.resolution)
            self._start_segments = self._segments if not self.contact.planar or layer.all() else (
                np.array([0, k], dtype=np.int64), np.zeros((1, 3)), np.array([np.inf]))
        self.effort_groups, self.effort_weights = self._effort_metric(placement)
        self.dt = 1.0 / o.frequency
        self.reach = o.reach_tolerance if o.reach_tolerance is not None else (
            scene.goal_tolerance if scene.goal_tolerance > 0 else scene.resolution)
        self._q = np.array(scene.start, dtype=np.float64)[None]
        self._contact = False
        self.starts = VoxelStartCheck(self.grid, self.robot, outside_solid=True)
        self.start_tolerance = o.start_tolerance * self.grid.resolution

    def _effort_metric(self, placement):
        """Groups of the tangent coordinates and their weights for the effort solver (:mod:`.rigid_kernel`).

        A rigid body has a force limit on its translation and a torque limit on its rotation: two
        groups, weighted 1 and ``effort_length`` (torque limit / force limit, m).  Its default is the
        radius of gyration ``sqrt(mean |r|^2)`` of the body's points about the reference point: the
        limits that give the body's linear and angular accelerations the same effect at that radius.
        Joint-space robots have one effort limit per actuator: every coordinate its own group, weight 1.
        """
        t = self.space.tangent_dim
        if placement is None or not self.angular.any():
            if placement is not None:                     # a translating body: one force limit
                return np.zeros(t, dtype=np.int64), np.ones(1)
            return np.arange(t, dtype=np.int64), np.ones(t)
        length = self.options.effort_length
        if length is None:
            local = placement[2]
            length = float(np.sqrt(np.mean(np.sum(local ** 2, axis=1))))
        return self.angular.astype(np.int64), np.array([1.0, max(length, 1e-9)])

    # --- the control law ----------------------------------------------------------------------

    def limit(self, velocity: np.ndarray) -> np.ndarray:
        """Scale velocities ``(n, t)`` into the limits, keeping their direction.

        Rigid bodies cap the norm of the translational and of the rotational part separately
        (thesis ch. 5: 1.0 m/s and 0.125 rad/s); articulated robots, or per-actuator limits, cap every
        component by one common factor.
        """
        return limit_velocity(velocity, self.angular, self.options.velocity_limit,
                              self.options.angular_velocity_limit, self.limits if self.per_actuator else None)

    def control_law(self) -> ControlLaw:
        """The P law of :meth:`simulate` (eq. 8.1-8.2; ``kd`` recorded), its limits and noise."""
        o = self.options
        return ControlLaw(self.space, o.kp, o.kd, self.dt, self.angular, o.velocity_limit, o.angular_velocity_limit,
                          self.limits if self.per_actuator else None, self.noise,
                          lambda q, velocity: self.microsteps(q, velocity, self.dt))

    # --- simulation ---------------------------------------------------------------------------

    def simulate(self, starts, targets, rng, duration, record=False):
        q, _ = check_batch(starts, self.space, "starts")
        q = q.copy()
        targets = np.broadcast_to(check_batch(targets, self.space, "targets")[0], q.shape)
        if not (math.isfinite(duration) and duration > 0):
            raise DimensionError("duration must be a positive number of seconds", field="duration", value=duration)
        n = len(q)
        if n == 0:
            empty = np.zeros(0, dtype=bool)
            return SimulationBatch(final=q, in_contact=empty, stuck=empty.copy(), reached=empty.copy(),
                                   trajectories=np.zeros((0, 1, q.shape[1])) if record else None, steps=0)
        steps = max(1, round(duration * self.options.frequency))
        touched = np.zeros(n, dtype=bool)
        stuck = np.zeros(n, dtype=bool)
        previous_error = None
        trajectory = [q.copy()] if record else None
        total_micro = 0
        for _ in range(steps):
            checkpoint()             # a planner's time budget may end inside a long simulation
            error = self.space.difference(targets, q)
            command = self.options.kp * error
            if self.options.kd and previous_error is not None:
                command += self.options.kd * (error - previous_error)
            previous_error = error
            velocity = self.limit(command / self.dt)
            before = q.copy()
            q, contact, micro = self._advance(q, velocity, self.dt, rng)
            touched |= contact
            total_micro += micro
            moved = self.space.distance(q, before)
            commanded = np.linalg.norm(velocity * self.dt, axis=1)
            stuck = (moved < self.options.stuck_fraction * commanded) & (commanded > 1e-12)
            if record:
                trajectory.append(q.copy())
        reached = self.space.distance(q, targets) <= self.reach
        return SimulationBatch(final=q, in_contact=touched, stuck=stuck & ~reached, reached=reached,
                               trajectories=np.stack(trajectory, axis=1) if record else None, steps=total_micro)

    def reset(self, q):
        """Place the robot at ``q`` ``(d,)`` at rest.  The core refuses a configuration whose surface points lie
        deeper than ``start_tolerance`` inside an obstacle or outside the grid (:meth:`start_penetration`) before
        this runs: collision resolution only ever pushes a robot back out along its motion, so one placed inside a
        wall would report no contact and pass through."""
        self._q = check_batch(q, self.space, "configuration")[0][:1].copy()
        self._contact = False

    def start_penetration(self, configurations):
        """How deep (m) the deepest surface point of the robot at each configuration ``(n, d)`` lies inside an
        occupied voxel or outside the grid (which the simulator treats as solid): its distance to the nearest free
        voxel (:class:`pliant.execution.starts.VoxelStartCheck`).  Every occupied voxel counts, deformable material
        and movable objects included: this simulator holds every object fixed and rigid."""
        q = np.atleast_2d(np.asarray(configurations, dtype=np.float64))
        depth = np.zeros(len(q))
        if self.placement_kind is not None:                 # a rigid body: the compiled test first, most are free
            c = self.contact
            suspect = np.empty(len(q), dtype=np.bool_)
            placed_points_hit(self.placement_kind, np.ascontiguousarray(q), self._walked_local, *self._start_segments,
                              c.free_clearance, c.lower, 1.0 / c.res, c._shape, c.occupied_flat, suspect)
            q = q[suspect]
        else:
            suspect = np.ones(len(q), dtype=bool)
        if len(q) == 0:
            return depth
        points = self.robot.body_points(q, self.surface)
        hit = self.contact.colliding(points)                # which points collide: the ones to measure
        if hit.any():
            rows, cols = np.nonzero(hit)
            measured = np.zeros(len(q))
            np.maximum.at(measured, rows, self.starts.depth(points[rows, cols]))
            depth[suspect] = measured
        return depth

    def describe_obstacle(self, q):
        return self.starts.describe(q)

    def configuration(self):
        return self._q[0].copy()

    def in_contact(self):
        return self._contact

    def step(self, velocity, dt, rng):
        v = np.atleast_2d(np.asarray(velocity, dtype=np.float64))
        if v.shape != (1, self.space.tangent_dim) or not np.all(np.isfinite(v)):
            raise DimensionError(f"velocity must be ({self.space.tangent_dim},) and finite", field="velocity",
                                 value=np.asarray(velocity).tolist())
        self._q, contact, _ = self._advance(self._q, self.limit(v), float(dt), rng)
        self._contact = bool(contact[0])
        return self._q[0].copy()

    # --- microsteps and collision resolution ------------------------------------------------

    def _advance(self, q, velocity, dt, rng):
        """Apply ``velocity`` ``(n, t)`` for ``dt`` seconds in microsteps; returns (q, touched, microsteps)."""
        n = len(q)
        micro = self.microsteps(q, velocity, dt)
        sub_dt = dt / micro
        if self.kernel_kind is not None:
            # rigid bodies: the noise of every microstep drawn first (in the same order as below), then one compiled
            # pass over the particles
            noise = np.empty((micro, *velocity.shape))
            for m in range(micro):
                noise[m] = self.noise.sample(rng, velocity)
            return (*self._advance_fused(q, velocity, noise, sub_dt), micro)
        scale = np.ones(n)
        halvings = np.zeros(n, dtype=int)
        touched = np.zeros(n, dtype=bool)
        for _ in range(micro):
            noise = self.noise.sample(rng, velocity)
            step = (velocity + noise) * sub_dt * scale[:, None]
            q, ok, contact = self._microstep(q, step)
            touched |= contact
            failed = ~ok
            if failed.any():
                halvings[failed] += 1
                scale[failed] = np.where(halvings[failed] > self.options.max_halvings, 0.0, scale[failed] * 0.5)
        return q, touched, micro

    def microsteps(self, q: np.ndarray, velocity: np.ndarray, dt: float) -> int:
        """Microsteps of one step of ``dt`` s at ``velocity`` ``(n, t)`` from ``q`` ``(n, d)``: enough that no surface
        point of any particle moves more than ``step_fraction`` of a voxel, noise included (one count per batch)."""
        delta = velocity * dt
        bound = delta + np.where(delta >= 0, 1.0, -1.0) * self.noise.limits(velocity) * dt
        if not bound.any():                             # nothing moves (an arm at rest, noiseless): no travel
            return 1
        if self.reach_radius is not None:
            # a rigid body's points move at most |translation| + |rotation| * (farthest point's radius)
            linear = np.linalg.norm(bound[:, ~self.angular], axis=1)
            angular = np.linalg.norm(bound[:, self.angular], axis=1) if self.angular.any() else 0.0
            travel = float(np.max(linear + angular * self.reach_radius))
        else:
            p0 = self._surface_points(q)
            p1 = self.robot.body_points(self.space.retract(q, bound), self.surface)
            # the largest squared displacement, then one square root: the same number as the largest norm (the
            # square root is monotonic and the sum is norm's own, x^2 + y^2 + z^2 in that order), without a
            # reduction over an axis of three per point
            d = p1 - p0
            travel = math.sqrt(float(np.max(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2]))) \
                if p0.size else 0.0
        return max(1, math.ceil(travel / (self.options.step_fraction * self.grid.resolution)))

    def _surface_points(self, q: np.ndarray) -> np.ndarray:
        """The surface points of configurations ``q`` ``(n, d)``; those of the last free microstep's result when
        ``q`` is it, bit for bit (the next step's travel bound starts where that microstep ended)."""
        key, points = self._placed
        if points is not None and key == q.tobytes():
            return points
        return self.robot.body_points(q, self.surface)

    def _microstep(self, q, step):
        """One microstep with RESOLVECOLLISIONS; returns (q, converged, touched) per particle (the generic path:
        rigid bodies go through :meth:`_advance_fused`)."""
        surface = self.surface
        before = None                                # the points at q: needed only once something collides
        trial = self.space.retract(q, step)
        touched = np.zeros(len(q), dtype=bool)
        for _ in range(self.options.max_corrections):
            pts = self.robot.body_points(trial, surface)
            hit = self.contact.colliding(pts)
            active = np.nonzero(hit.any(axis=1))[0]
            if len(active) == 0:
                still = np.zeros(len(q), dtype=bool)     # these points are the trial's: every particle is free
                self._placed = (trial.tobytes(), pts)
                break
            if before is None:
                before = self._surface_points(q)
            touched[active] = True
            trial[active] = self._correct(trial[active], pts[active], before[active], hit[active])
        else:                                         # corrections used up (or none allowed): test the last trial
            still = self.contact.colliding(self.robot.body_points(trial, surface)).any(axis=1)
        if self.self_collision:
            for a in np.nonzero(~still)[0]:
                trial[a], ok, hit_self = self._resolve_self_collision(trial[a], step[a])
                still[a] = not ok
                touched[a] |= hit_self
        trial[still] = q[still]                      # revert: the step could not be made feasible
        return trial, ~still, touched

    def _resolve_self_collision(self, q, step):
        """Thesis app. B's momentum model of self-collisions for one particle; returns (q, resolved, touched).

        Each contact between links a and b is an inelastic collision of their momenta along the
        contact normal: with ``M`` the mass of a link and everything after it in the chain and ``u``
        its contact point's motion along the normal during the microstep (``J step . n``), both
        points take the common motion ``u* = (M_a u_a + M_b u_b) / (M_a + M_b)``.  The differences,
        plus half the penetration each, are the point corrections, mapped to the joints by damped
        least squares (eq. 8.5).
        """
        touched = False
        for _ in range(self.options.max_corrections):
            c = self._self_contacts(q)
            if len(c) == 0:
                return q, True, touched
            touched = True
            n = c.normal
            ua = np.einsum("cij,j,ci->c", c.jacobian_a, step, n)
            ub = np.einsum("cij,j,ci->c", c.jacobian_b, step, n)
            total = np.maximum(c.mass_a + c.mass_b, 1e-12)
            common = (c.mass_a * ua + c.mass_b * ub) / total
            separate = 0.5 * (c.depth + self.options.clearance * self.grid.resolution)
            dp = np.concatenate([((common - ua) - separate)[:, None] * n, ((common - ub) + separate)[:, None] * n])
            jac = np.concatenate([c.jacobian_a, c.jacobian_b]).reshape(-1, self.space.tangent_dim)
            lhs = jac.T @ jac
            lhs += self.options.damping * max(np.trace(lhs) / len(lhs), 1e-12) * np.eye(len(lhs))
            q = self.space.retract(q, np.linalg.solve(lhs, jac.T @ dp.reshape(-1)))
            if self.space.kind == "rn":
                q = self.space.enforce_bounds(q)
        return q, len(self._self_contacts(q)) == 0, touched

    def _self_contacts(self, q):
        """The robot's self-contacts at ``q`` ``(d,)`` that the collision library described with finite numbers.

        coal's GJK/EPA sometimes reports a colliding pair with NaN witness points, normal and Jacobians
        (seen on Baxter's right arm, elbow bent near its limit, e1 = 2.61 rad); one such row made the damped
        least squares return NaN joints, which ended the whole planning run.  Such contacts carry no usable
        geometry, so they are left out; the others are resolved as usual.
        """
        c = self.robot.self_contacts(q)
        if len(c) == 0:
            return c
        finite = (np.isfinite(c.point_a).all(axis=1) & np.isfinite(c.point_b).all(axis=1)
                  & np.isfinite(c.normal).all(axis=1) & np.isfinite(c.depth)
                  & np.isfinite(c.jacobian_a).all(axis=(1, 2)) & np.isfinite(c.jacobian_b).all(axis=(1, 2)))
        if finite.all():
            return c
        return type(c)(**{name: np.asarray(value)[finite] for name, value in vars(c).items()})

    def _advance_fused(self, q, velocity, noise, sub_dt):
        """:meth:`_advance` for rigid bodies, compiled end to end (same mathematics, see rigid_kernel): ``noise``
        ``(micro, n, t)`` holds every microstep's actuation error; returns (q, touched)."""
        n = len(q)
        out = np.empty_like(q)
        touched = np.empty(n, dtype=np.bool_)
        c = self.contact
        solver = SOLVE_EFFORT if self.options.solver == "effort" else SOLVE_LEAST_SQUARES
        fused_advance(self.kernel_kind, np.ascontiguousarray(q), np.ascontiguousarray(velocity), noise, sub_dt,
                      self.options.max_halvings, self._walked_local, self._walked_faces, self._walk, *self._segments,
                      c.lower, c.res, c._shape, c.exposed, c.deep_normal, c.deep_depth, c.free_clearance,
                      c.planar, self.reach_radius, self.options.clearance, self.options.max_corrections,
                      self.options.damping, solver, self.effort_groups, self.effort_weights, self._effort_tol,
                      out, touched)
        return out, touched

    @property
    def _effort_tol(self) -> float:
        """Tolerance (m) of the effort solver: a tenth of the default clearance, far below a voxel."""
        return 1e-3 * self.grid.resolution

    def _correct(self, q, pts, before, hit):
        """One correction for particles ``(a, d)`` with colliding points ``hit`` (eq. 8.5, or the effort solver).

        ``least-squares``: ``dq = J^+ dp`` over the push-out vectors (thesis eq. 8.5); ``qp``: the same
        with first-order non-penetration constraints; ``effort`` (default): the displacement of least
        dissipation against the controller's effort limits with only the contact normals constrained
        (:mod:`.rigid_kernel`), which a rigid body shares with the fused kernel.
        """
        used = np.nonzero(hit.any(axis=0))[0]           # surface points colliding in some particle
        hit = hit[:, used]
        pts, before = pts[:, used], before[:, used]
        a, k = hit.shape
        rows, cols = np.nonzero(hit)
        normals, depth = self.contact.penetration(pts[rows, cols], pts[rows, cols] - before[rows, cols],
                                                  self._robot_faces(q, rows, used[cols]))
        push = depth + self.options.clearance * self.grid.resolution
        dp = np.zeros((a, k, 3))
        dp[rows, cols] = normals * push[:, None]
        jac = self.robot.point_jacobians(q, self.surface[used])              # (a, k, 3, t)
        t = jac.shape[-1]
        masked = (jac * hit[..., None, None]).reshape(a, 3 * k, t)
        if self.options.solver == "effort":
            dq = np.zeros((a, t))
            constraint = np.einsum("kc,kct->kt", normals, jac[rows, cols])       # a_i = J_i^T n_i
            for p in range(a):
                sel = rows == p
                effort_correction(np.ascontiguousarray(constraint[sel]), np.ascontiguousarray(push[sel]),
                                  int(sel.sum()), self.effort_groups, self.effort_weights, self._effort_tol, dq[p])
        elif self.options.solver == "qp":
            dq = self._qp_corrections(masked, dp, rows, cols, normals, push, jac)
        else:
            lhs = np.swapaxes(masked, 1, 2) @ masked
            rhs = np.swapaxes(masked, 1, 2) @ dp.reshape(a, 3 * k, 1)
            damping = self.options.damping * np.maximum(np.trace(lhs, axis1=1, axis2=2) / t, 1e-12)
            lhs += damping[:, None, None] * np.eye(t)
            dq = np.linalg.solve(lhs, rhs)[..., 0]
        moved = self.space.retract(q, dq)
        return self.space.enforce_bounds(moved) if self.space.kind == "rn" else moved

    def _robot_faces(self, q, rows, points):
        """World directions ``(k, 6, 3)`` of the robot faces that surface points ``points`` of particles
        ``rows`` lie on (zero where not), or ``None`` when the robot does not report them."""
        if self.surface_faces is None:
            return None
        placement = self.robot.rigid_placement(q)
        if placement is None:
            return None
        rotations = placement[0][rows]                                          # (k, 3, 3)
        directions = np.einsum("kij,ej->kei", rotations, FACE_NORMALS)          # (k, 6, 3)
        return directions * self.surface_faces[points][..., None]

    def _qp_corrections(self, masked, dp, rows, cols, normals, push, jac):
        """Least-squares corrections subject to ``n_i . J_i dq >= depth_i`` for every colliding point."""
        from qpsolvers import solve_qp

        a, _, t = masked.shape
        out = np.zeros((a, t))
        for p in range(a):
            sel = rows == p
            j = jac[p, cols[sel]]                                          # (c, 3, t)
            g = -np.einsum("ck,ckt->ct", normals[sel], j)                  # -n^T J dq <= -depth
            h = -push[sel]
            m = masked[p]
            lhs = m.T @ m + 1e-9 * np.eye(t)
            rhs = m.T @ dp[p].reshape(-1)
            sol = solve_qp(lhs, -rhs, g, h, solver="daqp")
            out[p] = sol if sol is not None else np.linalg.lstsq(m, dp[p].reshape(-1), rcond=None)[0]
        return out
