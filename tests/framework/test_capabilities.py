"""Declared planner capabilities (PlannerSpecs): a pipeline that cannot work is rejected when it is built."""

from __future__ import annotations

import pytest
from pliant import registry
from pliant.errors import PipelineError
from pliant.interfaces import Planner, PlannerSpecs
from pliant.pipeline import Pipeline
from pliant.results import PlanResult, Status


def test_every_builtin_planner_declares_its_specs():
    specs = {name: registry.default_registry().entry("planner", name).load().SPECS
             for name in registry.available("planner")}
    assert specs["belief"].needs_simulator and specs["belief"].returns_policy
    assert specs["astar"].spaces == ("r3",) and specs["astar"].needs_cost
    assert specs["gradient-trrt"].needs_gradient and specs["rrtstar"].anytime
    assert not specs["straight"].needs_simulator and specs["straight"].spaces is None
    assert all(isinstance(s, PlannerSpecs) for s in specs.values())


def test_a_belief_pipeline_without_a_simulator_is_rejected_at_build_not_at_plan_time():
    with pytest.raises(PipelineError, match=r"simulator: BeliefPlanner plans by forward simulation") as info:
        Pipeline("se2-maze", planner="belief", controller="contact").build()
    assert info.value.field == "simulator"
    simple = Pipeline("se2-maze", planner={"name": "belief", "mode": "simple"}).build()     # needs none
    assert simple.extras["planner"].specs.needs_simulator is False


@pytest.mark.parametrize(("scene", "planner", "field", "says"), [
    ("se2-maze", "astar", "planner", "plans in r3 only; this robot's space is se2"),
    ("triple-wall", "astar", "cost", "needs a cost model"),
    ("triple-wall", "gradient-trrt", "cost", "needs a cost model"),
])
def test_a_planner_given_what_it_cannot_use_is_rejected_naming_the_field(scene, planner, field, says):
    components = {"planner": planner, **({"cost": "voxel"} if planner == "astar" and scene != "triple-wall" else {})}
    with pytest.raises(PipelineError, match=says) as info:
        Pipeline(scene, **components).build()
    assert info.value.field == field


def test_a_third_party_planner_declares_and_is_checked_the_same_way():
    class PolicyOnlyInSE3(Planner):
        SPECS = PlannerSpecs(spaces=("se3",))

        def plan(self, problem, rng, termination=None):
            return PlanResult(status=Status.INFEASIBLE)

    with pytest.raises(PipelineError, match="plans in se3 only; this robot's space is r3"):
        Pipeline("triple-wall", planner=PolicyOnlyInSE3()).build()
    Pipeline("se3-peg-in-hole", planner=PolicyOnlyInSE3()).build()
