"""The belief-space RRT of thesis 5.3.1-5.3.2 on se2-maze: splits, probabilities, solutions, baselines."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from pliant import Pipeline
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import PlanningProblem
from pliant.results import Status
from pliant_belief.belief import BeliefNode, BeliefTree, effective_probability
from pliant_belief.local import LocalPlannerSettings, extend


def maze(**planner):
    # Simple RRT plans without a simulator, and a pipeline refuses a simulator nothing would use
    simulator = {} if planner.get("mode") == "simple" else \
        {"simulator": {"name": "kinematic", "kp": 0.5, "angular_velocity_limit": 0.125}}
    pipe = Pipeline("se2-maze", planner={"name": "belief", "max_time": None, **planner}, **simulator)
    ctx = pipe.build()
    return PlanningProblem.from_context(ctx), ctx.extras["planner"]


SETTINGS = LocalPlannerSettings(particles=12, attempts=50, speed=1.0, angular_speed=0.125, settle=2.0,
                                min_progress=0.125)


def one_extension(starts, target, seed=0):
    problem, planner = maze()
    cluster = planner._clusterer(problem, np.random.default_rng(seed))
    tree = BeliefTree(problem.space)
    tree.add(BeliefNode(particles=np.asarray(starts, dtype=np.float64), action=None, parent=-1, action_id=0))
    counters = {"particles_simulated": 0}
    new = extend(tree, 0, np.asarray(target, dtype=np.float64), problem, cluster, SETTINGS,
                 np.random.default_rng(seed), counters)
    return tree, new, counters


def test_particles_straddling_a_wall_split_and_their_probabilities_sum_to_one():
    # half the belief in the middle passage, half in the right one (the L-block's x arm reaches 1.5 m right of its
    # reference point, so both are free); the target lies in the wall between
    starts = [[4.75, 5.0, 0.0]] * 6 + [[8.0, 5.0, 0.0]] * 6
    tree, new, counters = one_extension(starts, [6.75, 5.0, 0.0])
    assert len(new) == 2 and all(tree.nodes[i].split for i in new)
    assert sum(tree.nodes[i].probability for i in new) == pytest.approx(1.0)
    assert len({tree.nodes[i].action_id for i in new}) == 1
    sides = sorted(float(tree.nodes[i].expected[0]) for i in new)
    assert sides[0] < 6.5 < 7.0 < sides[1]                       # one outcome each side of the wall
    assert counters["particles_simulated"] == 12 * (1 + 2)       # forward, then back from each outcome


def test_a_motion_in_free_space_does_not_split():
    rng = np.random.default_rng(0)
    starts = np.array([7.75, 5.0, 0.0]) + rng.uniform(-0.05, 0.05, (12, 3))      # free: the arm ends 0.25 m short
    tree, new, _ = one_extension(starts, [7.75, 4.0, 0.0])
    assert len(new) == 1 and not tree.nodes[new[0]].split
    node = tree.nodes[new[0]]
    assert node.probability == 1.0 and node.reverse_probability == 1.0 and node.effective_probability == 1.0
    assert node.expected[1] == pytest.approx(4.0, abs=0.1)


def test_the_effective_probability_is_the_retry_formula():
    # by hand: p = 0.5, every miss returns (r = 1): 1 - 0.5^3 after three attempts
    assert effective_probability(0.5, 1.0, 3) == pytest.approx(0.875)
    # no return after a miss: only the first attempt counts
    assert effective_probability(0.3, 0.0, 10) == pytest.approx(0.3)
    # brute force over the attempt tree
    p, r, n = 0.4, 0.7, 5
    total, alive = 0.0, 1.0
    for _ in range(n):
        total += alive * p
        alive *= (1 - p) * r
    assert effective_probability(p, r, n) == pytest.approx(total)


def test_the_planner_finds_a_policy_that_reaches_the_goal_with_p_goal():
    problem, planner = maze(particles=8, max_iterations=120, p_goal=0.51)
    result = planner.plan(problem, np.random.default_rng(4))        # 7 of seeds 0-9 solve within 120 iterations
    assert result.status is Status.SOLVED and result.policy is not None
    stats = result.statistics
    assert stats["solutions"] >= 1 and stats["best_probability"] >= 0.51
    assert stats["particles_stored"] == sum(len(n.particles) for n in planner.tree.nodes)
    assert stats["particles_simulated"] >= stats["particles_stored"] - 8
    for solution in planner.tree.solutions:
        last = planner.tree.nodes[solution[-1]]
        assert solution[0] == 0 and last.path_probability * last.goal_fraction >= 0.51
        assert all(planner.tree.nodes[b].parent == a for a, b in itertools.pairwise(solution))
    # a solved branch leaves nearest-neighbour consideration (thesis 5.3.1)
    assert set(planner.tree.solutions[0][1:]) & planner.tree.excluded
    again = planner.plan(problem, np.random.default_rng(4))
    assert np.array_equal(again.path.configurations, result.path.configurations)


def test_simple_rrt_never_touches_a_wall_and_contact_rrt_uses_one_particle():
    problem, planner = maze(mode="simple", max_iterations=4000, stop_on_first=True)
    result = planner.plan(problem, np.random.default_rng(1))
    assert result.status is Status.SOLVED
    grid = VoxelGrid.from_scene(problem.scene, static_only=True)
    dense = np.vstack([problem.space.discretize(a, b, 0.125) for a, b in zip(result.path.configurations[:-1],
                                                                            result.path.configurations[1:])])
    flat = grid.flat_index(problem.robot.body_points(dense))
    assert not grid.occupied.reshape(-1)[flat[flat >= 0]].any()
    problem, planner = maze(mode="contact", max_iterations=60)
    planner.plan(problem, np.random.default_rng(0))
    assert all(len(n.particles) == 1 for n in planner.tree.nodes)


@pytest.mark.slow
def test_a_pipeline_plans_a_policy_and_executes_it():
    record = Pipeline.from_file("maze-policy", overrides=[       # a work budget; the time is only a cap
        "planning.max_time=1000", "planning.max_iterations=150", "planner.particles=8", "execution.world=kinematic",
        "execution.time_limit=600", 'output="/tmp/pliant-test-maze-policy"']).run(write=False)
    assert record.result.status is Status.SOLVED
    assert record.execution is not None and len(record.execution.details.actions) >= 1
    # executed in the simulator it was planned with, the policy reaches the goal
    assert record.execution.success, record.execution.events
    assert record.problem.in_goal(record.execution.configurations[-1:])[0]


@pytest.mark.parametrize("retire", ["split", "root"])
def test_a_solution_branch_leaves_nearest_neighbour_lookups_back_to_its_base(retire):
    """Thesis 5.3.1: back to the nearest split; ``retire = "root"``: the root's whole subtree the solution
    starts with, so no later solution shares an action with it beyond the start."""
    problem, planner = maze(particles=8, max_iterations=120, p_goal=0.51, retire=retire)
    result = planner.plan(problem, np.random.default_rng(5))
    tree = planner.tree
    assert result.status is Status.SOLVED
    for solution in tree.solutions:
        base = len(solution) - 1
        while base > 1 and not (retire == "split" and tree.nodes[solution[base]].split):
            base -= 1
        assert set(solution[base:]) <= tree.excluded and 0 not in tree.excluded
    if retire == "root":
        assert all(set(s[1:]) <= tree.excluded for s in tree.solutions)
        firsts = [s[1] for s in tree.solutions]
        assert len(firsts) >= 2 and len(set(firsts)) == len(firsts)    # each leaves the start differently
        below = {i for i, n in enumerate(tree.nodes) if n.parent in tree.excluded}
        assert below <= tree.excluded                     # nothing under a retired node is a candidate


@pytest.mark.parametrize("spread", [0.0, 0.3, 1.0])
def test_rotation_spread_keeps_sampled_orientations_near_the_goals(spread):
    """SE(3): every sampled target's orientation is within ``spread`` of the goal's, positions still cover
    the bounds; without the option, samples cover the rotation group (some beyond any small spread)."""
    from pliant import load_scene, registry
    from pliant.geometry.rotations import quat_angle
    from pliant.interfaces import Context

    ctx = Context(scene=load_scene("se3-peg-in-hole"))
    ctx.robot = registry.create("robot", "rigid", ctx)
    space, goal = ctx.robot.space, np.asarray(ctx.scene.goal, dtype=np.float64)
    planner = registry.create("planner", "belief", ctx, rotation_spread=spread)
    rng = np.random.default_rng(7)
    samples = np.array([planner._sample(space, goal, rng) for _ in range(400)])
    assert (quat_angle(samples[:, 3:], goal[3:]) <= spread + 1e-9).all()
    np.testing.assert_allclose(np.linalg.norm(samples[:, 3:], axis=1), 1.0)
    assert samples[:, :3].min(axis=0).max() < 1.0 and samples[:, :3].max(axis=0).min() > 9.0
    uniform = registry.create("planner", "belief", ctx)
    free = np.array([uniform._sample(space, goal, rng) for _ in range(400)])
    assert (quat_angle(free[:, 3:], goal[3:]) > 1.0).mean() > 0.5


def test_rotation_spread_in_se2_bounds_the_heading():
    problem, planner = maze(rotation_spread=0.25)
    goal = problem.goal
    headings = np.array([planner._sample(problem.space, goal, np.random.default_rng(k))[2] for k in range(200)])
    assert np.abs((headings - goal[2] + np.pi) % (2 * np.pi) - np.pi).max() <= 0.25 + 1e-12
    assert np.ptp(headings) > 0.3


def test_connect_stops_when_an_extension_comes_no_closer_to_its_target(monkeypatch):
    # a compliant extension may end somewhere new without approaching the target (sliding back and forth along
    # a face): RRT-Connect must count that as trapped, not extend forever
    problem, planner = maze(max_iterations=3, goal_bias=0.0)
    calls = []

    def sideways(tree, near, target, *args):
        calls.append(near)
        if len(calls) > 50:
            raise AssertionError("the connect loop never stopped")
        q = tree.nodes[near].expected.copy()
        q[1] += 0.5 if len(calls) % 2 else -0.5             # oscillates along y, never approaches
        return [tree.add(BeliefNode(particles=q[None], action=q, parent=near, action_id=tree.new_action_id()))]

    monkeypatch.setattr(planner, "_extend", sideways)
    result = planner.plan(problem, np.random.default_rng(0))
    assert result.statistics["iterations"] == 3 and len(calls) <= 3 * 2
