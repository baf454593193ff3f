"""Shared machinery of dynamic simulator backends that advance one robot at a time.

A backend implements ``reset``, ``step`` (one control period under a velocity command) and
``configuration``; :class:`SteppedSimulator` supplies the actuator model (velocity limits and noise,
:mod:`pliant.execution.actuation`, :mod:`pliant.execution.noise`), ``simulate``, which runs the particles one
after the other with the kinematic simulator's P law (thesis eq. 8.1-8.2), so that backends agree on what a
command means and can be swapped by name, and the start check (:meth:`SteppedSimulator.setup_start_check`: the core
refuses every start inside an obstacle, :func:`pliant.contracts.check_starts`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pliant.components import SimulationBatch, Simulator, check_batch
from pliant.errors import DimensionError
from pliant.execution.actuation import actuator_limits, angular_mask, limit_velocity
from pliant.execution.noise import NOISE_MODELS, ActuationNoise
from pliant.execution.starts import VoxelStartCheck
from pliant.options import option
from pliant.termination import checkpoint


@dataclass(frozen=True)
class SteppedOptions:
    """Options every stepped backend shares (backends extend this dataclass)."""

    frequency: float = option(10.0, "control frequency (Hz)", minimum=1e-6)
    physics_rate: float = option(240.0, "physics steps per second (Hz)", minimum=1.0)
    kp: float = option(0.5, "proportional gain: fraction of the error commanded per control step", minimum=0.0)
    velocity_limit: float = option(1.0, "translation speed limit (m/s)", minimum=1e-9)
    angular_velocity_limit: float = option(0.125, "rotation speed limit (rad/s)", minimum=1e-9)
    joint_velocity_limits: tuple[float, ...] = option((), "per-actuator speed limits (rad/s or m/s); overrides "
                                                      "the two limits above when given")
    noise: str = option("none", "actuation noise model (pliant.execution.noise)", choices=NOISE_MODELS)
    noise_linear: float = option(0.0, "noise parameter of translation (bound m/s, or factor)", minimum=0.0)
    noise_angular: float = option(0.0, "noise parameter of rotation (rad/s, or factor)", minimum=0.0)
    friction: float = option(0.5, "friction coefficient of robot and obstacles", minimum=0.0)
    reach_tolerance: float | None = option(None, "distance counting as reached; default the scene's goal "
                                           "tolerance, else one voxel")
    stuck_fraction: float = option(0.05, "stuck when a control step moves less than this fraction of what it "
                                   "commanded", minimum=0.0, maximum=1.0)
    start_tolerance: float = option(0.25, "deepest a start's surface points may lie inside an obstacle, in voxels "
                                    "(contact and the solver's slop); a deeper start is refused by reset, simulate "
                                    "and step", minimum=0.0, maximum=0.5)


class SteppedSimulator(Simulator):
    """Base of backends that step one robot: actuator model plus a particle-by-particle ``simulate``."""

    Options = SteppedOptions

    def setup_actuation(self, scene) -> None:
        """Read the space, limits, noise, periods and reach tolerance from the options and the scene."""
        o = self.options
        self.space = self.robot.space
        self.angular = angular_mask(self.space)
        self.limits = actuator_limits(self.space, o.velocity_limit, o.angular_velocity_limit, o.joint_velocity_limits)
        # as in the kinematic simulator: articulated robots (and explicit limits) cap every actuator by one
        # common factor; rigid bodies cap the norms of translation and rotation separately
        self.per_actuator = bool(o.joint_velocity_limits) or self.robot.rigid_placement(
            np.asarray(scene.start, dtype=np.float64)[None]) is None
        self.noise = ActuationNoise(o.noise, np.where(self.angular, o.noise_angular, o.noise_linear), self.limits)
        self.dt = 1.0 / o.frequency
        self.substeps = max(1, round(o.physics_rate / o.frequency))
        self.reach = o.reach_tolerance if o.reach_tolerance is not None else (
            scene.goal_tolerance if scene.goal_tolerance > 0 else scene.resolution)

    def setup_start_check(self, grid, *, outside_solid: bool) -> None:
        """Measure starts against ``grid``'s occupied voxels (the obstacles the backend builds its walls from) with
        the robot model's surface points (:class:`pliant.execution.starts.VoxelStartCheck`); ``outside_solid``: the
        backend closes the scene's bounds with walls.  Call before the first ``reset``."""
        self.starts = VoxelStartCheck(grid, self.robot, outside_solid=outside_solid)
        self.start_tolerance = self.options.start_tolerance * grid.resolution

    def start_penetration(self, configurations):
        """Depth (m) of the robot's deepest surface point inside the obstacles at each configuration ``(n, d)`` (see
        :meth:`setup_start_check`); ``None`` (nothing refused) for a backend that did not set the check up."""
        starts = getattr(self, "starts", None)
        return None if starts is None else starts.penetration(configurations)

    def describe_obstacle(self, q) -> str:
        starts = getattr(self, "starts", None)
        return "" if starts is None else starts.describe(q)

    def limit(self, velocity: np.ndarray) -> np.ndarray:
        """Velocities ``(n, t)`` scaled into the actuators' limits, keeping their direction."""
        return limit_velocity(velocity, self.angular, self.options.velocity_limit,
                              self.options.angular_velocity_limit, self.limits if self.per_actuator else None)

    def actuate(self, velocity, rng) -> np.ndarray:
        """A velocity command ``(t,)`` checked, limited and made noisy: what the actuators deliver."""
        v = np.asarray(velocity, dtype=np.float64).reshape(-1)
        if v.shape != (self.space.tangent_dim,) or not np.all(np.isfinite(v)):
            raise DimensionError(f"velocity must be ({self.space.tangent_dim},) and finite", field="velocity",
                                 value=np.asarray(velocity).tolist())
        v = self.limit(v[None])[0]
        return v + self.noise.sample(rng, v[None])[0]

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
        trajectories = np.empty((n, steps + 1, self.space.dim)) if record else None
        for a in range(n):
            self.reset(starts[a])
            q = self.configuration()
            if record:
                trajectories[a, 0] = q
            for k in range(steps):
                checkpoint()         # a planner's time budget may end inside a long simulation
                command = self.options.kp * self.space.difference(targets[a], q) / self.dt
                command = self.limit(command[None])[0]
                before = q
                q = self.step(command, self.dt, rng)
                touched[a] |= self.in_contact()
                stuck[a] = float(self.space.distance(q, before)) < (
                    self.options.stuck_fraction * float(np.linalg.norm(command * self.dt)))
                if record:
                    trajectories[a, k + 1] = q
            final[a] = q
        reached = self.space.distance(final, targets) <= self.reach
        return SimulationBatch(final=final, in_contact=touched, stuck=stuck & ~reached, reached=reached,
                               trajectories=trajectories, steps=n * steps * self.substeps)
