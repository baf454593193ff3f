"""The straight-line planner: solved, blocked, invalid endpoints."""

from __future__ import annotations

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.interfaces import Context, PlanningProblem
from pliant.results import Status
from pliant.testing import check_component


@pytest.fixture
def hard_walls():
    ctx = Context(scene=load_scene("triple-wall:hard-robot-hard-walls"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.cost = registry.create("cost", "voxel", ctx)
    return ctx


def plan(ctx, **kw):
    return registry.create("planner", "straight", step=0.004).plan(PlanningProblem.from_context(ctx, **kw),
                                                                   np.random.default_rng(0))


def test_free_motion_is_solved(hard_walls):
    start = (np.array([24, 6, 24]) + 0.5) * 0.008
    goal = (np.array([24, 6, 4]) + 0.5) * 0.008
    result = plan(hard_walls, start=start, goal=goal)
    assert result.status is Status.SOLVED and result.cost == 0.0
    assert np.allclose(result.path.configurations[[0, -1]], [start, goal])


def test_a_rigid_wall_blocks_it(hard_walls):
    result = plan(hard_walls)
    assert result.status is Status.INFEASIBLE and "blocked" in result.message and result.path is None


def test_invalid_endpoints(hard_walls):
    inside = (np.array([5, 15, 20]) + 0.5) * 0.008
    assert plan(hard_walls, start=inside).status is Status.INVALID_START
    assert plan(hard_walls, goal=inside).status is Status.INVALID_GOAL


def test_soft_walls_make_it_costly_but_feasible(scene_context):
    result = plan(scene_context("triple-wall", "voxel"))
    assert result.status is Status.SOLVED and result.cost > 0


def test_conformance():
    assert check_component("planner", "straight")
