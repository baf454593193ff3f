"""The path-quality metrics of thesis ch. 6 as ``metric`` components.

``reachable-volume``  the proposed metric (6.4): reachable volumes, sampling, contact characterisation and the
                      image estimate of ``P_stuck`` (eq. 6.10-6.13).
``sampling-driven``   the simplified variant (6.5, method 2): simulate from ``RV_0`` only past the last volume
                      holding a stuck sample.
``simulation``        Simulation (baseline): ``simulations`` kinematic executions from the start ball.
``simulation-scaled`` Simulation (scaled): as many executions as the largest reachable volume has samples.

Each scores a path by ``P_exec`` (eq. 6.13: the product over its adjacent waypoint pairs) and reports the work
done: ``samples`` (configurations sampled), ``contacts`` (projected to contact), ``simulated_steps`` (control
steps simulated, every robot counted) and ``volumes`` (reachable volumes, all pairs); the same seed gives the same
scores (a pipeline times its metric itself).  All need the
pipeline's simulator to expose its control law (the kinematic simulator does) and a voxelised scene.
"""

from __future__ import annotations

import itertools
import weakref
from dataclasses import dataclass

import numpy as np
from pliant.api import (
    ClusteringContext,
    ConfigError,
    DimensionError,
    Path,
    PathMetric,
    PlanningError,
    PlanningProblem,
    VoxelGrid,
    option,
)

from pliant_reachability.assess import (
    SamplingSettings,
    image_probability,
    propagated_probability,
    sample_counts,
    sample_motion,
    sampling_driven_probability,
)
from pliant_reachability.clearance import Clearance
from pliant_reachability.rollout import rollout
from pliant_reachability.volumes import ReachableVolumes, reachable_volumes, tangent_weights


@dataclass(frozen=True)
class ReachabilityOptions:
    """Options shared by the four metrics (thesis 6.5's values where it gives them)."""

    epsilon_reached: float = option(0.125, "distance within which a waypoint counts as reached, in weighted units "
                                    "(thesis grid 0.125, 0.1875, 0.25)", minimum=1e-9)
    translation_weight: float = option(10.0, "weight of translation (per m) in distances and measures (thesis: 10)",
                                       minimum=1e-9)
    rotation_weight: float = option(1.0, "weight of rotation (per rad)", minimum=1e-9)
    density: float | None = option(None, "samples per unit of weighted measure; default: largest_volume_samples in "
                                   "the largest reachable volume of each waypoint pair", minimum=1e-12)
    largest_volume_samples: int = option(500, "samples in the largest reachable volume when density is not given "
                                         "(thesis: 500 for SE(3), 250 for SE(2))", minimum=1)
    max_samples: int = option(20000, "most samples drawn in one reachable volume", minimum=1)
    max_volumes: int = option(200, "most reachable volumes per waypoint pair", minimum=1)
    near_distance: float = option(3.0, "near contact: a surface point within this many voxels of an obstacle "
                                  "(voxel-centre signed distance)", minimum=0.0)
    projection_iterations: int = option(6, "steps of the projection to contact (eq. 6.9)", minimum=1)
    stuck_distance: float = option(0.01, "stuck: the robot's motion over stuck_steps control steps is shorter than "
                                   "this (weighted units; the contact controller's test and default)", minimum=0.0)
    theta: float = option(0.26, "downstream check: largest angle (rad) between rejections", minimum=0.0,
                          maximum=3.1416)
    distribution: str = option("propagated", "reachable-volume: samples of each volume uniform in its box ('uniform', "
                               "the thesis) or particles of the obstacle-free controller distribution ('propagated')",
                               choices=("uniform", "propagated"))
    reachability: str = option("none", "uniform: set aside samples not reachable from the previous volume's, by the "
                               "clustering of thesis 5.3.3 ('ac': the nearest previous sample's actuation centre "
                               "connects by a free segment; thesis 6.6.2)", choices=("none", "ac"))
    particles: int = option(1500, "propagated: particles per waypoint pair", minimum=1)
    labelled: int = option(200, "propagated: contact events labelled by simulation; the others take the nearest "
                           "one's label", minimum=1)
    threads: int = option(2, "threads for the batched clearance queries (the kernel releases the GIL)", minimum=1)
    image_samples: int = option(16, "Monte-Carlo futures per sample image (eq. 6.10)", minimum=1)
    stuck_steps: int = option(5, "the window of control steps of the stuck test, in simulated executions and in the "
                              "contact labels (the contact controller's default; thesis 6.5: 2 steps)", minimum=1)
    contact_horizon: int = option(12, "control steps each contact is simulated to tell sliding from stuck and "
                                  "becoming stuck", minimum=1)
    step_allowance: float = option(3.0, "simulated executions end after this many times the number of reachable "
                                   "volumes of the pair", minimum=1.0)
    simulations: int = option(10000, "simulation: executions per waypoint pair (thesis: 10,000 SE(3), 2,000 SE(2))",
                              minimum=1)


#: the voxel grid of each scene object the metrics were bound to: ``id(scene) -> (weak reference, fingerprint, grid)``
_GRIDS: dict[int, tuple] = {}


def scene_grid(scene) -> VoxelGrid:
    """``VoxelGrid.from_scene(scene)``, built once per scene object and shared by every metric bound to it.

    Voxelising a scene and its signed distance field takes seconds (se3-peg-tight: 4.5 million voxels), and the
    tables evaluate thousands of metrics in one process on the same few scenes.  The entry is rebuilt when the scene
    object is gone or its workspace, resolution or object list changed.
    """
    fingerprint = (scene.resolution, tuple(np.asarray(scene.lower).tolist()), tuple(np.asarray(scene.upper).tolist()),
                   id(scene.objects), len(scene.objects))
    entry = _GRIDS.get(id(scene))
    if entry is not None and entry[0]() is scene and entry[1] == fingerprint:
        return entry[2]
    grid = VoxelGrid.from_scene(scene)
    _GRIDS[id(scene)] = (weakref.ref(scene), fingerprint, grid)
    for key in [k for k, e in _GRIDS.items() if e[0]() is None]:       # scenes gone
        del _GRIDS[key]
    return grid


class ReachabilityMetric(PathMetric):
    """Base of the ch. 6 metrics: per waypoint pair, reachable volumes and (sub-class) an estimate of ``P_exec``."""

    Options = ReachabilityOptions
    example_scene = "se2-through-passage"
    example_components = {"simulator": "kinematic"}
    example_options = {"simulations": 200, "largest_volume_samples": 100}

    def bind(self, context) -> None:
        super().bind(context)
        self.robot = self.require("robot")
        self.simulator = self.require("simulator")
        law = self.simulator.control_law()
        if law is None:
            raise PlanningError(f"the {self.kind} {type(self).__name__} needs a simulator with a control law (e.g. "
                                f"'kinematic'); {type(self.simulator).__name__} has none", field="simulator")
        self.law = law
        self.weights = tangent_weights(law, self.options.translation_weight, self.options.rotation_weight)
        grid = scene_grid(self.require("scene"))
        self.clearance = Clearance(self.robot, grid, self.options.threads)
        self.clustering = ClusteringContext.from_context(context, grid=grid) \
            if self.options.reachability == "ac" else None

    def volumes(self, a: np.ndarray, b: np.ndarray) -> ReachableVolumes:
        """The reachable volumes of the motion ``a -> b``."""
        return reachable_volumes(self.law, a, b, self.options.epsilon_reached, self.weights, self.options.max_volumes)

    def density(self, volumes: ReachableVolumes) -> float:
        """Samples per unit weighted measure for this pair (the option, or the largest volume's share)."""
        if self.options.density is not None:
            return self.options.density
        return self.options.largest_volume_samples / float(np.max(volumes.measures()))

    def settings(self, volumes: ReachableVolumes) -> SamplingSettings:
        density = self.density(volumes)
        return SamplingSettings.from_options(self.options, density=density,
                                             axis=0.5 * density ** (-1.0 / len(self.weights)))

    def max_steps(self, volumes: ReachableVolumes) -> int:
        return int(np.ceil(self.options.step_allowance * len(volumes)))

    def evaluate(self, path: Path, problem: PlanningProblem, rng: np.random.Generator) -> dict[str, float]:
        q = np.asarray(path.configurations, dtype=np.float64)
        space = self.robot.space
        if q.ndim != 2 or q.shape[1] != space.dim:
            raise DimensionError(f"path must be (k, {space.dim})", field="path", value=list(q.shape))
        if len(q) < 2:
            raise ConfigError("a path needs at least two waypoints", field="path", value=len(q))
        if not np.all(np.isfinite(q)):
            raise ConfigError("path configurations must be finite", field="path")
        totals = {"samples": 0, "contacts": 0, "simulated_steps": 0, "volumes": 0}
        p_exec = 1.0
        for a, b in itertools.pairwise(q):
            volumes = self.volumes(a, b)
            totals["volumes"] += len(volumes)
            p_exec *= self.pair(volumes, rng, totals)
        return {"p_exec": float(p_exec), **{k: float(v) for k, v in totals.items()}}

    def pair(self, volumes: ReachableVolumes, rng: np.random.Generator, totals: dict) -> float:
        raise NotImplementedError

    def starts(self, volumes: ReachableVolumes, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` configurations uniform in the start ball's free part: preferably ones that do not touch (no surface
        point in a voxel next to an obstacle, so that a dynamic simulator's finer geometry also starts free), else,
        where the ball lies in a passage narrower than that, free ones that touch.  Rejection sampling with a
        budget of ``100 n`` (at least a million) draws; none free is an error."""
        touching = 0.6 * self.clearance.grid.resolution
        kept, fallback = [], []
        count, drawn, budget = 0, 0, max(100 * n, 10**6)
        while count < n and drawn < budget:
            batch = min(max(4 * (n - count), 4096), budget - drawn)
            q = volumes.sample_start_ball(rng, batch)
            drawn += batch
            distance, _, colliding = self.clearance.query(q)
            good = q[~colliding & (distance > touching)][:n - count]
            kept.append(good)
            count += len(good)
            if sum(len(f) for f in fallback) < n:
                fallback.append(q[~colliding & (distance <= touching)])
        if count == 0:
            q = np.concatenate(fallback) if fallback else np.zeros((0, len(volumes.start)))
            if len(q) == 0:
                raise PlanningError("the epsilon_reached ball around a waypoint lies inside obstacles",
                                    field="path", value=volumes.start.tolist())
            return q[:n]
        return np.concatenate(kept)


class ReachableVolumeMetric(ReachabilityMetric):
    """Thesis ch. 6's proposed metric: ``P_exec`` from the images of reachable-volume samples (eq. 6.10-6.13)."""

    def pair(self, volumes, rng, totals):
        settings = self.settings(volumes)
        if self.options.distribution == "propagated":
            starts = self.starts(volumes, rng, self.options.particles)
            p, motion = propagated_probability(volumes, settings, self.clearance, self.simulator, rng, starts,
                                               self.options.labelled, self.max_steps(volumes))
            totals["samples"] += len(starts) * len(volumes)
            totals["contacts"] += motion.events
            totals["simulated_steps"] += motion.simulated
            return p
        sampled = sample_motion(volumes, settings, self.robot, self.clearance, self.simulator, rng, self.clustering)
        totals["samples"] += sampled.sample_count
        totals["contacts"] += len(sampled.contacts.x)
        totals["simulated_steps"] += sampled.contacts.simulated
        p, _ = image_probability(sampled, settings, self.clearance, rng)
        return p


class SamplingDrivenMetric(ReachabilityMetric):
    """Thesis 6.5's Sampling-driven method: simulate from ``RV_0`` past the last volume with a stuck sample."""

    def pair(self, volumes, rng, totals):
        settings = self.settings(volumes)
        sampled = sample_motion(volumes, settings, self.robot, self.clearance, self.simulator, rng, self.clustering)
        totals["samples"] += sampled.sample_count
        totals["contacts"] += len(sampled.contacts.x)
        totals["simulated_steps"] += sampled.contacts.simulated
        p, rolled = sampling_driven_probability(sampled, settings, self.simulator, rng, self.max_steps(volumes))
        if rolled is not None:
            totals["simulated_steps"] += rolled.steps
        return p


class SimulationMetric(ReachabilityMetric):
    """Thesis 6.5's Simulation (baseline): ``simulations`` kinematic executions from the start ball."""

    def executions(self, volumes: ReachableVolumes) -> int:
        return self.options.simulations

    def pair(self, volumes, rng, totals):
        starts = self.starts(volumes, rng, self.executions(volumes))
        o = self.options
        result = rollout(volumes, starts, self.simulator, rng, stuck_distance=o.stuck_distance,
                         stuck_steps=o.stuck_steps, max_steps=self.max_steps(volumes))
        totals["samples"] += len(starts)
        totals["simulated_steps"] += result.steps
        return result.probability


class ScaledSimulationMetric(SimulationMetric):
    """Thesis 6.5's Simulation (scaled): as many executions as the largest reachable volume has samples."""

    def executions(self, volumes: ReachableVolumes) -> int:
        return int(np.max(sample_counts(volumes, self.density(volumes), self.options.max_samples)))
