"""Learning deformability (thesis appendix A): press a known object and the unknown ones, compare volume changes.

The appendix brings a central object of known deformability into contact with each unknown object and takes the
unknown deformability as the ratio of volume changes times the known one, averaged over 30 repetitions.  Both
bodies here are pybullet Neo-Hookean soft bodies (tetrahedral boxes, the volume change being the sum of the
tetrahedra's absolute volume changes, as in thesis 3.3.4) whose stiffness is ``(mu0, lambda0) / d``: compliance
proportional to deformability.

One deviation, measured: in pybullet's deformable world, two soft bodies pressed together compress equally
whatever their stiffness ratio (estimates of 0.46-0.70 for true 0.25-0.75), so the load is not shared by
stiffness and the appendix's pairwise press cannot be reproduced there.  Instead a rigid indenter, pulled by a
constraint capped at a force, presses each object in turn, the known one included, with one face held.  Each
repetition moves the indenter by up to ``jitter`` m across the face.

The estimate (issue 33).  A body whose stiffness is ``(mu0, lambda0) / d`` in static equilibrium under a force
``F`` is deformed exactly as the same body of deformability ``d_k`` under ``F d_k / d`` (the stresses scale with
``1/d``).  So pressing the *known* object at the forces ``F d_j / d_k`` shows the volume change an object of its
kind and deformability ``d_j`` would show under ``F``: a response curve over the model's range ``[0, 1]``, with
``V(0) = 0``.  An unknown object's deformability is read off that curve (monotone, piecewise linear): within
``[0, 1]`` by construction, whatever the curve's non-linearity.  A volume change above the curve's end (the data
say more than 1) gives 1 and is reported, never silently: a :class:`DeformabilityRangeWarning`, and the value the
curve's last segment extrapolates to in ``above_range``.  The press force, unless given, is chosen from the
reference object: the force under which an object of its kind at deformability 1 changes volume by ``target``
times its rest volume (a few probe presses of the reference).  The volume change is the mean over the last
``window`` steps of the press (every 10th step), so that the indenter's residual oscillation averages out.
"""

from __future__ import annotations

import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pliant.api import ConfigError, DimensionError, Learner, box_tetrahedra, option, tetrahedron_volumes, write_vtk


class DeformabilityRangeWarning(UserWarning):
    """An object's volume change lies beyond the reference's response at deformability 1 (the data say > 1)."""


@dataclass(frozen=True)
class PressOptions:
    """Options of the ``press-deformability`` learner (SI units)."""

    known: float = option(0.5, "deformability of the known reference object", minimum=1e-6, maximum=1.0)
    force: float | None = option(None, "the indenter's pulling force (N); none: chosen from the reference object "
                                 "(see target)", minimum=1e-6)
    target: float = option(0.015, "automatic force: the volume change, as a fraction of the rest volume, of an "
                           "object of the reference's kind at deformability 1", minimum=1e-4, maximum=0.2)
    probe: float = option(1.0, "automatic force: the first force tried (N)", minimum=1e-6)
    probes: int = option(4, "automatic force: largest number of probe presses of the reference", minimum=1)
    repetitions: int = option(30, "presses per unknown object, averaged (thesis: 30)", minimum=1)
    calibration: int = option(4, "points of the reference's response curve: deformabilities 1/n, 2/n .. 1",
                              minimum=1)
    calibration_repetitions: int = option(2, "presses of the reference per point of the curve", minimum=1)
    size: float = option(0.1, "length of each box along the press (m)", minimum=1e-3)
    shape: tuple[float, float] = option((1.0, 1.0), "the box's width and height over its length")
    cells: int = option(4, "hexahedral cells per edge of the mesh (5 tetrahedra each)", minimum=1)
    mu0: float = option(90.0, "Neo-Hookean mu at deformability 1 (Pa); an object of deformability d has mu0 / d",
                        minimum=1e-6)
    lambda0: float = option(300.0, "Neo-Hookean lambda at deformability 1 (Pa)", minimum=0.0)
    damping: float = option(0.2, "Neo-Hookean damping", minimum=0.0)
    time_step: float = option(1 / 480, "simulation step (s)", minimum=1e-6)
    steps: int = option(1200, "steps from the start of the press to its end", minimum=1)
    window: int = option(600, "last steps whose volume changes (every 10th) are averaged", minimum=1)
    jitter: float = option(0.005, "largest sideways offset of the indenter per repetition (m)", minimum=0.0)


def press(deformability: float, options: PressOptions, rng: np.random.Generator, force: float | None = None) -> float:
    """Volume change (m^3) of a soft box of ``deformability`` held at one face and pressed on the opposite one with
    ``force`` (N; default ``options.force``, else ``options.probe``): the mean over the press's last ``window``
    steps."""
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    o = options
    force = force if force is not None else (o.force if o.force is not None else o.probe)
    dims = np.array([o.size, o.size * o.shape[0], o.size * o.shape[1]])
    nodes0, tets = box_tetrahedra(dims, o.cells)
    rest = tetrahedron_volumes(nodes0, tets)
    pb = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        with tempfile.TemporaryDirectory() as directory:
            mesh = write_vtk(nodes0, tets, Path(directory) / "box.vtk")
            pb.resetSimulation(pb.RESET_USE_DEFORMABLE_WORLD)
            pb.setGravity(0, 0, 0)
            pb.setTimeStep(o.time_step)
            body = pb.loadSoftBody(str(mesh), basePosition=[o.size / 2, 0, 0], mass=1.0, useNeoHookean=1,
                                   NeoHookeanMu=o.mu0 / deformability, NeoHookeanLambda=o.lambda0 / deformability,
                                   NeoHookeanDamping=o.damping, collisionMargin=0.002, useSelfCollision=0,
                                   frictionCoeff=0.5)
            pb.stepSimulation()
            nodes = _nodes(pb, body)
            for k in np.flatnonzero(nodes[:, 0] > nodes[:, 0].max() - 1e-6):       # hold the far face
                pb.createSoftBodyAnchor(body, int(k), -1, -1)
            side = rng.uniform(-o.jitter, o.jitter, 2)
            half = 0.1 * o.size
            shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[half, 0.7 * dims[1], 0.7 * dims[2]])
            start = [-2 * half, side[0], side[1]]
            indenter = pb.createMultiBody(0.2, shape, basePosition=start)
            hold = pb.createConstraint(indenter, -1, -1, -1, pb.JOINT_FIXED, [0, 0, 0], [0, 0, 0], start)
            pb.changeConstraint(hold, [0.4 * o.size, side[0], side[1]], maxForce=force)
            samples = []
            first = o.steps - min(o.window, o.steps)
            for step in range(o.steps):
                pb.stepSimulation()
                if step >= first and (o.steps - 1 - step) % 10 == 0:
                    samples.append(float(np.sum(np.abs(tetrahedron_volumes(_nodes(pb, body), tets) - rest))))
            return float(np.mean(samples))
    finally:
        pb.disconnect()


def _nodes(pb, body) -> np.ndarray:
    _, verts = pb.getMeshData(body, flags=pb.MESH_DATA_SIMULATION_MESH)
    return np.asarray(verts, dtype=np.float64)


def rest_volume(options: PressOptions) -> float:
    """Rest volume (m^3) of the pressed box."""
    return float(options.size ** 3 * options.shape[0] * options.shape[1])


def choose_force(options: PressOptions, rng: np.random.Generator) -> tuple[float, list[dict]]:
    """The force under which an object of the reference's kind at deformability 1 changes volume by ``target``
    times its rest volume, from presses of the reference at ``force / known`` (the same deformation, by the
    scaling of the stresses with 1/d): starting at ``probe`` N, each next force is the last one times the ratio of
    the target to the change seen (at most x10 either way), until within 10% of the target or ``probes`` presses.
    Returns the force and the probes (force, fraction)."""
    o = options
    goal = o.target * rest_volume(o)
    force, probes = o.probe, []
    for _ in range(o.probes):
        change = press(o.known, o, rng, force=force / o.known)
        probes.append({"force": force, "fraction": change / rest_volume(o)})
        ratio = goal / max(change, 1e-12)
        if abs(ratio - 1) <= 0.1:
            break
        force *= float(np.clip(ratio, 0.1, 10.0))
    return force, probes


def invert(curve_d: np.ndarray, curve_v: np.ndarray, change: float) -> tuple[float, float]:
    """The deformability in ``[0, 1]`` whose change on the response curve ``(curve_d, curve_v)`` (from (0, 0),
    increasing in d up to d = 1; made monotone by a running maximum) is ``change``, and the unbounded value (beyond
    the curve's end: its last segment extended)."""
    d = np.concatenate([[0.0], np.asarray(curve_d, dtype=np.float64)])
    v = np.maximum.accumulate(np.concatenate([[0.0], np.asarray(curve_v, dtype=np.float64)]))
    if change <= v[-1]:
        keep = np.concatenate([[True], np.diff(v) > 0])            # np.interp needs increasing abscissae
        value = float(np.interp(max(change, 0.0), v[keep], d[keep]))
        return value, value
    slope = (v[-1] - v[-2]) / max(d[-1] - d[-2], 1e-12)
    with np.errstate(over="ignore", divide="ignore"):
        raw = d[-1] + np.float64(change - v[-1]) / slope if slope > 0 else np.inf
    return 1.0, float(raw)


class PressDeformabilityLearner(Learner):
    """Deformability of unknown objects from presses against a known reference (thesis appendix A).

    ``fit(data, rng)``: ``data`` maps each unknown object's name to the deformability its simulated body is given
    (the hidden ground truth: the learner sees only volume changes).  Returns ``deformability`` ``{name:
    estimate}`` (each in [0, 1]), ``volume_change`` ``{name: mean m^3}``, ``reference`` (the known object's mean,
    m^3, under the chosen force), ``force`` (N) and ``force_probes``, ``curve`` (the reference's response:
    ``deformability`` and ``volume_change`` lists) and ``above_range`` ``{name: unbounded estimate}`` for the
    objects whose change exceeds the curve's end (each also a :class:`DeformabilityRangeWarning`).
    """

    Options = PressOptions
    example_options = {"repetitions": 1, "steps": 200, "window": 100, "calibration": 2, "calibration_repetitions": 1,
                       "probes": 1}
    example_data = staticmethod(lambda: {"soft": 0.75, "stiff": 0.25})

    def fit(self, data, rng: np.random.Generator) -> dict:
        if not isinstance(data, dict) or not data:
            raise DimensionError("needs a non-empty {object: deformability} of the objects to probe",
                                 field="learner.data", value=data)
        for name, d in data.items():
            if isinstance(d, bool) or not isinstance(d, (int, float)) or not 0 < d <= 1:
                raise ConfigError("a deformability must be in (0, 1]", field=f"learner.data.{name}", value=d)
        o = self.options
        probes = []
        force = o.force
        if force is None:
            force, probes = choose_force(o, rng)
        grid = sorted({*(j / o.calibration for j in range(1, o.calibration + 1)), o.known})
        curve = [float(np.mean([press(o.known, o, rng, force=force * dj / o.known)
                                for _ in range(o.calibration_repetitions)])) for dj in grid]
        changes = {name: float(np.mean([press(float(d), o, rng, force=force) for _ in range(o.repetitions)]))
                   for name, d in data.items()}
        estimates, above = {}, {}
        for name, change in changes.items():
            estimates[name], raw = invert(np.array(grid), np.array(curve), change)
            if raw > 1.0:
                above[name] = raw
                warnings.warn(f"object {name!r}: its volume change ({change:.3g} m^3) exceeds the reference's "
                              f"response at deformability 1 ({max(curve):.3g} m^3): the data say {raw:.3f}; "
                              f"reported as 1", DeformabilityRangeWarning, stacklevel=2)
        return {"deformability": estimates, "volume_change": changes, "reference": curve[grid.index(o.known)],
                "force": force, "force_probes": probes, "curve": {"deformability": grid, "volume_change": curve},
                "above_range": above}
