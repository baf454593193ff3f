"""Partial policies (thesis 5.3.4-5.3.5): construction, Algorithm 4, adaptation by eq. 5.2-5.3, insertion of
unforeseen outcomes, the termination proof, file round trips, and execution on se2-maze."""

from __future__ import annotations

import itertools
import json
import math
import time

import numpy as np
import pytest
from pliant import load_scene, registry
from pliant.errors import ConfigError, DimensionError, PlanningError
from pliant.interfaces import Context
from pliant.results import PlanResult, Status
from pliant.spaces import RealVectorSpace
from pliant_belief.belief import BeliefNode, BeliefTree, effective_probability
from pliant_belief.execute import execute_policy
from pliant_belief.policy import DistanceMatcher, PartialPolicy, attempts_needed

SPACE = RealVectorSpace([-20.0, -20.0], [40.0, 40.0])
MATCH = DistanceMatcher(SPACE, 0.3)
GOAL = np.array([2.0, 0.0])


def _add(tree, centre, parent, action_id, p=1.0, reverse=1.0, goal_fraction=0.0, n=10, target=None):
    particles = np.asarray(centre, dtype=np.float64) + np.linspace(-0.05, 0.05, n)[:, None]
    node = BeliefNode(particles, None if target is None else np.asarray(target, dtype=np.float64), parent, action_id,
                      probability=p, reverse_probability=reverse, goal_fraction=goal_fraction)
    return tree.add(node)


def two_routes():
    """Root (0, 0); route A: a split (0.8 to node 1, 0.2 to node 2) then node 3 at the goal; route B: node 4,
    then a split (0.6 to node 5 at the goal, 0.4 to node 6).  Route A is the more probable one."""
    tree = BeliefTree(SPACE)
    _add(tree, (0, 0), -1, 0)
    a1 = tree.new_action_id()
    _add(tree, (1, 0), 0, a1, 0.8, 1.0, n=8, target=(1, 0))
    _add(tree, (1, 1), 0, a1, 0.2, 0.9, n=2, target=(1, 0))
    a2 = tree.new_action_id()
    _add(tree, (2, 0), 1, a2, 1.0, 1.0, goal_fraction=1.0, target=(2, 0))
    a3 = tree.new_action_id()
    _add(tree, (0, -1), 0, a3, target=(0, -1))
    a4 = tree.new_action_id()
    _add(tree, (2, 0.1), 4, a4, 0.6, 1.0, goal_fraction=1.0, n=6, target=(2, 0))
    _add(tree, (2, -1), 4, a4, 0.4, 1.0, n=4, target=(2, 0))
    tree.solutions = [[0, 1, 3], [0, 4, 5]]
    return tree


def chain(n_particles=10):
    """Root (0, 0) -> node 1 (1, 0), certain -> goal node 2 (2, 0): one route, no alternative."""
    tree = BeliefTree(SPACE)
    _add(tree, (0, 0), -1, 0, n=n_particles)
    _add(tree, (1, 0), 0, tree.new_action_id(), n=n_particles, target=(1, 0))
    _add(tree, (2, 0), 1, tree.new_action_id(), goal_fraction=1.0, n=n_particles, target=(2, 0))
    tree.solutions = [[0, 1, 2]]
    return tree


def test_transition_probabilities_sum_to_one_per_action_also_after_adaptation():
    policy = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3)
    assert len(policy.nodes) == 7 and policy.tree_index == list(range(7))     # siblings 2 and 6 included

    def check():
        for action in policy.actions.values():
            total = sum(action.probability(v) for v in action.outcomes)
            if action.kind == "forward":
                assert total == pytest.approx(1.0)
                assert all(policy.nodes[v].action_id == action.id for v in action.outcomes)
            else:   # a reverse action's planned failures (1 - reverse_probability) have no node yet
                assert total <= 1.0 + 1e-12

    check()
    assert policy.actions[1].probability(1) == pytest.approx(0.8) and policy.actions[1].probability(2) == 0.2
    policy.query(np.array([1.0, 1.0]), 1, MATCH)               # a miss into the known sibling
    check()
    policy.query(np.array([7.0, 7.0]), policy.reverse_of[2], MATCH)   # an unforeseen outcome of a reverse
    check()


def test_effective_probability_and_attempts_follow_the_retry_formula():
    policy = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3)
    e = policy.edge(0, 1, 1)
    # a miss lands in node 2 (probability 0.2) which returns with 0.9: r = 0.9, 50 tries
    by_hand = sum(0.8 * ((1 - 0.8) * 0.9) ** k for k in range(50))
    assert e.retry == pytest.approx(0.9) and e.effective == pytest.approx(by_hand)
    assert e.effective == pytest.approx(effective_probability(0.8, 0.9, 50))
    assert e.attempts_needed == 1 and e.cost == pytest.approx(1 / 0.8)
    # route B's split: p = 0.6, node 6 always returns
    e = policy.edge(4, 5)
    assert e.retry == 1.0 and e.effective == pytest.approx(1 - 0.4 ** 50)
    # attempts needed to reach P_goal (the complement of the effective probability), by hand
    assert attempts_needed(0.3, 1.0, 0.5, 50) == 2                       # 0.3, then 0.3 + 0.7 * 0.3 = 0.51
    assert attempts_needed(0.1, 1.0, 0.51, 50) == 7                      # 1 - 0.9^k >= 0.51 first at k = 7
    assert 1 - 0.9 ** 6 < 0.51 <= 1 - 0.9 ** 7
    assert attempts_needed(0.2, 0.5, 0.51, 50) == 50                     # limit 0.2 / 0.6 < 0.51: capped
    assert attempts_needed(0.0, 1.0, 0.51, 50) == 50
    # P(root -> goal) along the chosen route: product of effective probabilities times the goal fraction
    assert policy.goal_probability(0) == pytest.approx(by_hand * 1.0 * 1.0)
    assert policy.distance(0) == pytest.approx(1 / 0.8 + 1.0 + 1.0)


def test_the_policy_follows_the_most_probable_path_when_every_action_succeeds():
    policy = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3)
    assert policy.route(0) == [0, 1, 3]
    action = policy.first_action()
    assert action.id == 1 and np.allclose(action.target, [1, 0]) and action.kind == "forward"
    action, node = policy.query(np.array([1.02, 0.0]), action.id, MATCH)
    assert node == 1 and action.id == 2
    step = policy.query_step(np.array([2.0, 0.01]), action.id, MATCH)
    assert step.node == 3 and step.status == "goal" and step.action is None and not step.inserted
    # success raised the probabilities of the actions taken (eq. 5.2)
    assert policy.actions[1].probability(1) == pytest.approx((8 + 500) / (10 + 500))


def test_adaptation_lowers_a_failing_action_by_eq_5_3_and_routes_around_it():
    policy = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3)
    step = policy.query_step(np.array([1.0, 1.05]), 1, MATCH)        # action 1 ended in node 2, not node 1
    assert step.node == 2 and step.matching == [2]
    a = 500.0
    # N_attempts = 10 particles, N_successful = 8 (node 1) and 2 (node 2)
    assert policy.actions[1].probability(1) == pytest.approx(8 / (10 + a))           # eq. 5.3
    assert policy.actions[1].probability(2) == pytest.approx((2 + a) / (10 + a))     # eq. 5.2
    assert {(c["outcome"], round(c["before"], 6)) for c in step.changes} == {(1, 0.8), (2, 0.2)}
    # from node 2: return to the root, then take route B
    assert step.status == "continue" and step.action.id == policy.reverse_of[2]
    assert np.allclose(step.action.target, policy.nodes[0].expected)
    assert policy.route(2) == [2, 0, 4, 5]
    assert step.probability == pytest.approx(0.9 * 1.0 * (1 - 0.4 ** 50) * 1.0)
    action, node = policy.query(np.array([0.01, 0.0]), step.action.id, MATCH)
    assert node == 0 and action.id == 3


def test_a_failing_reversible_action_without_alternative_is_retried_until_p_goal_is_out_of_reach():
    a = 5.0
    tree = two_routes()
    tree.solutions = [[0, 4, 5]]                                     # route B alone
    policy = PartialPolicy.from_tree(tree, goal=GOAL, goal_tolerance=0.3, importance=a)
    assert policy.tree_index == [0, 4, 5, 6]
    n4, n5, n6 = 1, 2, 3
    # after k misses (each reversed successfully): P(4 -> 5) = 6 / (10 + k A); the miss always returns, so the
    # effective probability is 1 - (1 - p)^50, which first drops below P_goal = 0.51 at this k:
    expected = next(k for k in range(1, 1000) if 1 - (1 - 6 / (10 + k * a)) ** 50 < 0.51)
    misses = 0
    while True:
        step = policy.query_step(np.array([2.0, -1.0]), 4, MATCH)    # action 4 keeps ending in node 6
        misses += 1
        assert step.node == n6 and policy.actions[4].probability(n5) == pytest.approx(6 / (10 + misses * a))
        if step.status == "failure":
            break
        assert step.action.id == policy.reverse_of[n6]                # return and retry
        back = policy.query_step(np.array([0.0, -1.0]), step.action.id, MATCH)
        assert back.node == n4 and back.action.id == 4
    assert misses == expected and expected > 10


def test_an_unforeseen_outcome_is_inserted_and_the_policy_first_reverses():
    policy = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3)
    q = np.array([5.0, 5.0])
    step = policy.query_step(q, 1, MATCH)
    k = step.node
    assert step.inserted and step.matching == [] and k == 7 and policy.tree_index[k] == -1
    node = policy.nodes[k]
    assert node.parent == 0 and node.action_id == 1 and np.allclose(node.particles, [q])
    assert policy.outcomes(1) == [1, 2, 7]
    # the reverse prior N_attempts = N_successful = 1: the next action returns to the previous node
    reverse = policy.actions[policy.reverse_of[k]]
    assert reverse.attempts == 1 and reverse.successes == {0: 1.0}
    assert step.action is reverse and np.allclose(reverse.target, policy.nodes[0].expected)
    # eq. 5.2 for the inserted outcome (N_successful 0), eq. 5.3 for the planned ones
    assert policy.actions[1].probability(k) == pytest.approx(500 / 510)
    assert policy.actions[1].probability(1) == pytest.approx(8 / 510)
    # the same observation again now matches the inserted node instead of inserting another
    again = policy.query_step(q + 0.1, 1, MATCH)
    assert not again.inserted and again.node == k and len(policy.nodes) == 8


def test_an_outcome_that_matches_another_branch_relocalizes_there():
    """Action 1 (planned outcomes: nodes 1 and 2) lands where both goal nodes 3 and 5 are (equally near the
    goal: the lower index wins): with relocalization the policy continues from node 3 (a goal) and learns
    that action 1 leads there; without it, thesis 5.3.5 inserts a new node and returns.  An observation
    matching only a node far from the goal relocalizes there (node 6, route B's miss)."""
    policy = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3)
    step = policy.query_step(np.array([2.0, 0.05]), 1, MATCH)
    assert step.relocalized and not step.inserted and step.node == 3 and len(policy.nodes) == 7
    assert policy.outcomes(1) == [1, 2, 3] and step.status == "goal"
    assert policy.actions[1].probability(3) == pytest.approx(500 / 510)
    assert sum(policy.actions[1].probability(v) for v in policy.outcomes(1)) == pytest.approx(1.0)
    assert policy.edge(0, 3, 1).probability == pytest.approx(500 / 510)
    other = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3)
    assert other.query_step(np.array([2.0, -0.95]), 1, MATCH).node == 6
    thesis = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3, options={"relocalize": False})
    step = thesis.query_step(np.array([2.0, -0.95]), 1, MATCH)
    assert step.inserted and not step.relocalized and step.node == 7 and step.action.kind == "reverse"


def test_an_action_that_left_the_robot_where_it_was_counts_as_a_retry():
    """Landing back on the action's own source (relocalized there) is a miss that needs no return."""
    policy = PartialPolicy.from_tree(chain(), goal=GOAL, goal_tolerance=0.3)
    action = policy.first_action()
    step = policy.query_step(np.array([0.02, 0.0]), action.id, MATCH)
    assert step.relocalized and step.node == 0 and step.action is action      # try the same action again
    assert policy.edge(0, 1, action.id).retry == pytest.approx(1.0)


@pytest.mark.parametrize("importance", [1.0, 3.0])
def test_termination_when_unforeseen_outcomes_keep_coming_raw_product(importance):
    """Thesis 5.3.5's proof with raw probabilities (N_attempt = 1): after the i-th failed reverse,
    P(n_observed -> goal) = prod 1 / (1 + A) times P(start -> goal), so execution terminates."""
    p_goal = 0.05
    policy = PartialPolicy.from_tree(chain(), p_goal=p_goal, attempts=1, importance=importance, goal=GOAL,
                                     goal_tolerance=0.3)
    action = policy.first_action()
    steps = []
    for i in range(100):
        step = policy.query_step(np.array([10.0 + 3 * i, 10.0]), action.id, MATCH)   # never a planned node
        assert step.inserted
        steps.append(step)
        if step.status == "failure":
            break
        assert step.action.kind == "reverse"          # always: try to return to the previous node
        action = step.action
    root_after = 10 / (10 + importance)                 # action 1's planned outcome after the first miss (5.3)
    for i, step in enumerate(steps):
        assert step.probability == pytest.approx((1 / (1 + importance)) ** i * root_after)
    bound = 1 + math.ceil(math.log(p_goal / root_after) / math.log(1 / (1 + importance)))
    assert steps[-1].status == "failure" and len(steps) == bound


def test_termination_with_retries_counted():
    """With the thesis's N_attempt = 50 the retries of a reverse are counted too; P(goal) still falls at least
    geometrically with the failed reverses, so execution terminates within a bounded number of actions."""
    a, p_goal = 1.0, 0.51
    policy = PartialPolicy.from_tree(chain(), p_goal=p_goal, attempts=50, importance=a, goal=GOAL, goal_tolerance=0.3)
    action = policy.first_action()
    probabilities = []
    for i in range(100):
        step = policy.query_step(np.array([10.0 + 3 * i, 10.0]), action.id, MATCH)
        probabilities.append(step.probability)
        if step.status == "failure":
            break
        action = step.action
    assert step.status == "failure" and probabilities[-1] < p_goal
    assert all(b <= a_ + 1e-12 for a_, b in itertools.pairwise(probabilities))
    # a failed reverse (p = 1/(1+A)) whose misses return with at most 1/(1+A): effective <= p / (1 - (1-p) p)
    p = 1 / (1 + a)
    ratio = p / (1 - (1 - p) * p)
    assert len(probabilities) <= 3 + math.ceil(math.log(p_goal / probabilities[0]) / math.log(ratio))


def test_save_and_load_give_the_same_next_actions(tmp_path):
    policy = PartialPolicy.from_tree(two_routes(), goal=GOAL, goal_tolerance=0.3, clustering="wcr")
    policy.query(np.array([1.0, 1.0]), 1, MATCH)
    policy.query(np.array([9.0, 9.0]), policy.reverse_of[2], MATCH)      # adapted and with an inserted node
    policy.match_thresholds = {"wcr_threshold": 0.5, "distance_threshold": 1.25}       # as the planner set them
    policy.save(tmp_path / "policy.json")
    loaded = PartialPolicy.load(tmp_path / "policy.json")
    assert loaded.clustering == "wcr" and len(loaded.nodes) == len(policy.nodes) == 8
    # a loaded policy matches observations with the planner's thresholds, not the clustering defaults
    loaded.use_clustering(maze_context("se2-maze"))
    assert loaded.match_thresholds == {"wcr_threshold": 0.5, "distance_threshold": 1.25}
    for v in range(len(policy.nodes)):
        a, b = policy.next_action(v), loaded.next_action(v)
        assert (a is None and b is None) or (a.id == b.id and np.array_equal(a.target, b.target))
        assert loaded.goal_probability(v) == pytest.approx(policy.goal_probability(v))
        assert loaded.distance(v) == pytest.approx(policy.distance(v))
    # and inside a PlanResult
    result = PlanResult(Status.SOLVED, policy=policy, planner="belief")
    result.save(tmp_path / "result.json")
    again = PlanResult.load(tmp_path / "result.json").policy
    assert isinstance(again, PartialPolicy) and again.route(0) == policy.route(0)
    # the two continue identically
    s1 = policy.query_step(np.array([0.0, 0.0]), policy.reverse_of[2], MATCH)
    s2 = loaded.query_step(np.array([0.0, 0.0]), policy.reverse_of[2], MATCH)
    assert s1.action.id == s2.action.id and s1.probability == pytest.approx(s2.probability)


def test_bad_input_names_the_field():
    tree = two_routes()
    policy = PartialPolicy.from_tree(tree)
    with pytest.raises(ConfigError, match="performed_action_id"):
        policy.query(np.zeros(2), 999, MATCH)
    with pytest.raises(DimensionError, match="q_current"):
        policy.query(np.zeros(3), 1, MATCH)
    with pytest.raises(PlanningError, match="matcher"):
        policy.query(np.zeros(2), 1)
    with pytest.raises(ConfigError, match="node"):
        policy.next_action(99)
    tree.solutions = []
    with pytest.raises(ConfigError, match="solutions"):
        PartialPolicy.from_tree(tree)
    tree.solutions = [[0, 3]]
    with pytest.raises(ConfigError, match=r"solutions\[0\]"):
        PartialPolicy.from_tree(tree)
    with pytest.raises(ConfigError, match="p_goal"):
        PartialPolicy.from_tree(two_routes(), options={"p_goal": 1.5})
    data = policy.to_dict()
    data["match_thresholds"] = {"distance": 1.0}
    with pytest.raises(ConfigError, match="match_thresholds"):
        PartialPolicy.from_dict(json.loads(json.dumps(data)))
    del data["actions"]
    with pytest.raises(ConfigError, match="actions"):
        PartialPolicy.from_dict(json.loads(json.dumps(data)))


# --- execution on se2-maze ---------------------------------------------------------------------------------


def maze_context(scene: str) -> Context:
    """A fresh context (the shared ``scene_context`` ones must not gain a simulator) with the kinematic simulator."""
    ctx = Context(scene=load_scene(scene))
    ctx.robot = registry.create("robot", "rigid", ctx)
    ctx.simulator = registry.create("simulator", "kinematic", ctx)
    return ctx


def maze_tree(ctx):
    """A hand-built policy down the right passage and along the bottom corridor to the goal (every node free)."""
    space = ctx.robot.space
    tree = BeliefTree(space)
    waypoints = [ctx.scene.start, (7.75, 1.4, 0.0), (0.75, 1.4, 0.0), ctx.scene.goal]
    jitter = np.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0], [0.0, 0.05, 0.0], [-0.05, -0.05, 0.0]])
    for i, w in enumerate(waypoints):
        w = np.asarray(w, dtype=np.float64)
        tree.add(BeliefNode(w + jitter, None if i == 0 else w.copy(), i - 1, 0 if i == 0 else tree.new_action_id(),
                            goal_fraction=1.0 if i == len(waypoints) - 1 else 0.0))
    tree.solutions = [list(range(len(waypoints)))]
    return tree


def test_execute_policy_on_se2_maze_reaches_the_goal():
    from pliant.planning.clustering import ClusteringContext, matches

    ctx = maze_context("se2-maze")
    controller = registry.create("controller", "contact", ctx)
    tree = maze_tree(ctx)
    cluster_ctx = ClusteringContext.from_context(ctx)
    policy = PartialPolicy.from_tree(tree, goal=ctx.scene.goal, goal_tolerance=ctx.scene.goal_tolerance,
                                     clustering="wcr")

    def matcher(particles, q):
        return matches(particles, q, "wcr", cluster_ctx)

    began = time.perf_counter()
    record = execute_policy(policy, ctx.simulator, controller, np.random.default_rng(0), matcher=matcher,
                            time_limit=120.0, action_limit=10)
    assert time.perf_counter() - began < 10.0
    assert record.success, record.events
    assert [a["node"] for a in record.details.actions] == [1, 2, 3][: len(record.details.actions)]
    assert all(not a["inserted"] and a["drive"] == "reached" for a in record.details.actions)
    assert ctx.robot.space.distance(record.configurations[-1], ctx.scene.goal) <= ctx.scene.goal_tolerance
    assert len(record.configurations) == len(record.times) == len(record.contacts)
    data = json.loads(json.dumps(record.to_dict()))
    assert data["outcome"] == "success" and len(data["details"]["actions"]) == len(record.details.actions)
    assert data["details"]["adaptations"] and all(c["after"] >= c["before"] for c in data["details"]["adaptations"])


def test_execution_in_the_blocked_maze_inserts_the_unforeseen_outcome_and_terminates():
    """se2-maze with the block added during execution (thesis 5.4.3): the robot gets stuck on the block, the
    stuck configuration matches no planned outcome and is inserted; with no alternative route the policy's
    P(goal) falls below P_goal and execution stops with a failure (instead of pushing on)."""
    planned = maze_context("se2-maze")
    ctx = maze_context("se2-maze:blocked")
    controller = registry.create("controller", "contact", ctx)
    policy = PartialPolicy.from_tree(maze_tree(planned), goal=planned.scene.goal,
                                     goal_tolerance=planned.scene.goal_tolerance)
    matcher = DistanceMatcher(ctx.robot.space, 0.5)
    record = execute_policy(policy, ctx.simulator, controller, np.random.default_rng(0), matcher=matcher,
                            time_limit=60.0, action_limit=10)
    assert record.outcome == "failure", record.events
    first = record.details.actions[0]
    assert first["drive"] == "stuck" and first["inserted"] and first["node"] == len(maze_tree(planned).nodes)
    assert first["reached"][1] > 5.0                                  # stopped above the block (y = 5)
    assert record.contacts.any()
    assert record.details.actions[-1]["probability"] < policy.options.p_goal
    assert any("inserted" in e for e in record.events) and any("P_goal" in e for e in record.events)


@pytest.mark.parametrize("final_approach", [True, False])
def test_a_goal_vertex_reached_outside_the_tolerance_gets_one_final_approach(final_approach):
    """The policy's last vertex counts as a goal (its goal fraction), but it lies 0.5 from the goal (tolerance
    0.4375): with the final approach the robot then drives to the goal itself and succeeds; without it the
    execution ends there as a failure."""
    ctx = maze_context("se2-maze")
    controller = registry.create("controller", "contact", ctx)
    tree = maze_tree(ctx)
    near_goal = np.array([1.25, 0.75, 0.0])
    last = tree.nodes[-1]
    last.particles = near_goal + (last.particles - last.particles.mean(axis=0))
    last.action = near_goal.copy()
    last.expected = near_goal.copy()
    policy = PartialPolicy.from_tree(tree, goal=ctx.scene.goal, goal_tolerance=ctx.scene.goal_tolerance)
    record = execute_policy(policy, ctx.simulator, controller, np.random.default_rng(0),
                            matcher=DistanceMatcher(ctx.robot.space, 0.3), time_limit=120.0, action_limit=10,
                            final_approach=final_approach)
    assert record.details.actions[2]["node"] == 3 and record.details.actions[2]["status"] == "goal"
    if final_approach:
        assert record.success and record.details.actions[-1]["kind"] == "goal" and len(record.details.actions) == 4
        assert ctx.robot.space.distance(record.configurations[-1], ctx.scene.goal) <= ctx.scene.goal_tolerance
    else:
        assert record.outcome == "failure" and len(record.details.actions) == 3
        assert any("outside the goal tolerance" in e for e in record.events)
