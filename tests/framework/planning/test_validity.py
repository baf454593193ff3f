"""The core's validity checker (pliant.planning.validity): known answers for states and motions, the final check of
every planner's result, and the straight baseline through the maze's walls."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pliant import Pipeline, load_scene
from pliant.errors import PlanningError
from pliant.interfaces import Planner, PlanningProblem
from pliant.planning.validity import ValidityChecker
from pliant.results import Path, PlanResult, Status
from pliant.scene import Scene

NAN = float("nan")


def scene(objects, robot_size=(0.3, 0.3, 0.3), space="r3", robot_material=(0.0, 1.0), planar=False,
          start=(0.25, 0.5, 0.5), goal=(0.25, 0.6, 0.5)):
    """A 1 m box world of 0.1 m voxels (one 0.1 m layer when ``planar``) with the given objects and a box robot."""
    z = (-0.05, 0.05) if planar else (0.0, 1.0)
    return Scene.from_dict({
        "name": "validity-test", "planar": planar, "start": list(start), "goal": list(goal),
        "bounds": {"lower": [0.0, 0.0, z[0]], "upper": [1.0, 1.0, z[1]], "resolution": 0.1},
        "objects": objects,
        "robot": {"kind": "rigid", "space": space, "deformability": robot_material[0],
                  "sensitivity": robot_material[1], "parts": [{"shape": "box", "size": list(robot_size)}]},
    })


def wall(material=(0.0, 1.0), cells=((5, 6), (0, 10), (0, 10))):
    return {"name": "wall", "cells": [list(c) for c in cells], "deformability": material[0],
            "sensitivity": material[1]}


def checker_of(scn, **components) -> tuple[ValidityChecker, PlanningProblem]:
    context = Pipeline(scn, planner="straight", **components).build()
    problem = PlanningProblem.from_context(context)
    assert isinstance(problem.checker, ValidityChecker)
    return problem.checker, problem


def at(x, y=0.5, z=0.5):
    return np.array([x, y, z])


# --- states ----------------------------------------------------------------------------------------


def test_a_body_one_voxel_into_a_rigid_wall_is_invalid_and_touching_it_is_valid():
    # the robot: 3 x 3 x 3 points 0.1 apart around its origin; the wall fills x in [0.5, 0.6]
    checker, problem = checker_of(scene([wall()]))
    assert checker.states_valid(at(0.35))[0]                  # points up to x = 0.45, a voxel off the wall
    assert checker.states_valid(at(0.4))[0]                   # points at x = 0.5: on the wall's face, touching
    assert not checker.states_valid(at(0.45))[0]              # points at x = 0.55: one voxel into the wall
    assert not checker.states_valid(at(0.4 + 1e-4))[0]        # a tenth of a millimetre in
    assert checker.states_valid(at(0.8))[0]                   # the far side
    assert list(problem.is_valid(np.array([at(0.35), at(0.45), at(0.8)]))) == [True, False, True]
    assert "wall" in checker.explain(at(0.45))
    assert checker.explain(at(0.35)) is None


def test_materials_decide_as_the_cost_of_deformation_does():
    # a rigid robot in a soft wall deforms it (valid, costly); a soft robot in a rigid wall too
    assert checker_of(scene([wall((0.5, 0.5))]))[0].states_valid(at(0.55))[0]
    assert checker_of(scene([wall()], robot_material=(0.5, 0.5)))[0].states_valid(at(0.55))[0]
    # a forbidden object (NaN sensitivity) is never entered, whatever the robot is made of
    assert not checker_of(scene([wall((0.5, NAN))], robot_material=(0.5, 0.5)))[0].states_valid(at(0.55))[0]
    # the workspace's bounds are walls: a point outside is invalid
    checker = checker_of(scene([]))[0]
    assert checker.states_valid(at(0.1))[0] and checker.states_valid(at(0.1 + 0.05))[0]
    assert not checker.states_valid(at(0.05))[0]              # points at x = -0.05


def test_a_movable_object_is_not_an_obstacle():
    crate = {"name": "crate", "shape": "box", "size": [0.2, 0.2, 0.2], "position": [0.55, 0.5, 0.5], "mass": 1.0,
             "deformability": 0.0, "sensitivity": 1.0}
    assert checker_of(scene([crate]))[0].states_valid(at(0.55))[0]


# --- motions ---------------------------------------------------------------------------------------


def test_a_motion_through_a_wall_is_invalid_though_both_ends_are_valid():
    checker, problem = checker_of(scene([wall()]))
    a, b = at(0.25), at(0.85)
    assert checker.states_valid(np.array([a, b])).all()
    assert not checker.motions_valid(a, b)[0]
    assert not problem.motion_is_valid(a, b)
    # along the wall, touching its face all the way: valid
    assert checker.motions_valid(at(0.4, 0.2), at(0.4, 0.8))[0]
    # batched, in order
    assert list(checker.motions_valid(np.array([a, at(0.4, 0.2)]), np.array([b, at(0.4, 0.8)]))) == [False, True]


@pytest.mark.parametrize(("offset", "valid"), [(0.002, False), (-0.002, True)])
def test_a_point_clipping_a_cube_corner_by_a_fortieth_of_a_voxel_is_caught(offset, valid):
    # a one-point robot moving along x + y = 1 + offset past the corner (0.5, 0.5) of a column of cubes
    column = wall(cells=((5, 6), (5, 6), (0, 10)))
    checker, _ = checker_of(scene([column], robot_size=(0.05, 0.05, 0.05)))
    s = 1.0 + offset
    a, b = at(s - 0.6, 0.6), at(0.6, s - 0.6)
    assert checker.states_valid(np.array([a, b])).all()
    assert checker.motions_valid(a, b)[0] == valid


def test_rotation_sweeps_are_checked_by_the_farthest_point():
    # a planar bar of 5 points (x = -0.2 ... 0.2) turning about (0.5, 0.5) next to the cube [0.6, 0.7]^2: its tip
    # passes through the cube at 45 degrees going counter-clockwise, and misses it going clockwise
    cube = wall(cells=((6, 7), (6, 7), (0, 1)))
    scn = scene([cube], robot_size=(0.5, 0.1, 0.1), space="se2", planar=True, start=(0.5, 0.5, 0.0),
                goal=(0.5, 0.5, math.pi / 2))
    checker, problem = checker_of(scn)
    q0, q90, qm90 = (np.array([0.5, 0.5, t]) for t in (0.0, math.pi / 2, -math.pi / 2))
    assert checker.states_valid(np.array([q0, q90, qm90])).all()
    assert not checker.states_valid(np.array([0.5, 0.5, math.pi / 4]))[0]
    assert not checker.motions_valid(q0, q90)[0]
    assert checker.motions_valid(q0, qm90)[0]
    verdict = problem.path_verdict(np.array([q0, q90]))
    assert not verdict.valid and verdict.kind == "motion" and verdict.index == 0


# --- planners: the final check and the straight baseline -------------------------------------------


class Teleport(Planner):
    """A planner that claims the straight start -> goal without looking (to test the core's final check)."""

    def plan(self, problem, rng, termination=None):
        path = Path(np.array([problem.start, problem.goal]), space_kind=problem.space.kind)
        return PlanResult(Status.SOLVED, path=path, cost=0.0, planner="teleport")


def test_a_solved_path_through_a_wall_is_downgraded_with_the_reason():
    scn = scene([wall()], start=(0.25, 0.5, 0.5), goal=(0.85, 0.5, 0.5))
    _, problem = checker_of(scn)
    result = Teleport().plan(problem, np.random.default_rng(0))
    assert result.status is Status.INVALID_PATH and not result.solved
    assert result.path is None and math.isnan(result.cost)
    assert result.statistics["validity"]["kind"] == "motion" and result.statistics["reported_status"] == "solved"
    assert "not valid" in result.message and "motion from state 0 to state 1" in result.message
    # a problem built by hand, without a checker, gets the scene's and robot's one
    bare = PlanningProblem(space=problem.space, start=problem.start, goal=problem.goal, robot=problem.robot,
                           scene=problem.scene)
    assert Teleport().plan(bare, np.random.default_rng(0)).status is Status.INVALID_PATH
    # a scene with obstacles but no robot: nothing could be checked, so the core refuses to plan
    with pytest.raises(PlanningError, match="robot"):
        Teleport().plan(PlanningProblem(space=problem.space, start=problem.start, goal=problem.goal,
                                        scene=problem.scene), np.random.default_rng(0))
    # the free side: solved, and the check is on record
    free = checker_of(scene([wall()], start=(0.25, 0.3, 0.5), goal=(0.25, 0.7, 0.5)))[1]
    ok = Teleport().plan(free, np.random.default_rng(0))
    assert ok.status is Status.SOLVED and ok.statistics["validity"]["valid"]


def test_the_straight_baseline_through_the_maze_walls_is_infeasible_not_solved(tmp_path):
    # issue 31: `pliant run straight-demo --set scene=se2-maze` reported solved, cost 0, through the walls
    record = Pipeline.from_file("straight-demo", overrides=["scene=se2-maze", f'output="{tmp_path}"']).run()
    assert record.result.status is Status.INFEASIBLE and record.result.path is None
    assert "blocked" in record.result.message


def test_straight_and_waypoints_check_the_motions_not_only_the_states():
    scn = scene([wall()], start=(0.25, 0.5, 0.5), goal=(0.85, 0.5, 0.5))
    context = Pipeline(scn, planner={"name": "straight", "step": 10.0}).build()     # a single step: both ends valid
    problem = PlanningProblem.from_context(context)
    assert context.extras["planner"].plan(problem, np.random.default_rng(0)).status is Status.INFEASIBLE
    context = Pipeline(scn, planner={"name": "waypoints", "waypoints": [[0.25, 0.1, 0.5], [0.85, 0.1, 0.5]]}).build()
    result = context.extras["planner"].plan(PlanningProblem.from_context(context), np.random.default_rng(0))
    # waypoint 0 is the start
    assert result.status is Status.INFEASIBLE and "motion from waypoint 1 to waypoint 2" in result.message


class ShortOfTheGoal(Planner):
    """Claims solved with a valid path that stops halfway (what gradient-trrt once returned)."""

    def plan(self, problem, rng, termination=None):
        half = 0.5 * (problem.start + problem.goal)
        return PlanResult(Status.SOLVED, path=Path(np.vstack([problem.start, half])), cost=0.0, planner="short")


def test_a_solved_path_that_stops_short_of_the_goal_is_approximate():
    problem = checker_of(scene([wall()], start=(0.25, 0.3, 0.5), goal=(0.25, 0.7, 0.5)))[1]
    result = ShortOfTheGoal().plan(problem, np.random.default_rng(0))
    assert result.status is Status.APPROXIMATE and result.path is not None
    assert result.statistics["goal"]["distance"] == pytest.approx(0.2)
    assert result.statistics["reported_status"] == "solved" and "from the goal" in result.message
    # within the goal tolerance it stays solved
    problem.goal_tolerance = 0.25
    assert ShortOfTheGoal().plan(problem, np.random.default_rng(0)).status is Status.SOLVED


def test_a_hand_built_problem_of_the_pipeline_s_scene_and_robot_reuses_its_checker(monkeypatch):
    ctx = Pipeline.from_file("straight-demo", overrides=["scene=se2-maze"]).build()
    planner = ctx.extras["planner"]
    ValidityChecker.from_context(ctx)                  # the pipeline's checker (planners build it when bound)
    built = []
    original = ValidityChecker.__init__

    def counted(self, *args, **kwargs):
        built.append(1)
        original(self, *args, **kwargs)

    monkeypatch.setattr(ValidityChecker, "__init__", counted)
    bare = PlanningProblem(space=ctx.space, start=ctx.scene.start, goal=ctx.scene.goal, robot=ctx.robot,
                           scene=ctx.scene)
    for _ in range(2):
        assert planner.plan(bare, np.random.default_rng(0)).status is Status.INFEASIBLE   # the walls are seen
    assert built == []                                 # the context's checker, not a new grid per plan
    # a scene of its own (not the pipeline's) gets a checker of its own
    other = PlanningProblem(space=ctx.space, start=ctx.scene.start, goal=ctx.scene.goal, robot=ctx.robot,
                            scene=load_scene("se2-maze"))
    planner.plan(other, np.random.default_rng(0))
    assert built == [1]
