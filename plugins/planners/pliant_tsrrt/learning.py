"""LEARN_MODEL in a simulator (poster ICHR 2010, "Model Learning"): per object class and primitive, push an object of
that class repeatedly from its current state until the model's variance falls below ``sigma_ref^2``.

The learning takes place on the table's centre, or the free point of the table farthest from its edges and its fixed
obstacles (the *spot*): the object learned is put there (keeping its
orientation), every other object whose footprint could be reached by the paddle is moved out of the way, and the
object is put back on the spot (still keeping its orientation) whenever it has wandered more than :data:`WANDER`
from it, so that pushes never run off the table or into another object.  Otherwise each push starts where the last one
left the object, as in the pseudo code.  At the end every object is put back where it was.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pliant.api import PlanningError

from pliant_tsrrt.geometry import Footprints
from pliant_tsrrt.models import Displacement, PushModels, object_class, relative
from pliant_tsrrt.options import LearningOptions
from pliant_tsrrt.pushing import PRIMITIVES, PushSettings, apply_action

#: how far (m) the object learned may leave the learning spot before it is put back
WANDER = 0.12


@dataclass
class LearningArena:
    """The world, the movable objects' names and footprints, the table ``(x0, y0, x1, y1)``, the scene bounds
    ``(x0, y0, x1, y1)`` (where objects may be parked while another is learned), the push settings and the fixed
    obstacles as circles ``(centre (2,), radius)`` (m)."""

    world: object
    names: list[str]
    fp: Footprints
    table: tuple[float, float, float, float]
    bounds: tuple[float, float, float, float]
    push: PushSettings
    fixed: list[tuple[np.ndarray, float]] = field(default_factory=list)

    @property
    def spot(self) -> np.ndarray:
        """The learning spot: the point of the table farthest from its edges and from the fixed obstacles (given as
        circles ``(centre, radius)``): the table's centre when nothing stands there."""
        x0, y0, x1, y1 = self.table
        u, v = np.meshgrid(np.linspace(x0, x1, 51), np.linspace(y0, y1, 41), indexing="ij")
        p = np.stack([u.ravel(), v.ravel()], -1)
        room = np.minimum(np.minimum(p[:, 0] - x0, x1 - p[:, 0]), np.minimum(p[:, 1] - y0, y1 - p[:, 1]))
        for centre, radius in self.fixed:
            room = np.minimum(room, np.linalg.norm(p - centre, axis=1) - radius)
        centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        best = np.nonzero(room >= room.max() - 1e-9)[0]
        return p[best[np.argmin(np.linalg.norm(p[best] - centre, axis=1))]]

    def clear_spot(self, index: int, poses: dict[str, np.ndarray], wander: float,
                   rng: np.random.Generator) -> dict[str, np.ndarray]:
        """``poses`` with object ``index`` on the spot and every other object out of the paddle's reach."""
        poses = {n: np.asarray(p, dtype=np.float64).copy() for n, p in poses.items()}
        name = self.names[index]
        poses[name][:2] = self.spot
        radius = self.fp.radius
        s = self.push
        reach = wander + radius[index] + s.push_gap + s.push_depth + s.thickness + 0.5 * s.width + 0.03
        placed = [(self.spot, radius[index] + s.push_gap + s.thickness + s.width)]
        bx0, by0, bx1, by1 = self.bounds
        for j, other in enumerate(self.names):
            if j == index:
                continue
            p = poses[other]
            r = radius[j]
            if (np.linalg.norm(p[:2] - self.spot) >= reach + r
                    and all(np.linalg.norm(p[:2] - c) >= r + rc + 0.01 for c, rc in placed[1:])):
                placed.append((p[:2].copy(), r))
                continue
            for _ in range(2000):
                xy = rng.uniform([bx0 + r + 0.01, by0 + r + 0.01], [bx1 - r - 0.01, by1 - r - 0.01])
                if np.linalg.norm(xy - self.spot) >= reach + r and all(
                        np.linalg.norm(xy - c) >= r + rc + 0.01 for c, rc in placed[1:] + self.fixed):
                    break
            else:
                raise PlanningError("no room to park the other objects away from the learning spot; enlarge the "
                                    "scene's bounds around the table", field="bounds", value=list(self.bounds))
            poses[other][:2] = xy
            placed.append((xy, r))
        return poses


def learn_models(arena: LearningArena, settings: LearningOptions, rng: np.random.Generator,
                 holdout: int = 0, only: list[str] | None = None) -> tuple[PushModels, dict]:
    """LEARN_MODEL for every class among ``arena.names`` (its first object stands for the class; ``only``: the classes
    of these objects only) with the stopping rule of ``settings`` (the ``learning`` options, or the learner's own,
    which hold the same fields); returns the models
    and a report: pushes per class and primitive and, with ``holdout`` > 0, the prediction error of the models on
    that many further pushes per class and primitive (not used for fitting)."""
    world = arena.world
    original = {n: np.asarray(p, dtype=np.float64).copy() for n, p in world.object_poses().items()}
    missing = [n for n in arena.names if n not in original]
    if missing:
        raise PlanningError("the simulator has no movable object of this name", field="objects", value=missing[0])
    models = PushModels()
    report: dict = {"pushes": {}, "holdout": {}}
    ref = np.array([settings.sigma_ref ** 2, settings.sigma_ref ** 2, settings.sigma_ref_angle ** 2])
    seen: dict[str, int] = {}
    for i, name in enumerate(arena.names):
        cls = object_class(name)
        if cls in seen or (only is not None and cls not in {object_class(o) for o in only}):
            continue
        seen[cls] = i
        poses = arena.clear_spot(i, original, WANDER, rng)
        world.set_object_poses(poses)
        models.footprints[cls] = (int(arena.fp.kind[i]), arena.fp.half[i].copy())
        learned = []
        for a in range(len(PRIMITIVES)):
            model = Displacement()
            while model.n < settings.max_pushes and (
                    model.n < settings.min_pushes or np.any(model.mean_variance() > ref)):
                poses = _push(arena, i, a, poses, settings, rng, model)
            learned.append(model)
        models.models[cls] = learned
        report["pushes"][cls] = {p: m.n for p, m in zip(PRIMITIVES, learned)}
        if holdout > 0:
            rows = {}
            for a, p in enumerate(PRIMITIVES):
                test = Displacement()
                for _ in range(holdout):
                    poses = _push(arena, i, a, poses, settings, rng, test)
                obs = np.asarray(test.samples)
                err = obs - learned[a].mean
                sd = learned[a].std
                inside = np.abs(err) <= 1.96 * np.maximum(sd, 1e-12)
                rows[p] = {"translation_error": float(np.mean(np.linalg.norm(err[:, :2], axis=1))),
                           "rotation_error": float(np.mean(np.abs(err[:, 2]))),
                           "displacement": float(np.linalg.norm(learned[a].mean[:2])),
                           "coverage95": float(np.mean(np.all(inside, axis=1)))}
            report["holdout"][cls] = rows
    world.set_object_poses(original)
    return models, report


def _push(arena: LearningArena, i: int, a: int, poses: dict, settings: LearningOptions, rng, model: Displacement):
    """One APPLY_ACTION on object ``i`` from its current state (put back on the spot if it wandered off), and
    UPDATE_DISTR with the displacement seen."""
    name = arena.names[i]
    if np.linalg.norm(poses[name][:2] - arena.spot) > WANDER:
        poses = arena.clear_spot(i, poses, WANDER, rng)
    before = poses[name].copy()
    after = apply_action(arena.world, arena.names, arena.fp, i, a, arena.push, rng, poses)
    model.update(relative(before, after[name]))
    return after
