"""Learning deformability (thesis appendix A): press a known object and the unknown ones, compare volume changes.

The appendix brings a central object of known deformability into contact with each unknown object and takes the
unknown deformability as the ratio of volume changes times the known one, averaged over 30 repetitions.  Both
bodies here are pybullet Neo-Hookean soft bodies (tetrahedral boxes, the volume change being the sum of the
tetrahedra's absolute volume changes, as in thesis 3.3.4) whose stiffness is ``(mu0, lambda0) / d``: compliance
proportional to deformability, so that equal loads give volume changes in the ratio of the deformabilities.

One deviation, measured: in pybullet's deformable world, two soft bodies pressed together compress equally
whatever their stiffness ratio (estimates of 0.46-0.70 for true 0.25-0.75), so the load is not shared by
stiffness and the appendix's pairwise press cannot be reproduced there.  Instead a rigid indenter, pulled by a
constraint capped at ``force`` newtons, presses each object in turn, the known one included, with one face held;
the known object's volume change under the same load is the reference.  The ratio of volume changes times the
known deformability is the estimate, as in the appendix.  Each repetition moves the indenter by up to
``jitter`` m across the face.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pliant.api import ConfigError, DimensionError, Learner, box_tetrahedra, option, tetrahedron_volumes, write_vtk


@dataclass(frozen=True)
class PressOptions:
    """Options of the ``press-deformability`` learner (SI units)."""

    known: float = option(0.5, "deformability of the known reference object", minimum=1e-6, maximum=1.0)
    force: float = option(1.0, "the indenter's pulling force (N)", minimum=1e-6)
    repetitions: int = option(30, "presses per object, averaged (thesis: 30)", minimum=1)
    size: float = option(0.1, "edge of each cubic object (m)", minimum=1e-3)
    cells: int = option(4, "hexahedral cells per edge of the mesh (5 tetrahedra each)", minimum=1)
    mu0: float = option(90.0, "Neo-Hookean mu at deformability 1 (Pa); an object of deformability d has mu0 / d",
                        minimum=1e-6)
    lambda0: float = option(300.0, "Neo-Hookean lambda at deformability 1 (Pa)", minimum=0.0)
    time_step: float = option(1 / 480, "simulation step (s)", minimum=1e-6)
    steps: int = option(900, "steps from first contact to the measurement", minimum=1)
    jitter: float = option(0.005, "largest sideways offset of the indenter per repetition (m)", minimum=0.0)


def press(deformability: float, options: PressOptions, rng: np.random.Generator) -> float:
    """Volume change (m^3) of a soft cube of ``deformability`` held at one face and pressed on the opposite one."""
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    o = options
    nodes0, tets = box_tetrahedra(o.size, o.cells)
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
                                   NeoHookeanDamping=0.05, collisionMargin=0.002, useSelfCollision=0,
                                   frictionCoeff=0.5)
            pb.stepSimulation()
            nodes = _nodes(pb, body)
            for k in np.flatnonzero(nodes[:, 0] > nodes[:, 0].max() - 1e-6):       # hold the far face
                pb.createSoftBodyAnchor(body, int(k), -1, -1)
            side = rng.uniform(-o.jitter, o.jitter, 2)
            half = 0.1 * o.size
            shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[half, 0.7 * o.size, 0.7 * o.size])
            start = [-2 * half, side[0], side[1]]
            indenter = pb.createMultiBody(0.2, shape, basePosition=start)
            hold = pb.createConstraint(indenter, -1, -1, -1, pb.JOINT_FIXED, [0, 0, 0], [0, 0, 0], start)
            pb.changeConstraint(hold, [0.4 * o.size, side[0], side[1]], maxForce=o.force)
            for _ in range(o.steps):
                pb.stepSimulation()
            return float(np.sum(np.abs(tetrahedron_volumes(_nodes(pb, body), tets) - rest)))
    finally:
        pb.disconnect()


def _nodes(pb, body) -> np.ndarray:
    _, verts = pb.getMeshData(body, flags=pb.MESH_DATA_SIMULATION_MESH)
    return np.asarray(verts, dtype=np.float64)


class PressDeformabilityLearner(Learner):
    """Deformability of unknown objects from presses against a known reference (thesis appendix A).

    ``fit(data, rng)``: ``data`` maps each unknown object's name to the deformability its simulated body is given
    (the hidden ground truth: the learner sees only volume changes).  Returns ``deformability`` ``{name:
    estimate}``, ``volume_change`` ``{name: mean m^3}`` and ``reference`` (the known object's mean, m^3).
    """

    Options = PressOptions
    example_options = {"repetitions": 1, "steps": 300}
    example_data = staticmethod(lambda: {"soft": 0.75, "stiff": 0.25})

    def fit(self, data, rng: np.random.Generator) -> dict:
        if not isinstance(data, dict) or not data:
            raise DimensionError("needs a non-empty {object: deformability} of the objects to probe",
                                 field="learner.data", value=data)
        for name, d in data.items():
            if isinstance(d, bool) or not isinstance(d, (int, float)) or not 0 < d <= 1:
                raise ConfigError("a deformability must be in (0, 1]", field=f"learner.data.{name}", value=d)
        o = self.options
        reference = float(np.mean([press(o.known, o, rng) for _ in range(o.repetitions)]))
        changes = {name: float(np.mean([press(float(d), o, rng) for _ in range(o.repetitions)]))
                   for name, d in data.items()}
        return {"deformability": {name: o.known * v / reference for name, v in changes.items()},
                "volume_change": changes, "reference": reference}
