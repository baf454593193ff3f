"""Recovered parameter verification (thesis 4.3.4): plan each demonstration task with RRT* and compare.

The task is planned in the scene with the *recovered* sensitivities by the registered ``rrtstar`` planner (looked
up by name through the registry: plugins do not import each other) with the puncture and cut check on, the
task-space goal "the tip touches the target" and the task's collision planes as a validity constraint, as in the
chapter; then the path is shortcut (:mod:`pliant.planning.shortcut`, cost-aware, every shortcut checked for punctures
and cuts along the whole path), the post-processing step of sampling planners.  The chapter planned for 30 and 60
minutes per task with RRT* alone; the budget here is an option (iterations or seconds).  With ``refine_rounds`` the
shortcut path is then improved by local search in the recovered cost (:func:`refine` with :data:`REFINE`): the
sample paths of thesis 4.3.1 and rigid turns of the path's tail about the target drawn around it, the cheapest kept
when it is cheaper and free of punctures, with the noise adapting to success -- the local optimisation a
trajectory optimiser (STOMP, which the chapter's sampling follows) does after a sampling planner.  With
``straight`` the local search starts from the cheaper of that path and the recovered values' best straight insertion
(:func:`straight_insertion`), as a trajectory optimiser starts from a simple initial guess.  The ground truth is
never read while planning or refining.
The planned path and the demonstration are then both measured in the scene's *true* sensitivities: the deformation
of each object and the cost ``S . V``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pliant.api import PlanningError

from pliant_piirl.demonstration import Demonstration, DemonstrationTask


def scene_with(scene, sensitivities: dict[str, float]):
    """``scene`` with the given per-object sensitivities (deformabilities kept)."""
    objects = [dataclasses.replace(o, material=dataclasses.replace(o.material,
                                                                  sensitivity=float(sensitivities[o.name])))
               for o in scene.objects]
    return dataclasses.replace(scene, objects=objects)


def plan_task(scene, sensitivities: dict[str, float], demonstration: Demonstration, tip, rng: np.random.Generator,
              *, max_time: float | None, shortcut_iterations: int = 300, planner_options: dict | None = None,
              planner: str = "rrtstar", refine_rounds: int = 0, straight: bool = False):
    """RRT* (puncture check on) for ``demonstration``'s task in ``scene`` with ``sensitivities``; the planner's
    result and its path after cost-aware shortcutting and ``refine_rounds`` of :func:`refine` with :data:`REFINE`
    in the cost of ``sensitivities`` (``None`` without a path or with no shortcut iterations).  ``max_time``: RRT*'s
    budget in seconds (None: the iteration budget in ``planner_options``, ``max_iterations``).

    ``straight``: for a task that ends with the tip on a target in SE(3), also plan the cheapest straight insertion
    in the cost of ``sensitivities`` (:func:`straight_insertion`) and start the local search from whichever of it
    and the shortcut RRT* path is cheaper in that cost (a straight insertion with a puncture or cut is not used).
    The choice and both costs are in ``result.statistics["verification"]``."""
    from pliant import api
    from pliant.api import Budget, Context, PlanningProblem

    context = Context(scene=scene_with(scene, sensitivities))
    context.robot = api.registry.create("robot", "rigid", context)
    context.cost = api.registry.create("cost", "voxel", context)
    task = demonstration.task
    if planner == "rrtstar":
        options = {"puncture_check": True, "progress": False, "max_step": 0.02, **(planner_options or {})}
    else:
        options = dict(planner_options or {})
    # the request's budget: planner_options' max_iterations (a work budget) and max_time (s, a cap; None: none)
    budget = Budget(max_time=max_time if planner == "rrtstar" else options.pop("max_time", None),
                    max_iterations=options.pop("max_iterations", None))
    if planner == "rrtstar":
        options.pop("max_time", None)
    if task.goal is None:                            # "the tip touches the target", as the chapter plans
        options.update({"target": tuple(task.target), "tip": tuple(tip), "target_tolerance": 0.004})
    planner = api.registry.create("planner", planner, context, **options)
    robot = context.robot

    def inside_funnel(q: np.ndarray) -> np.ndarray:
        return task.allows(robot.body_points(q)).all(axis=1)

    goal = task.start if task.goal is None else task.goal
    problem = PlanningProblem(space=context.space, start=task.start, goal=goal, goal_tolerance=scene.goal_tolerance,
                              cost=context.cost, robot=robot, scene=context.scene,
                              # no collision planes (the planar scene's tasks): every state is inside, and placing
                              # the body's points to say so was a tenth of Table 4.2's planning
                              validity=inside_funnel if len(task.planes) else None,
                              budget=budget)
    result = planner.plan(problem, rng)
    straight = straight and task.goal is None and context.space.tangent_dim == 6
    if (result.path is None and not straight) or shortcut_iterations == 0:
        return result, None
    from pliant.api import PunctureChecker, VoxelGrid, arc_margin, shortcut

    checker = PunctureChecker(VoxelGrid.from_scene(context.scene), robot.body_points,
                              arc_margin=arc_margin(context.scene, context.space))
    path = None
    if result.path is not None:
        path, _ = shortcut(problem, result.path.configurations, rng, step=scene.resolution / 2,
                           iterations=shortcut_iterations, check=lambda q: checker.check(q)[0])
    if not (straight or refine_rounds):
        return result, path
    from pliant_piirl.features import DeformationFeatures

    features = DeformationFeatures(context.scene)       # only the straight start and the local search read it
    weights = features.sensitivity_vector(sensitivities)

    def intact(candidate: np.ndarray) -> bool:
        return bool(checker.check(features.states(candidate))[0])

    if straight:
        path = _cheaper_start(path, straight_insertion(features, sensitivities, task, tip), features, weights,
                              intact, result.statistics)
        if path is None:
            return result, None
    if refine_rounds:
        path = refine(path, demonstration.task, features, weights, tip, rng, rounds=refine_rounds, check=intact,
                      **REFINE)
    return result, path


def straight_insertion(features, sensitivities: dict[str, float], task, tip) -> np.ndarray | None:
    """The cheapest straight insertion for ``task`` in the cost of ``sensitivities``: the search of
    :class:`~pliant_piirl.expert.SimulatedExpert` over insertion directions inside the task's funnel, without its
    noise (``[start, pre-insertion, final]``, SE(3) configurations), or ``None`` when no direction is valid.  Only
    the given (recovered) values are read."""
    from pliant.api import PlanningError

    from pliant_piirl.expert import ExpertOptions, SimulatedExpert

    searcher = SimulatedExpert(features, sensitivities, tip, ExpertOptions(noise=0.0))
    try:
        tilt, frame = searcher.optimum(task)
    except PlanningError:
        return None
    return searcher.path(task, tilt, frame)


def _cheaper_start(path, candidate, features, weights: np.ndarray, intact, statistics: dict):
    """Whichever of ``path`` (the shortcut RRT* path or None) and ``candidate`` (a straight insertion or None) is
    cheaper in ``features``' cost with ``weights`` and free of punctures; the comparison goes into
    ``statistics["verification"]``."""
    def cost(p) -> float:
        return float(features.of_path(p) @ weights) if p is not None else float("inf")

    usable = candidate is not None and intact(candidate)
    searched, straight_cost = cost(path), cost(candidate) if usable else float("inf")
    chosen = "straight" if straight_cost < searched else "rrtstar"
    def finite(x: float) -> float | None:
        return x if np.isfinite(x) else None

    statistics["verification"] = {"start": chosen if np.isfinite(min(searched, straight_cost)) else None,
                                  "rrtstar_cost": finite(searched), "straight_cost": finite(straight_cost),
                                  "straight_intact": bool(usable)}
    return candidate if chosen == "straight" else path


#: the local optimiser of Table 4.1's verification (``learn-table --refine``, :func:`plan_task`): noise starting at
#: 2 cm and 0.3 rad, shrinking by 0.8 after a round that finds nothing cheaper and growing by 1.2 (up to the start)
#: after one that does; 100 smooth samples and 100 pivots about the target per round
REFINE = {"samples": 100, "pivots": 100, "translation": 0.02, "rotation": 0.3, "shrink": 0.8, "grow": 1.2}


def refine(path: np.ndarray, task, features, weights: np.ndarray, tip, rng: np.random.Generator, *,
           rounds: int = 8, samples: int = 100, translation: float = 0.01, rotation: float = 0.15,
           shrink: float = 0.7, grow: float = 1.0, pivots: int = 0, check=None) -> np.ndarray:
    """Stochastic local search on ``path`` in the cost ``features.of_path(path) @ weights`` (thesis eq. 3.1 with the
    given sensitivities, deformation only): a (1 + lambda) search with step-size adaptation.

    Each round draws ``samples`` smooth sample paths around the current one (thesis 4.3.1's sampler: start clamped,
    the end back on the task's target or at its goal, inside the task's collision planes) with largest standard
    deviations ``translation * scale`` (m) and ``rotation * scale`` (rad), and, for a task that ends with the tip
    on a target in SE(3), ``pivots`` rotations of the path's tail about the target (:func:`pivot_paths`).  The
    cheapest candidate that ``check`` accepts (e.g. no puncture) replaces the path when it costs less.  ``scale``
    starts at 1; it is multiplied by ``grow`` (at most back to 1) after a round that replaced the path and by
    ``shrink`` after one that did not (with ``grow = 1``, the default, the noise only shrinks).  Every draw comes
    from ``rng``: the result is a function of its seed.  Returns the best path found (``path`` itself when nothing
    cheaper was found)."""
    from pliant_piirl.sampling import PathSampler, SampleOptions

    best = np.asarray(path, dtype=np.float64)
    best_cost = float(features.of_path(best) @ weights)
    if not np.isfinite(best_cost):
        return best
    scale = 1.0
    for _ in range(rounds):
        sampler = PathSampler(features, tip, SampleOptions(samples=samples, translation=translation * scale,
                                                           rotation=rotation * scale, rounds=0))
        current = Demonstration(task, best)
        drawn, feats = sampler.draw_with_features(current, rng)
        drawn = list(drawn)
        if pivots and task.goal is None and features.space.tangent_dim == 6:
            turned, turned_feats = sampler.valid_with_features(
                pivot_paths(sampler.resample(best), task.target, rng, pivots, rotation * scale), task)
            drawn += turned
            feats = np.concatenate([feats, turned_feats]) if len(drawn) > len(turned) else turned_feats
        improved = False
        if drawn:
            costs = feats @ weights
            for j in np.argsort(costs, kind="stable"):
                if not costs[j] < best_cost:
                    break
                if check is None or check(drawn[j]):
                    best, best_cost, improved = drawn[j], float(costs[j]), True
                    break
        scale = min(1.0, scale * grow) if improved else scale * shrink
    return best


def pivot_paths(base: np.ndarray, target, rng: np.random.Generator, n: int, rotation: float) -> np.ndarray:
    """``n`` paths ``(n, k, 7)``: ``base`` ``(k, 7)`` (SE(3): position in m, quaternion x, y, z, w) with its tail
    turned rigidly about the point ``target`` (m).  Each path draws a rotation vector of standard deviation
    ``rotation`` (rad) per axis and a waypoint ``j`` in ``1 .. k - 1``; waypoint ``i`` is turned by ``min(1, i / j)``
    of it, so the start stays and every waypoint from ``j`` on turns as one body.  A tip on the target stays on
    it.  This is the move the smooth samples lack: a straight insertion tilted as a whole."""
    from scipy.spatial.transform import Rotation

    base = np.asarray(base, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    k = len(base)
    omega = rng.normal(scale=rotation, size=(n, 3))
    joint = rng.integers(1, k, size=n) if k > 1 else np.ones(n, dtype=np.int64)
    share = np.minimum(1.0, np.arange(k)[None, :] / joint[:, None])                 # (n, k)
    turn = Rotation.from_rotvec((share[:, :, None] * omega[:, None, :]).reshape(-1, 3))
    out = np.repeat(base[None], n, axis=0).reshape(n * k, 7)
    out[:, :3] = target + turn.apply(out[:, :3] - target)
    out[:, 3:] = (turn * Rotation.from_quat(out[:, 3:])).as_quat()
    out = out.reshape(n, k, 7)
    out[:, 0] = base[0]
    return out


def compare(features, truth: dict[str, float], demonstration: Demonstration, planned_path, *,
            deformed: float = 0.0) -> dict:
    """Per object the demonstrated and planned deformation, the objects each deforms, and both true costs."""
    weights = features.sensitivity_vector(truth)
    shown = features.of_path(demonstration.path)
    planned = features.of_path(planned_path) if planned_path is not None else np.full(len(shown), np.nan)
    names = features.names
    return {"demonstrated": dict(zip(names, shown.tolist())), "planned": dict(zip(names, planned.tolist())),
            "demonstrated_objects": [n for n, v in zip(names, shown) if v > deformed],
            "planned_objects": [n for n, v in zip(names, planned) if v > deformed],
            "demonstrated_cost": float(shown @ weights), "planned_cost": float(planned @ weights)}


class PlannerExpert:
    """A simulated expert for tasks that end at a goal configuration (the planar environment): the registered
    ``rrtstar`` planner with the scene's true sensitivities for ``max_time`` s (None: no time limit, for an
    iteration budget in ``planner_options``), shortcut (see
    :mod:`pliant_piirl.verification`), then perturbed once by the smooth noise of the sample paths with largest
    standard deviations ``noise`` m and ``10 * noise`` rad (its documented sub-optimality; 0 for none)."""

    def __init__(self, features, sensitivities: dict[str, float], *, max_time: float | None = 60.0,
                 noise: float = 0.002, planner_options: dict | None = None, shortcut_iterations: int = 500) -> None:
        self.features, self.sensitivities = features, dict(sensitivities)
        self.max_time = None if max_time is None else float(max_time)     # None: planner_options' budget
        self.noise = float(noise)
        self.planner_options, self.shortcut_iterations = dict(planner_options or {}), int(shortcut_iterations)

    def demonstrate(self, task: DemonstrationTask, rng: np.random.Generator) -> Demonstration:
        from pliant_piirl.sampling import PathSampler, SampleOptions

        seed = Demonstration(task, np.array([task.start, task.goal]), "simulated-expert")
        result, path = plan_task(self.features.scene, self.sensitivities, seed, (0.0, 0.0, 0.0), rng,
                                 max_time=self.max_time, planner_options=self.planner_options,
                                 shortcut_iterations=self.shortcut_iterations)
        if path is None:
            if result.path is None:
                raise PlanningError(f"the expert's planner found no path ({result.status.value})", field="task",
                                    value=task.goal.tolist())
            path = result.path.configurations
        shown = Demonstration(task, path, "simulated-expert")
        if self.noise > 0:
            sampler = PathSampler(self.features, (0.0, 0.0, 0.0),
                                  SampleOptions(samples=1, translation=self.noise, rotation=10 * self.noise,
                                                waypoints=max(3, min(len(path), 12))))
            drawn = sampler.draw(shown, rng, 1)
            if drawn:
                shown = Demonstration(task, drawn[0], "simulated-expert")
        return shown
