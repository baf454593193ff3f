"""Recovered parameter verification (thesis 4.3.4): plan each demonstration task with RRT* and compare.

The task is planned in the scene with the *recovered* sensitivities by the registered ``rrtstar`` planner (looked
up by name through the registry: plugins do not import each other) with the puncture and cut check on, the
task-space goal "the tip touches the target" and the task's collision planes as a validity constraint, as in the
chapter; then the path is shortcut (:mod:`pliant.planning.shortcut`, cost-aware, every shortcut checked for punctures
and cuts along the whole path), the post-processing step of sampling planners.  The chapter planned for 30 and 60
minutes per task; the time budget here is an option.  With ``refine_rounds`` the shortcut path is then improved by
stochastic local search in the recovered cost (:func:`refine`): the sample paths of thesis 4.3.1 drawn around it,
the cheapest kept when it is cheaper and free of punctures, with the noise shrinking each round -- the local
optimisation a trajectory optimiser (STOMP, which the chapter's sampling follows) does after a sampling planner.
The planned path and the demonstration are then both measured in the scene's *true* sensitivities: the deformation
of each object and the cost ``S . V``.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from pliant_piirl.demonstration import Demonstration


def scene_with(scene, sensitivities: dict[str, float]):
    """``scene`` with the given per-object sensitivities (deformabilities kept)."""
    objects = [dataclasses.replace(o, material=dataclasses.replace(o.material,
                                                                  sensitivity=float(sensitivities[o.name])))
               for o in scene.objects]
    return dataclasses.replace(scene, objects=objects)


def plan_task(scene, sensitivities: dict[str, float], demonstration: Demonstration, tip, rng: np.random.Generator,
              *, max_time: float | None, shortcut_iterations: int = 300, planner_options: dict | None = None,
              planner: str = "rrtstar", refine_rounds: int = 0):
    """RRT* (puncture check on) for ``demonstration``'s task in ``scene`` with ``sensitivities``; the planner's
    result and its path after cost-aware shortcutting and ``refine_rounds`` of :func:`refine` (``None`` without a
    path or with no shortcut iterations)."""
    import pliant
    from pliant.interfaces import Context, PlanningProblem

    context = Context(scene=scene_with(scene, sensitivities))
    context.robot = pliant.registry.create("robot", "rigid", context)
    context.cost = pliant.registry.create("cost", "voxel", context)
    task = demonstration.task
    if planner == "rrtstar":
        options = {"puncture_check": True, "max_time": max_time, "progress": False, "max_step": 0.02,
                   **(planner_options or {})}
    else:
        options = dict(planner_options or {})
    if task.goal is None:                            # "the tip touches the target", as the chapter plans
        options.update({"target": tuple(task.target), "tip": tuple(tip), "target_tolerance": 0.004})
    planner = pliant.registry.create("planner", planner, context, **options)
    robot = context.robot

    def inside_funnel(q: np.ndarray) -> np.ndarray:
        return task.allows(robot.body_points(q)).all(axis=1)

    goal = task.start if task.goal is None else task.goal
    problem = PlanningProblem(space=context.space, start=task.start, goal=goal, goal_tolerance=scene.goal_tolerance,
                              cost=context.cost, robot=robot, scene=context.scene, validity=inside_funnel)
    result = planner.plan(problem, rng)
    if result.path is None or shortcut_iterations == 0:
        return result, None
    from pliant.geometry.topology import PunctureChecker, arc_margin
    from pliant.geometry.voxelgrid import VoxelGrid
    from pliant.planning.shortcut import shortcut

    checker = PunctureChecker(VoxelGrid.from_scene(context.scene), robot.body_points,
                              arc_margin=arc_margin(context.scene, context.space))
    path, _ = shortcut(problem, result.path.configurations, rng, step=scene.resolution / 2,
                       iterations=shortcut_iterations, check=lambda q: checker.check(q)[0])
    if refine_rounds:
        from pliant_piirl.features import DeformationFeatures

        features = DeformationFeatures(context.scene)
        densify = features.states

        def intact(candidate: np.ndarray) -> bool:
            return bool(checker.check(densify(candidate))[0])

        path = refine(path, demonstration.task, features, features.sensitivity_vector(sensitivities), tip, rng,
                      rounds=refine_rounds, check=intact)
    return result, path


def refine(path: np.ndarray, task, features, weights: np.ndarray, tip, rng: np.random.Generator, *,
           rounds: int = 8, samples: int = 100, translation: float = 0.01, rotation: float = 0.15,
           shrink: float = 0.7, check=None) -> np.ndarray:
    """Stochastic local search on ``path`` in the cost ``features.of_path(path) @ weights`` (thesis eq. 3.1 with the
    given sensitivities, deformation only).

    Each round draws ``samples`` smooth sample paths around the current one (thesis 4.3.1's sampler: start clamped,
    the end back on the task's target or at its goal, inside the task's collision planes) with largest standard
    deviations ``translation`` (m) and ``rotation`` (rad), both multiplied by ``shrink`` after every round; the
    cheapest sample that ``check`` accepts (e.g. no puncture) replaces the path when it costs less.  Returns the
    best path found (``path`` itself when nothing cheaper was found)."""
    from pliant_piirl.sampling import PathSampler, SampleOptions

    best = np.asarray(path, dtype=np.float64)
    best_cost = float(features.of_path(best) @ weights)
    if not np.isfinite(best_cost):
        return best
    for k in range(rounds):
        scale = shrink ** k
        sampler = PathSampler(features, tip, SampleOptions(samples=samples, translation=translation * scale,
                                                           rotation=rotation * scale, rounds=0))
        drawn = sampler.draw(Demonstration(task, best), rng)
        if not drawn:
            continue
        costs = features.of_paths(drawn) @ weights
        for j in np.argsort(costs):
            if not costs[j] < best_cost:
                break
            if check is None or check(drawn[j]):
                best, best_cost = drawn[j], float(costs[j])
                break
    return best


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


def verify(scene, features, learned: dict[str, float], demonstrations: list[Demonstration], tip,
           rng: np.random.Generator, *, max_time: float, shortcut_iterations: int = 300, echo=print) -> list[dict]:
    """:func:`plan_task` and :func:`compare` for every demonstration; one row each."""
    from pliant_piirl.features import true_sensitivities

    truth = true_sensitivities(scene)
    rows = []
    for k, demonstration in enumerate(demonstrations):
        started = time.perf_counter()
        result, path = plan_task(scene, learned, demonstration, tip, rng, max_time=max_time,
                                 shortcut_iterations=shortcut_iterations)
        if path is None and result.path is not None:
            path = result.path.configurations
        row = {"task": k, "objects": list(demonstration.task.objects), "status": result.status.value,
               "seconds": time.perf_counter() - started, **compare(features, truth, demonstration, path)}
        rows.append(row)
        echo(f"task {k} {row['objects']}: {row['status']}, demonstrated {row['demonstrated_objects']} cost "
             f"{row['demonstrated_cost']:.1f}, planned {row['planned_objects']} cost {row['planned_cost']:.1f}")
    return rows
