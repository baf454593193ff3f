"""Scene descriptions and their TOML format.

A scene holds the workspace bounds and voxel resolution, the objects (a shape, a pose and a
material each), optional hand-labelled convex regions, the robot and the task (start and goal).
The format is documented in docs/scenes.md; :func:`load_scene` reads a bundled scene by name or a
TOML file and validates every field, raising :class:`~pliant.errors.SceneError` that names
``file:field`` and the offending value.

Materials follow thesis ch. 3.2.1: *deformability* in [0, 1] (0 rigid, 1 empty space) and
*sensitivity* >= 0 (cost per unit of deformation), or NaN for "forbidden" (any overlap is infeasible).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pliant.errors import SceneError
from pliant.geometry.rotations import UNIT_QUATERNION_TOLERANCE, quat_to_matrix
from pliant.geometry.shapes import Box, Cylinder, Mesh, Shape, Sphere, VoxelArray
from pliant.physics import PhysicsReader, ScenePhysics
from pliant.task import Task, read_task
from pliant.validation import Fields, read_toml, size_limit

ROBOT_SPACES = ("r3", "se2", "se3")


#: the most voxels a scene's grid may have (a 2000 x 2000 x 16 grid; the bundled scenes have at most 4.5 million);
#: checked before anything is allocated.  Raise it with the environment variable PLIANT_MAX_GRID_CELLS.
MAX_GRID_CELLS = 64_000_000

@dataclass(frozen=True)
class Material:
    """Per-voxel physical parameters (thesis eq. 3.1).

    deformability: in [0, 1]; 0 is rigid, 1 is empty space.
    sensitivity: >= 0, cost per unit deformation; NaN marks a forbidden object.
    """

    deformability: float = 0.0
    sensitivity: float = 1.0

    @property
    def forbidden(self) -> bool:
        return math.isnan(self.sensitivity)


FREE_SPACE = Material(deformability=1.0, sensitivity=0.0)


@dataclass(frozen=True)
class Pose:
    """A rigid placement: ``position`` (3,) in metres and unit quaternion ``orientation`` (qx, qy, qz, qw)."""

    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    orientation: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0]))

    @property
    def rotation(self) -> np.ndarray:
        return quat_to_matrix(self.orientation)

    def to_local(self, points: np.ndarray) -> np.ndarray:
        """World points ``(n, 3)`` expressed in this pose's frame."""
        return (np.asarray(points, dtype=np.float64) - self.position) @ self.rotation

    def to_world(self, points: np.ndarray) -> np.ndarray:
        """Points ``(n, 3)`` of this pose's frame expressed in the world frame."""
        return np.asarray(points, dtype=np.float64) @ self.rotation.T + self.position


@dataclass(frozen=True)
class Part:
    """A shape placed by a pose, minus optional cut-outs (each a shape with its own pose)."""

    shape: Shape
    pose: Pose
    cutouts: tuple[Part, ...] = ()

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Bool ``(n,)``: which points ``(n, 3)`` (in the parent frame) lie in the part."""
        points = np.asarray(points, dtype=np.float64)
        inside = self.shape.contains(self.pose.to_local(points))
        for cut in self.cutouts:
            if inside.any():
                inside &= ~cut.contains(points)
        return inside

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds of the part in the parent frame."""
        lo, hi = self.shape.bounds()
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        world = self.pose.to_world(corners)
        return world.min(axis=0), world.max(axis=0)


@dataclass(frozen=True)
class SceneObject:
    """A named solid of the environment with its material.

    mass: kg (> 0) for a movable object that dynamic simulators push around; ``None`` (the default) for
    a static object, fixed to the world.  Planners, the voxel cost and the kinematic simulator treat a
    movable object as an obstacle at its scene pose.
    friction: Coulomb friction coefficient (>= 0) of the object's surface; ``None`` leaves it to the
    simulator's default.
    """

    name: str
    part: Part
    material: Material
    mass: float | None = None
    friction: float | None = None

    @property
    def movable(self) -> bool:
        """True when the object has a mass (a dynamic body), False when it is fixed to the world."""
        return self.mass is not None

    def contains(self, points: np.ndarray) -> np.ndarray:
        return self.part.contains(points)


@dataclass(frozen=True)
class Region:
    """A hand-labelled convex region, an axis-aligned box ``[lower, upper]`` in world metres (thesis 5.3.3)."""

    name: str
    lower: np.ndarray
    upper: np.ndarray

    def contains(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=np.float64)[..., : len(self.lower)]
        return np.all((p >= self.lower) & (p <= self.upper), axis=-1)


@dataclass(frozen=True)
class RobotPart:
    """One solid of a rigid-body robot, in the robot's frame, with its material."""

    part: Part
    material: Material


@dataclass(frozen=True)
class RobotSpec:
    """What the scene says about the robot.

    kind: ``"rigid"`` (a free-flying body built from ``parts``) or ``"urdf"`` (a named or file URDF).
    space: for rigid bodies, ``"r3"`` (translation only), ``"se2"`` or ``"se3"``.
    model / group: for URDF robots, the robot name (``"baxter"``) or URDF path, and the joint group.
    """

    kind: str
    name: str
    space: str | None = None
    parts: tuple[RobotPart, ...] = ()
    material: Material = Material()
    model: str | None = None
    group: str | None = None
    weights: np.ndarray | None = None


@dataclass
class Scene:
    """A complete scene: workspace, objects, regions, robot and task.

    Attributes are read-only by convention; build scenes with :func:`load_scene` or
    :meth:`Scene.from_dict`.  Lengths in metres.
    """

    name: str
    lower: np.ndarray
    upper: np.ndarray
    resolution: float
    objects: list[SceneObject]
    robot: RobotSpec
    start: np.ndarray
    goal: np.ndarray
    regions: list[Region] = field(default_factory=list)
    planar: bool = False
    goal_tolerance: float = 0.0
    description: str = ""
    source: str = "<dict>"
    variant: str | None = None
    variants: tuple[str, ...] = ()
    pipeline: dict = field(default_factory=dict)
    physics: ScenePhysics = field(default_factory=ScenePhysics)   # pliant.physics
    raw: dict = field(default_factory=dict, repr=False)
    #: a robot-independent task (:class:`pliant.task.Task`): start and goal are empty until a pipeline resolves it
    task: Task | None = None

    @property
    def shape(self) -> tuple[int, int, int]:
        """Voxel grid shape ``(nx, ny, nz)`` at :attr:`resolution`."""
        return tuple(round(float(v)) for v in (self.upper - self.lower) / self.resolution)

    def object(self, name: str) -> SceneObject:
        for obj in self.objects:
            if obj.name == name:
                return obj
        raise SceneError("no object of that name", source=self.source, field="objects", value=name)

    @classmethod
    def from_dict(cls, data: dict, source: str = "<dict>", base_dir: Path | None = None,
                  variant: str | None = None) -> Scene:
        """Validate a parsed scene table (the TOML layout) and build the scene."""
        return _SceneReader(data, source, base_dir or Path.cwd(), variant).read()


def bundled_scenes_dir() -> Path:
    """The directory of the scenes shipped with pliant."""
    import pliant_scenes  # a data-only package mapped to the repository's scenes/ directory

    return Path(pliant_scenes.__file__).parent


def available_scenes() -> list[str]:
    """Names of the bundled scenes."""
    return sorted(p.stem for p in bundled_scenes_dir().glob("*.toml") if not p.stem.startswith("_"))


def resolve_scene_path(name_or_path: str | Path) -> Path:
    """A bundled scene's file from its name, or the given path; raises if neither exists."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or _is_file(path):
        if not _is_file(path):
            raise SceneError("scene file does not exist", source=str(path), field="<file>", value=str(path))
        return path
    candidate = bundled_scenes_dir() / f"{name_or_path}.toml"
    if _is_file(candidate):
        return candidate
    raise SceneError(f"no bundled scene or file of that name (bundled: {', '.join(available_scenes())})",
                     source=str(name_or_path), field="<scene>", value=str(name_or_path))


def _is_file(path: Path) -> bool:
    """``path.is_file()`` that answers False for names the OS rejects (too long, NUL bytes)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def load_scene(name_or_path: str | Path, variant: str | None = None) -> Scene:
    """Load a bundled scene by name (``"triple-wall"``) or a TOML scene file.

    ``variant`` selects one of the file's ``[variants.NAME]`` patches (e.g. a soft robot).
    ``"name:variant"`` is accepted as a shorthand.  Raises :class:`SceneError` on any bad field.
    """
    text = str(name_or_path)
    if variant is None and ":" in text and not _is_file(Path(text)) and not text.endswith(".toml"):
        text, variant = text.split(":", 1)
    path = resolve_scene_path(text)
    data = read_toml(path, SceneError)
    return Scene.from_dict(data, source=str(path), base_dir=path.parent, variant=variant)


def apply_patch(data: dict, patch: dict, source: str, field_prefix: str) -> dict:
    """Apply ``{"objects.wall1.deformability": 1.0, ...}`` to a scene table (a deep copy).

    Path segments walk tables; a segment after ``objects`` or ``robot.parts`` names an entry by its
    ``name`` (``*`` for every entry).  A key ending in ``+`` appends tables to an array
    (``"objects+" = [{name = "block", ...}]``).  Unknown paths raise :class:`SceneError`.
    """
    out = copy.deepcopy(data)
    for key, value in patch.items():
        if key.endswith("+"):
            target = key[:-1]
            if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
                raise SceneError("an appending patch takes an array of tables", source=source,
                                 field=f"{field_prefix}.{key}", value=value)
            holder = out
            segments = target.split(".")
            for seg in segments[:-1]:
                holder = holder.get(seg) if isinstance(holder, dict) else None
            existing = holder.get(segments[-1], []) if isinstance(holder, dict) else None
            if not isinstance(existing, list):
                raise SceneError("patch path does not name an array of tables", source=source,
                                 field=f"{field_prefix}.{key}", value=target)
            holder[segments[-1]] = existing + copy.deepcopy(value)
            continue
        parts = key.split(".")
        targets = [out]
        for depth, seg in enumerate(parts[:-1]):
            nxt = []
            for t in targets:
                if isinstance(t, list):
                    hits = [e for e in t if isinstance(e, dict) and (seg == "*" or e.get("name") == seg)]
                    nxt.extend(hits)
                elif isinstance(t, dict) and seg in t:
                    nxt.append(t[seg])
            if not nxt:
                raise SceneError("patch path matches nothing in the scene", source=source,
                                 field=f"{field_prefix}.{key}", value=".".join(parts[: depth + 1]))
            targets = nxt
        for t in targets:
            if not isinstance(t, dict):
                raise SceneError("patch path does not end in a table field", source=source,
                                 field=f"{field_prefix}.{key}", value=key)
            t[parts[-1]] = value
    return out


class _SceneReader:
    def __init__(self, data: Any, source: str, base_dir: Path, variant: str | None) -> None:
        self.source = source
        self.base_dir = base_dir
        top = Fields(data, source, error=SceneError)
        variants_table = top.table("variants", default={})
        self.variant_names = tuple(sorted(variants_table.data))
        if variant is not None:
            if variant not in variants_table.data:
                raise SceneError(f"unknown variant (available: {', '.join(self.variant_names) or 'none'})",
                                 source=source, field="variants", value=variant)
            patch = variants_table.table(variant)
            data = apply_patch(dict(data), dict(patch.data), source, patch.prefix)
            data.pop("variants", None)
            self.top = Fields(data, source, error=SceneError)
        else:
            self.top = top
            self.top.raw("variants", None)
        self.variant = variant

    def read(self) -> Scene:
        top = self.top
        self.physics = PhysicsReader()
        name = top.string("name")
        description = top.string("description", "")
        bounds = top.table("bounds")
        lower = bounds.vector("lower", 3)
        upper = bounds.vector("upper", 3)
        if np.any(upper <= lower):
            bounds.fail("upper", "every upper bound must exceed its lower bound", upper.tolist())
        resolution = bounds.number("resolution", positive=True)
        cells = (upper - lower) / resolution
        if np.any(np.abs(cells - np.round(cells)) > 1e-6 * np.maximum(1.0, cells)):
            bounds.fail("resolution", "the bounds must span a whole number of voxels", resolution)
        limit = size_limit("PLIANT_MAX_GRID_CELLS", MAX_GRID_CELLS)
        total = float(np.prod(np.round(cells)))
        if total > limit:
            bounds.fail("resolution", f"makes a grid of {' x '.join(f'{c:.0f}' for c in np.round(cells))} = "
                        f"{total:.3g} voxels, more than the limit of {limit:,} (a coarser resolution, smaller "
                        "bounds, or set PLIANT_MAX_GRID_CELLS)", resolution)
        bounds.finish()
        self.lower, self.resolution = lower, resolution
        planar = top.boolean("planar", False)
        objects = [self._object(t) for t in top.tables("objects")]
        seen = set()
        for t, obj in zip(top.tables("objects"), objects):
            if obj.name in seen:
                t.fail("name", "object names must be unique", obj.name)
            seen.add(obj.name)
            lo, hi = obj.part.bounds()
            if np.any(hi < lower) or np.any(lo > upper) or not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
                t.fail("position", "places the object wholly outside the scene's bounds (objects partly outside are "
                       f"cut at the bounds): it spans {np.round(lo, 6).tolist()} .. {np.round(hi, 6).tolist()}",
                       t.raw("position") if t.has("position") else None)
        regions = [self._region(t) for t in top.tables("regions")]
        robot = self._robot(top.table("robot"))
        task = read_task(top, robot)        # pliant.task: a robot-independent [task] replaces start and goal
        start = top.vector("start") if task is None else np.zeros(0)
        goal = top.vector("goal") if task is None else np.zeros(0)
        self._check_configuration(top, "start", start, robot, lower, upper)
        self._check_configuration(top, "goal", goal, robot, lower, upper)
        tol = top.number("goal_tolerance", 0.0, minimum=0.0)
        pipeline = top.table("pipeline", default={})   # validated by the pipeline when it is run
        physics = self.physics.finish(top.table("physics", default={}), planar)
        top.finish()
        return Scene(name=name, lower=lower, upper=upper, resolution=resolution, objects=objects, robot=robot,
                     start=start, goal=goal, task=task, regions=regions, planar=planar, goal_tolerance=tol,
                     description=description, source=self.source, variant=self.variant,
                     variants=self.variant_names, pipeline=dict(pipeline.data), physics=physics,
                     raw=dict(top.data))

    # --- pieces -------------------------------------------------------------------------------

    def _material(self, t: Fields, default: Material | None) -> Material:
        d = t.number("deformability", None if default is None else default.deformability, minimum=0.0, maximum=1.0)
        s = t.number("sensitivity", None if default is None else default.sensitivity, minimum=0.0, allow_nan=True)
        if d is None or s is None:
            t.fail("deformability" if d is None else "sensitivity", "is required but missing")
        return Material(deformability=d, sensitivity=s)

    def _pose(self, t: Fields) -> Pose:
        position = t.vector("position", 3, np.zeros(3))
        q = t.vector("orientation", 4, np.array([0.0, 0.0, 0.0, 1.0]))
        if abs(np.linalg.norm(q) - 1.0) > UNIT_QUATERNION_TOLERANCE:
            t.fail("orientation", "quaternion (qx, qy, qz, qw) must have unit norm", q.tolist())
        return Pose(position, q)

    def _cells_box(self, t: Fields, origin: np.ndarray) -> Part:
        raw = t.raw("cells")
        if not (isinstance(raw, list) and len(raw) == 3 and all(isinstance(r, list) and len(r) == 2 for r in raw)):
            t.fail("cells", "must be [[x0, x1], [y0, y1], [z0, z1]] (half-open voxel index ranges)", raw)
        if any(isinstance(v, bool) or not isinstance(v, int) for r in raw for v in r):
            t.fail("cells", "voxel indices must be integers", raw)
        rng = np.array(raw, dtype=np.float64)
        if np.any(rng[:, 1] <= rng[:, 0]):
            t.fail("cells", "each range must be non-empty (x1 > x0)", raw)
        lo = origin + rng[:, 0] * self.resolution
        hi = origin + rng[:, 1] * self.resolution
        # shrink by a hair so that voxel centres on the boundary are classified deterministically
        return Part(Box(hi - lo - 1e-9 * self.resolution), Pose((lo + hi) / 2))

    def _part(self, t: Fields, origin: np.ndarray) -> Part:
        if t.has("cells"):
            part = self._cells_box(t, origin)
        else:
            part = Part(self._shape(t), self._pose(t))
        cutouts = tuple(self._part(c, origin) for c in t.tables("cutouts"))
        return Part(part.shape, part.pose, cutouts)

    def _shape(self, t: Fields) -> Shape:
        kind = t.string("shape", choices={"box", "sphere", "cylinder", "mesh", "voxels"})
        if kind == "box":
            return Box(t.vector("size", 3, positive=True))
        if kind == "sphere":
            return Sphere(t.number("radius", positive=True))
        if kind == "cylinder":
            return Cylinder(t.number("radius", positive=True), t.number("length", positive=True))
        file_name = t.string("file")
        path = (self.base_dir / file_name).resolve()
        if kind == "mesh":
            return Mesh.load(path, t.number("scale", 1.0, positive=True), source=self.source, field_name=t.path("file"))
        return VoxelArray.load(path, t.number("resolution", self.resolution, positive=True), source=self.source,
                               field_name=t.path("file"))

    def _object(self, t: Fields) -> SceneObject:
        name = t.string("name")
        part = self._part(t, self.lower)
        material = self._material(t, None)
        mass = t.number("mass", None, positive=True)
        friction = t.number("friction", None, minimum=0.0)
        self.physics.object(t, name, mass, friction)
        t.finish()
        return SceneObject(name, part, material, mass=mass, friction=friction)

    def _region(self, t: Fields) -> Region:
        name = t.string("name")
        lower = t.vector("lower")
        upper = t.vector("upper", len(lower))
        if np.any(upper <= lower):
            t.fail("upper", "every upper bound must exceed its lower bound", upper.tolist())
        t.finish()
        return Region(name, lower, upper)

    def _robot(self, t: Fields) -> RobotSpec:
        kind = t.string("kind", choices={"rigid", "urdf"})
        name = t.string("name", "robot")
        weights = t.vector("weights", None, None, positive=True)
        if kind == "urdf":
            model = t.string("model")
            group = t.string("group", None)
            material = self._material(t, Material())
            self.physics.robot_fields(t, kind)
            t.finish()
            return RobotSpec(kind=kind, name=name, model=model, group=group, weights=weights, material=material)
        space = t.string("space", choices=set(ROBOT_SPACES))
        material = self._material(t, Material())
        self.physics.robot_fields(t, kind)
        ref = t.vector("reference_cell", 3, np.zeros(3))
        # robot frame origin = centre of the reference voxel; cell (i, j, k) spans [i - ref - 1/2, i - ref + 1/2]
        origin = -(ref + 0.5) * self.resolution
        parts = []
        for p in t.tables("parts", required=True):
            part = self._part(p, origin)
            mat = self._material(p, material)
            p.finish()
            parts.append(RobotPart(part, mat))
        t.finish()
        if not parts:
            t.fail("parts", "a rigid robot needs at least one part", [])
        return RobotSpec(kind=kind, name=name, space=space, parts=tuple(parts), material=material, weights=weights)

    def _check_configuration(self, top: Fields, key: str, q: np.ndarray, robot: RobotSpec, lower, upper) -> None:
        if robot.kind != "rigid":
            return
        size = {"r3": 3, "se2": 3, "se3": 7}[robot.space]
        if q.size != size:
            top.fail(key, f"a {robot.space} robot's configuration has {size} entries", q.tolist())
        if robot.space == "se3" and abs(np.linalg.norm(q[3:]) - 1.0) > UNIT_QUATERNION_TOLERANCE:
            top.fail(key, "quaternion (qx, qy, qz, qw) must have unit norm", q.tolist())
        dims = 2 if robot.space == "se2" else 3
        pos = q[:dims]
        if np.any(pos < lower[:dims]) or np.any(pos > upper[:dims]):
            top.fail(key, f"position lies outside the scene bounds {lower.tolist()} .. {upper.tolist()}", q.tolist())
