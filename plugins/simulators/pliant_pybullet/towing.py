"""Towing a soft cube along a path in pybullet and measuring its deformation (thesis 3.3.4).

The thesis validates the voxel cost of deformation in Bullet: "the deformable robot is modelled
using a tetrahedral mesh anchored to a small rigid body.  This setup allows the soft robot to be
towed along the path produced by the planner.  Deformation is assessed by computing the current
volume of each tetrahedron ... and comparing [it] against that of an undeformed reference mesh."

Here the soft part of the scene's robot (the cube-wall cube: a 0.2 m box) becomes a tetrahedral
soft body (:mod:`pliant_pybullet.softbody`) whose node planes include the faces of the rigid part
(the 0.06 m core); the nodes inside the core are anchored (``createSoftBodyAnchor``) to a small
rigid body that is driven kinematically along the path: between consecutive states its pose is
interpolated (linear in position, slerp in orientation) at ``speed``, and every physics step the
core's velocity is set so that it reaches the interpolated pose by the end of the step (setting its
pose directly, teleporting it, makes Bullet's anchors inject energy and the soft body blow up).
At each state the world is stepped until the nodes' RMS speed is below ``settle_speed`` (or
``max_settle_steps`` pass; in sliding contact Bullet's nodes jitter at a few cm/s and some never
settle by the maximum-speed criterion), then the deformation (sum of absolute per-tetrahedron volume changes,
m^3) is recorded.  The path's total is the thesis's "integral of
costs incurred at each state" (Table 3.1): the sum of the per-state deformations.

The static geometry is the scene's voxel grid merged into boxes (:meth:`VoxelGrid.boxes`), as in
the rigid-body backend.  pybullet is imported only when a :class:`Tower` is created.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
from pliant.api import (
    ConfigError,
    DimensionError,
    Scene,
    SimulationError,
    option,
    quat_angle,
    quat_conjugate,
    quat_multiply,
    quat_slerp,
    quat_to_matrix,
    quat_to_rotvec,
)

from pliant_pybullet.softbody import SoftBox, box_tetrahedra


@dataclass(frozen=True)
class TowingOptions:
    """Options of :class:`Tower` (thesis 3.3.4; Bullet's settings are not given by the thesis)."""

    cells: tuple[int, int, int] = option((5, 4, 4), "hexahedral cells per axis of the soft mesh, 5 tetrahedra "
                                         "each ((5, 4, 4): the thesis's 400 tetrahedra)")
    mass: float = option(1.0, "mass of the soft body (kg)", minimum=1e-9)
    mu: float = option(180.0, "Neo-Hookean shear modulus of the soft body (Pa)", minimum=1e-9)
    lam: float = option(600.0, "Neo-Hookean Lame lambda of the soft body (Pa)", minimum=1e-9)
    damping: float = option(0.1, "Neo-Hookean damping (s)", minimum=0.0)
    friction: float = option(0.5, "soft-rigid friction coefficient", minimum=0.0)
    margin: float = option(0.002, "collision margin of the soft body (m)", minimum=0.0)
    time_step: float = option(1 / 240, "physics step (s)", minimum=1e-6, maximum=0.1)
    speed: float = option(0.1, "towing speed of the core between states (m/s)", minimum=1e-6)
    angular_speed: float = option(1.0, "towing angular speed of the core between states (rad/s)", minimum=1e-6)
    settle_speed: float = option(0.01, "a state is settled when the nodes' RMS speed is below this (m/s)",
                                 minimum=0.0)
    min_settle_steps: int = option(2, "physics steps at least spent at each state", minimum=1)
    max_settle_steps: int = option(60, "physics steps at most spent settling at each state", minimum=1)
    tracking_tolerance: float = option(0.005, "largest distance (m) of an anchored node from where the core "
                                       "puts it for the core to count as tracking the path", minimum=0.0)

    def validate(self) -> None:
        """Cross-field checks (raise :class:`ConfigError` naming the field)."""
        cells = np.asarray(self.cells)
        if cells.shape != (3,) or not np.issubdtype(cells.dtype, np.integer) or np.any(cells < 2):
            raise ConfigError("three integers >= 2 (the core's faces must fall inside the mesh)", field="cells",
                              value=list(np.atleast_1d(self.cells)))
        if self.max_settle_steps < self.min_settle_steps:
            raise ConfigError("must be >= min_settle_steps", field="max_settle_steps", value=self.max_settle_steps)


@dataclass(frozen=True)
class SoftCube:
    """The soft robot of a scene: a soft box and a rigid core, both in the robot frame (m).

    ``center``/``size``: the soft box; ``core_lower``/``core_upper``: the rigid core's bounds.
    """

    center: np.ndarray
    size: np.ndarray
    core_lower: np.ndarray
    core_upper: np.ndarray


def soft_cube_from_scene(scene: Scene) -> SoftCube:
    """The soft box (the first deformable box part) and rigid core (the first rigid part) of ``scene``'s robot.

    Raises :class:`SimulationError` naming the field when the robot is not a rigid-kind body made of an
    axis-aligned deformable box around a rigid part (thesis 3.3.3's cube).
    """
    robot = scene.robot
    if robot.kind != "rigid":
        raise SimulationError("towing needs a free-flying robot built from parts", source=scene.source,
                              field="robot.kind", value=robot.kind)
    soft = core = None
    for k, rp in enumerate(robot.parts):
        if rp.material.deformability > 0 and soft is None:
            if rp.part.shape.kind != "box" or rp.part.cutouts:
                raise SimulationError("the soft part must be a box without cut-outs", source=scene.source,
                                      field=f"robot.parts[{k}].shape", value=rp.part.shape.kind)
            if not np.allclose(rp.part.pose.orientation, [0, 0, 0, 1]):
                raise SimulationError("the soft box must be axis-aligned in the robot frame", source=scene.source,
                                      field=f"robot.parts[{k}].orientation", value=rp.part.pose.orientation.tolist())
            soft = rp.part
        elif rp.material.deformability == 0 and core is None:
            core = rp.part
    if soft is None:
        raise SimulationError("the robot has no deformable box part to simulate as a soft body",
                              source=scene.source, field="robot.parts")
    if core is None:
        raise SimulationError("the robot has no rigid part (deformability 0) to anchor the soft body to",
                              source=scene.source, field="robot.parts")
    lo, hi = core.bounds()
    s_lo, s_hi = soft.bounds()
    if np.any(lo <= s_lo) or np.any(hi >= s_hi):
        raise SimulationError("the rigid core must lie strictly inside the soft box", source=scene.source,
                              field="robot.parts", value=[lo.tolist(), hi.tolist()])
    return SoftCube(center=np.array(soft.pose.position, dtype=np.float64),
                    size=np.array(soft.shape.size, dtype=np.float64), core_lower=lo, core_upper=hi)


@dataclass
class TowingResult:
    """Deformation of a soft cube towed along a path (thesis 3.3.4, Table 3.1 "Sim. cost").

    deformation: ``(k,)`` sum of absolute per-tetrahedron volume changes at each path state, after
        settling (m^3).
    total: the integral over the path as Table 3.1 defines it, the sum of ``deformation`` (m^3).
    settle_steps: ``(k,)`` physics steps spent settling at each state (``max_settle_steps`` = not settled).
    steps: all physics steps (towing and settling).
    core_error: ``(k,)`` largest distance of an anchored node from its place on the core at each state (m).
    tracked: every ``core_error`` within the tolerance (the soft body followed its core).
    contacts: ``(k,)`` soft-body contact points at each state.
    seconds: wall time (s).
    """

    deformation: np.ndarray
    total: float
    settle_steps: np.ndarray
    steps: int
    core_error: np.ndarray
    tracked: bool
    contacts: np.ndarray
    seconds: float
    interrupted: bool = False

    def to_dict(self) -> dict:
        """JSON-ready dictionary."""
        return {f.name: (v.tolist() if isinstance(v := getattr(self, f.name), np.ndarray) else v)
                for f in dataclasses.fields(self)}


def check_path(path, source: str = "path") -> np.ndarray:
    """An SE(3) path ``(k, 7)`` (x, y, z, qx, qy, qz, qw) as float64, or a :class:`DimensionError`."""
    q = np.asarray(path, dtype=np.float64)
    if q.ndim == 1 and q.shape[0] == 7:
        q = q[None]
    if q.ndim != 2 or q.shape[1] != 7 or len(q) == 0:
        raise DimensionError("an SE(3) path is (k, 7): x, y, z, qx, qy, qz, qw", field=source, value=list(q.shape))
    bad = np.flatnonzero(~np.all(np.isfinite(q), axis=1))
    if bad.size:
        raise DimensionError("non-finite configuration", field=f"{source}[{bad[0]}]", value=q[bad[0]].tolist())
    norms = np.linalg.norm(q[:, 3:], axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-6)
    if bad.size:
        raise DimensionError("quaternion is not unit norm", field=f"{source}[{bad[0]}]", value=q[bad[0]].tolist())
    return q


class Tower:
    """A pybullet world with the scene's static geometry and the scene robot as a towed soft cube.

    ``options`` a :class:`TowingOptions` (or a dict of its fields).  :meth:`tow` drags the cube along
    a path and measures its deformation; :meth:`close` disconnects (also on ``with``).  Thesis 3.3.4.
    """

    def __init__(self, scene: Scene, options: TowingOptions | dict | None = None) -> None:
        from pliant.api import build_options

        if isinstance(options, TowingOptions):
            options.validate()
            self.options = options
        else:
            self.options = build_options(TowingOptions, options, source="towing")
        self.scene = scene
        self.cube = soft_cube_from_scene(scene)
        self.client = None
        self._build_walls()

    # --- the world -------------------------------------------------------------------------------

    def _build_walls(self) -> None:
        import pybullet
        from pliant.api import VoxelGrid
        from pybullet_utils.bullet_client import BulletClient

        self.client = pb = BulletClient(connection_mode=pybullet.DIRECT)
        pb.resetSimulation(pb.RESET_USE_DEFORMABLE_WORLD)
        pb.setGravity(0, 0, 0)
        pb.setTimeStep(self.options.time_step)
        for lo, hi in VoxelGrid.from_scene(self.scene).boxes():
            shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=((hi - lo) / 2).tolist())
            wall = pb.createMultiBody(0, shape, basePosition=((hi + lo) / 2).tolist())
            pb.changeDynamics(wall, -1, lateralFriction=self.options.friction)
        self.soft = None

    def _place(self, q: np.ndarray) -> None:
        """Create the soft cube and its anchored core at configuration ``q`` (7,)."""
        pb, o, c = self.client, self.options, self.cube
        snap = (c.core_lower - c.center, c.core_upper - c.center)
        nodes, tets = box_tetrahedra(c.size, tuple(int(v) for v in o.cells), snap=snap)
        self.local = nodes + c.center                          # node positions in the robot frame (m)
        # the soft body's frame is the robot frame: its mesh is given in the robot frame
        self.soft = SoftBox(pb, mesh=(self.local, tets), position=q[:3].tolist(), orientation=q[3:].tolist(),
                            mass=o.mass, stiffness=(o.mu, o.lam), friction=o.friction, damping=o.damping,
                            margin=o.margin)
        size = (c.core_upper - c.core_lower) / 2
        core_shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=size.tolist())
        self.core = pb.createMultiBody(0.1, core_shape, basePosition=q[:3].tolist(), baseOrientation=q[3:].tolist())
        pb.setCollisionFilterGroupMask(self.core, -1, 0, 0)   # the core touches nothing; it only carries anchors
        tol = 1e-9
        inside = np.all((self.local >= c.core_lower - tol) & (self.local <= c.core_upper + tol), axis=1)
        self.anchored = np.flatnonzero(inside)
        if self.anchored.size == 0:
            raise SimulationError("no mesh node lies inside the rigid core", field="cells", value=list(o.cells))
        for node in self.anchored:
            pb.createSoftBodyAnchor(self.soft.body, int(node), self.core, -1)

    def _drive(self, q: np.ndarray) -> None:
        """Set the core's velocity so that it reaches pose ``q`` (7,) at the end of the next step."""
        pos, orn = self.client.getBasePositionAndOrientation(self.core)
        dt = self.options.time_step
        velocity = (q[:3] - np.asarray(pos)) / dt
        omega = quat_to_rotvec(quat_multiply(q[3:], quat_conjugate(np.asarray(orn, dtype=np.float64)))) / dt
        self.client.resetBaseVelocity(self.core, velocity.tolist(), omega.tolist())

    def _core_error(self, nodes: np.ndarray, q: np.ndarray) -> float:
        expected = self.local[self.anchored] @ quat_to_matrix(q[3:]).T + q[:3]
        return float(np.max(np.linalg.norm(nodes[self.anchored] - expected, axis=1)))

    def _move(self, a: np.ndarray, b: np.ndarray) -> int:
        """Drive the core from ``a`` to ``b`` at the towing speeds; returns the steps taken."""
        o = self.options
        dist = float(np.linalg.norm(b[:3] - a[:3]))
        angle = float(quat_angle(a[3:], b[3:]))
        n = max(1, math.ceil(max(dist / o.speed, angle / o.angular_speed) / o.time_step))
        for k in range(1, n + 1):
            t = k / n
            self._drive(np.concatenate([a[:3] + t * (b[:3] - a[:3]), quat_slerp(a[3:], b[3:], np.array(t))]))
            self.client.stepSimulation()
        return n

    def _settle(self, q: np.ndarray) -> tuple[int, np.ndarray]:
        o = self.options
        previous = self.soft.nodes()
        for k in range(1, o.max_settle_steps + 1):
            self._drive(q)
            self.client.stepSimulation()
            nodes = self.soft.nodes()
            speed = float(np.sqrt(np.mean(np.sum((nodes - previous) ** 2, axis=1)))) / o.time_step
            previous = nodes
            if k >= o.min_settle_steps and speed < o.settle_speed:
                return k, nodes
        return o.max_settle_steps, previous

    # --- public ----------------------------------------------------------------------------------

    def tow(self, path, progress=None) -> TowingResult:
        """Tow the soft cube along ``path`` ``(k, 7)`` and measure its deformation at each state.

        The cube is created undeformed at ``path[0]`` (which should be in free space: a cube created
        overlapping the wall is pushed out of it, not squeezed).  ``progress(i, k)``, if given, is
        called after each state.  Ctrl-C stops the towing and returns the states done so far with
        ``interrupted`` set.  Thesis 3.3.4.
        """
        q = check_path(path)
        t0 = time.perf_counter()
        if self.soft is not None:                     # a fresh world for every path
            self.close()
            self._build_walls()
        self._place(q[0])
        deformation, settle, errors, contacts = [], [], [], []
        steps = 0
        interrupted = False
        try:
            for i in range(len(q)):
                if i > 0:
                    steps += self._move(q[i - 1], q[i])
                n, nodes = self._settle(q[i])
                steps += n
                settle.append(n)
                deformation.append(self.soft.deformation(nodes))
                errors.append(self._core_error(nodes, q[i]))
                contacts.append(len(self.client.getContactPoints(bodyA=self.soft.body)))
                if progress is not None:
                    progress(i + 1, len(q))
        except KeyboardInterrupt:
            interrupted = True
        d = np.array(deformation, dtype=np.float64)
        err = np.array(errors, dtype=np.float64)
        return TowingResult(deformation=d, total=float(d.sum()), settle_steps=np.array(settle, dtype=np.int64),
                            steps=steps, core_error=err,
                            tracked=bool(err.size == len(q) and np.all(err <= self.options.tracking_tolerance)),
                            contacts=np.array(contacts, dtype=np.int64), seconds=time.perf_counter() - t0,
                            interrupted=interrupted)

    def assess(self, q) -> dict:
        """Deformation of one configuration ``q`` (7,): create the cube there and step until it settles.

        What it takes the simulator to assess one configuration (thesis 3.3.5's comparison with the
        voxel cost).  A cube created overlapping the wall is pushed out of it around its held core.
        Returns ``deformation`` (m^3), ``steps``, ``settled`` (before ``max_settle_steps``),
        ``create_s`` and ``settle_s`` (wall time, s) and ``contacts``.
        """
        q = check_path(q, "configuration")[0]
        if self.soft is not None:
            self.close()
            self._build_walls()
        t0 = time.perf_counter()
        self._place(q)
        t1 = time.perf_counter()
        steps, nodes = self._settle(q)
        t2 = time.perf_counter()
        return {"deformation": self.soft.deformation(nodes), "steps": steps,
                "settled": steps < self.options.max_settle_steps, "create_s": t1 - t0, "settle_s": t2 - t1,
                "contacts": len(self.client.getContactPoints(bodyA=self.soft.body))}

    def close(self) -> None:
        """Disconnect the pybullet client."""
        if self.client is not None:
            self.client.disconnect()
            self.client = None
            self.soft = None

    def __enter__(self) -> Tower:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def tow(scene: Scene, path, options: TowingOptions | dict | None = None, progress=None) -> TowingResult:
    """Tow the scene's soft robot along ``path`` ``(k, 7)`` in a fresh pybullet world (thesis 3.3.4)."""
    with Tower(scene, options) as tower:
        return tower.tow(path, progress=progress)
