"""Partial policies of thesis 5.3.4-5.3.5: construction from the solution paths, the query of Algorithm 4 and
online adaptation (eq. 5.2-5.3).

**The graph** (5.3.4).  Its vertices are the nodes on the planner's solution paths plus, by default, the
other outcomes of the same actions (the siblings of a split: the robot can land there, and knowing them
lets the query match them instead of inserting a new node; ``include_siblings=False`` keeps only the
solution nodes, as the thesis lists them).  Every action of the graph is a :class:`PolicyAction` performed
from one vertex (its ``source``) toward a target configuration, with one or more outcomes:

- a *forward* action is one EXTEND of the planner (the tree's ``action_id``); its outcomes are the vertices
  sharing that ``action_id``, and its target is their ``action``;
- a *reverse* action returns from a vertex to its parent (target = the parent's expected configuration);
  its planned outcome is the parent, with the planner's ``reverse_probability``.  Reverse actions make the
  retries of 5.3.2 representable: after a miss the policy returns and tries again.

Each action keeps the counts of eq. 5.2-5.3: ``attempts`` (N_attempts, shared by its outcomes) and
``successes[outcome]`` (N_successful).  The planner's probabilities initialise them as particle counts:
a forward action simulated ``N`` particles (the sum of its outcomes' particles), so ``attempts = N`` and
``successes = P(source -> outcome) * N``; a reverse action starts from ``N`` too, with
``successes[parent] = reverse_probability * N``.  ``P(source -> outcome | action) = successes / attempts``,
so the outcomes of an action always sum to one (when every outcome is a vertex).

**Edges and costs.**  Each (action, outcome) pair is an edge ``source -> outcome`` with probability ``p``.
Its retry probability ``r`` is the probability of returning to ``source`` after a miss: the
probability-weighted mean, over the miss mass ``1 - p``, of the other outcomes' reverse probabilities back
to ``source`` (0 for an outcome whose reverse action leads elsewhere, and for miss mass no outcome accounts
for -- e.g. a reverse action's failures before any was observed, or siblings left out of the graph), as in
the local planner.
The edge's effective probability is the retry formula of 5.3.2 with ``attempts`` (N_attempt) tries,
:func:`pliant_belief.belief.effective_probability`.  Its cost is ``1 / p`` times the number of attempts
needed to reach ``P_goal`` -- the smallest ``k`` with ``effective_probability(p, r, k) >= P_goal``,
capped at N_attempt (an edge that cannot reach ``P_goal`` within N_attempt tries costs ``N_attempt / p``);
edges with ``p = 0`` are dropped.

**Goals and Dijkstra.**  Goal vertices are the ends of the solutions and any vertex whose own goal fraction
is at least ``P_goal``; stopping at a goal vertex costs ``1 / goal_fraction`` (the last "edge" into the goal
region).  Dijkstra from the goal vertices over the reversed edges gives every vertex its distance to the
goal and its best edge; :meth:`PartialPolicy.next_action` is that edge's action (``None`` at a goal vertex
where stopping is best, or where no route exists).  ``P(node -> goal)`` follows the chosen route: the product
of the edges' effective probabilities times the goal fraction of the vertex where it stops.  With
``attempts = 1`` the effective probability is the raw probability and ``P(node -> goal)`` is the plain
product of the thesis's termination proof; with the thesis's ``N_attempt = 50`` a miss on a reversible split
does not end execution (the robot returns and retries), which is the point of 5.3.2.

**The query** (Algorithm 4, :meth:`PartialPolicy.query`).  Given the configuration reached and the action
performed, the potential result nodes are the action's outcomes; those whose belief clusters with the
observation (an injected ``matcher(particles, q) -> bool``, normally the clustering of 5.3.3) match, and the
one with the smallest Dijkstra distance is ``n_reached``.  Eq. 5.2-5.3 then add ``A_importance`` to the
action's ``attempts`` and to ``successes[n_reached]``:
``P(prev -> reached) = (N_successful + A) / (N_attempts + A)``, every other outcome
``N_successful / (N_attempts + A)``.  The policy is rebuilt; if ``P(n_reached -> goal) < P_goal`` the query
reports failure.  When nothing matches, ``n_observed = ({q_current}, a_performed)`` is inserted as a new
outcome of the action (``successes = 0``, then raised by the update) whose reverse action back to the node
the action was performed from has the prior ``N_attempts = N_successful = 1``, so the next action is to
return (thesis 5.3.5).

**Relocalization** (``PolicyOptions.relocalize``, on by default; not in the thesis).  Before inserting, the
observation is matched against every vertex with a route to the goal (in order of Dijkstra distance); the
first whose belief clusters with it becomes a new outcome of the performed action (``successes = 0``,
raised by the update like any match) and execution continues from there.  The thesis inserts a new node
whose only action is to return; when the dynamic world differs from the planner's simulator, an action
often lands the robot where *another* branch of the policy already knows what to do (measured on se2-maze,
policies planned with the kinematic simulator and executed in pymunk: the block slid past a wall end onto
a solution path's node, or next to the goal, and the thesis's policy reversed).  The performed action's
planned outcomes lose probability by eq. 5.3 exactly as with an insertion.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import ClassVar

import numpy as np
from pliant.api import ConfigError, DimensionError, PlanningError, Policy, Space, build_options, option, space_from_dict

from pliant_belief.belief import BeliefNode, BeliefTree, effective_probability

#: ``matcher(particles (k, d), q (d,)) -> bool``: whether ``q`` clusters with the belief into one cluster.
Matcher = Callable[[np.ndarray, np.ndarray], bool]


@dataclass(frozen=True)
class PolicyOptions:
    """Options of :class:`PartialPolicy` (thesis 5.3.4-5.3.5; the thesis's values as defaults)."""

    p_goal: float = option(0.51, "P_goal: the policy fails when P(node -> goal) falls below this", minimum=0.0,
                           maximum=1.0)
    attempts: int = option(50, "N_attempt: tries counted in an edge's effective probability, and the cap of the "
                               "attempts-needed estimate of the edge cost (1 = raw probabilities)", minimum=1)
    importance: float = option(500.0, "A_importance: weight of one executed action against one simulated particle "
                                      "in eq. 5.2-5.3 (thesis: 500 in se2-maze; 0 disables adaptation)",
                               minimum=0.0)
    relocalize: bool = option(True, "when no outcome of the performed action matches, match the observation "
                                    "against every vertex of the policy (nearest to the goal first) before "
                                    "inserting a new one (an extension of thesis 5.3.5)")


@dataclass
class PolicyAction:
    """An action of the policy graph: from vertex ``source`` toward ``target`` ``(d,)``, with its outcomes.

    ``id`` is the planner's ``action_id`` for forward actions and a fresh id for reverse actions.
    ``attempts`` (N_attempts) and ``successes[outcome]`` (N_successful) are the counts of eq. 5.2-5.3;
    ``P(source -> outcome) = successes[outcome] / attempts``.
    """

    id: int
    source: int
    target: np.ndarray
    kind: str
    outcomes: list[int] = field(default_factory=list)
    attempts: float = 1.0
    successes: dict[int, float] = field(default_factory=dict)

    def probability(self, outcome: int) -> float:
        """``P(source -> outcome | this action)`` (eq. 5.2-5.3 after any updates)."""
        if self.attempts <= 0:
            return 0.0
        return min(1.0, max(0.0, self.successes.get(outcome, 0.0) / self.attempts))

    def to_dict(self) -> dict:
        return {"id": self.id, "source": self.source, "target": self.target.tolist(), "kind": self.kind,
                "outcomes": list(self.outcomes), "attempts": self.attempts,
                "successes": [[int(k), float(v)] for k, v in self.successes.items()]}

    @classmethod
    def from_dict(cls, data: dict) -> PolicyAction:
        try:
            return cls(id=int(data["id"]), source=int(data["source"]),
                       target=np.asarray(data["target"], dtype=np.float64), kind=str(data["kind"]),
                       outcomes=[int(o) for o in data["outcomes"]], attempts=float(data["attempts"]),
                       successes={int(k): float(v) for k, v in data["successes"]})
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"malformed policy action: {exc}", field="policy.actions") from None


@dataclass(frozen=True)
class PolicyEdge:
    """One edge ``source -> outcome`` of ``action`` with its probability, retry probability, effective
    probability (thesis 5.3.2), attempts needed to reach ``P_goal`` and cost ``attempts_needed / probability``."""

    action: int
    source: int
    outcome: int
    probability: float
    retry: float
    effective: float
    attempts_needed: int
    cost: float


@dataclass
class PolicyQuery:
    """What one query (thesis Algorithm 4) did.

    status: ``continue`` (``action`` is the next action), ``goal`` (the reached node is a goal vertex where
    stopping is best) or ``failure`` (``P(node -> goal) < P_goal``).
    node: the reached vertex (matched or inserted); ``inserted``: whether it was inserted; ``relocalized``:
    whether it is a vertex that was not an outcome of the action (found by :attr:`PolicyOptions.relocalize`).
    matching: every outcome that matched.  probability: ``P(node -> goal)`` after the update.
    changes: the probability updates ``[{"action", "outcome", "before", "after"}, ...]``.
    """

    action: PolicyAction | None
    node: int
    status: str
    inserted: bool
    matching: list[int]
    probability: float
    changes: list[dict]
    relocalized: bool = False


class DistanceMatcher:
    """A simple matcher: ``q`` matches a belief when it lies within ``radius`` (space metric) of one of its
    particles, or within ``radius`` of the belief's mean.  For tests and for execution without clustering."""

    def __init__(self, space: Space, radius: float) -> None:
        if not (np.isfinite(radius) and radius > 0):
            raise ConfigError("radius must be positive (space metric)", field="radius", value=radius)
        self.space = space
        self.radius = float(radius)

    def __call__(self, particles: np.ndarray, q: np.ndarray) -> bool:
        particles = np.atleast_2d(particles)
        if float(np.min(self.space.distance(particles, q))) <= self.radius:
            return True
        return bool(float(self.space.distance(self.space.mean(particles), q)) <= self.radius)


class PartialPolicy(Policy):
    """The partial policy of thesis 5.3.4-5.3.5 (see the module docstring).

    Build it with :meth:`from_tree`.  Vertices are indexed ``0..n-1`` (0 = the start, the tree's root);
    ``tree_index[i]`` is the tree node a vertex came from (``-1`` for nodes inserted during execution).
    ``matcher`` (not saved) is used by :meth:`query` when no matcher is passed.
    """

    kind: ClassVar[str] = "partial-policy"
    #: executed by the core's one execution loop with :class:`pliant_belief.execute.PolicyStrategy`
    follower: ClassVar[str] = "pliant_belief.execute:follow_policy"

    def __init__(self, space: Space, nodes: list[BeliefNode], actions: dict[int, PolicyAction],
                 reverse_of: dict[int, int], solutions: list[list[int]], options: PolicyOptions | None = None, *,
                 tree_index: list[int] | None = None, goal: np.ndarray | None = None, goal_tolerance: float = 0.0,
                 clustering: str | None = None, next_id: int | None = None) -> None:
        self.space = space
        self.nodes = nodes
        self.actions = actions
        self.reverse_of = reverse_of
        self.solutions = solutions
        self.options = options if options is not None else PolicyOptions()
        self.tree_index = list(tree_index) if tree_index is not None else list(range(len(nodes)))
        self.goal = None if goal is None else np.asarray(goal, dtype=np.float64)
        self.goal_tolerance = float(goal_tolerance)
        self.clustering = clustering
        #: the clustering match's thresholds (wcr_threshold, distance_threshold), saved with the policy so that a
        #: policy loaded from a file matches observations as the planner that made it did
        self.match_thresholds: dict[str, float | None] = {}
        self.next_id = next_id if next_id is not None else max(actions, default=0) + 1
        self.matcher: Matcher | None = None
        self.start_node = 0
        if not nodes:
            raise ConfigError("a policy needs at least the start node", field="policy.nodes", value=0)
        self.rebuild()

    # --- construction (5.3.4) ------------------------------------------------------------------------

    @classmethod
    def from_tree(cls, tree: BeliefTree, *, p_goal: float = 0.51, attempts: int = 50, importance: float = 500.0,
                  goal: np.ndarray | None = None, goal_tolerance: float = 0.0, clustering: str | None = None,
                  include_siblings: bool = True, options: PolicyOptions | dict | None = None) -> PartialPolicy:
        """The policy over ``tree.solutions`` (thesis 5.3.4).

        ``p_goal``, ``attempts`` (N_attempt) and ``importance`` (A_importance) fill :class:`PolicyOptions`
        unless ``options`` is given.  ``goal`` ``(d,)`` and ``goal_tolerance`` (space metric) give nodes
        inserted during execution their goal fraction.  ``clustering`` records the clustering method name
        (for the matcher of execution).  Raises :class:`ConfigError` for a tree without solutions or with a
        solution that is not a root-to-node branch.
        """
        if options is None:
            options = PolicyOptions(p_goal=p_goal, attempts=attempts, importance=importance)
        elif not isinstance(options, PolicyOptions):
            options = build_options(PolicyOptions, options, prefix="policy")
        else:
            options = build_options(PolicyOptions, asdict(options), prefix="policy")
        if not tree.solutions:
            raise ConfigError("the tree has no solution to build a policy from", field="solutions", value=[])
        n = len(tree.nodes)
        on_path: set[int] = set()
        for s, solution in enumerate(tree.solutions):
            if not solution or solution[0] != 0 or any(not (0 <= i < n) for i in solution):
                raise ConfigError("a solution must list node indices from the root (0)", field=f"solutions[{s}]",
                                  value=list(solution))
            for a, b in itertools.pairwise(solution):
                if tree.nodes[b].parent != a:
                    raise ConfigError(f"node {b} is not a child of node {a}", field=f"solutions[{s}]",
                                      value=list(solution))
            on_path.update(solution)
        by_action: dict[int, list[int]] = {}
        for i, node in enumerate(tree.nodes):
            if i != 0:
                by_action.setdefault(node.action_id, []).append(i)
        vertices = set(on_path)
        if include_siblings:
            for i in on_path - {0}:
                vertices.update(by_action[tree.nodes[i].action_id])
        order = sorted(vertices)
        index = {t: k for k, t in enumerate(order)}
        nodes = []
        for t in order:
            src = tree.nodes[t]
            nodes.append(BeliefNode(
                particles=src.particles.copy(), action=None if src.action is None else src.action.copy(),
                parent=index[src.parent] if src.parent >= 0 else -1, action_id=src.action_id,
                probability=src.probability, reverse_probability=src.reverse_probability,
                effective_probability=src.effective_probability, path_probability=src.path_probability,
                goal_fraction=src.goal_fraction, split=src.split,
                expected=tree.space.mean(src.particles) if src.expected is None else src.expected.copy(),
                variance=src.variance))
        actions: dict[int, PolicyAction] = {}
        for k, t in enumerate(order):
            if k == 0:
                continue
            node = tree.nodes[t]
            aid = node.action_id
            group = by_action[aid]
            if any(tree.nodes[g].parent != node.parent for g in group):
                raise ConfigError("the outcomes of one action must share their parent", field="action_id", value=aid)
            if aid not in actions:
                total = float(sum(len(tree.nodes[g].particles) for g in group))
                actions[aid] = PolicyAction(id=aid, source=index[node.parent],
                                            target=np.asarray(node.action, dtype=np.float64).copy(), kind="forward",
                                            attempts=max(total, 1.0))
            action = actions[aid]
            action.outcomes.append(k)
            action.successes[k] = node.probability * action.attempts
        next_id = max([*actions, max(by_action, default=0), 0]) + 1
        reverse_of: dict[int, int] = {}
        for k in range(1, len(order)):
            node = nodes[k]
            base = actions[node.action_id].attempts
            actions[next_id] = PolicyAction(id=next_id, source=k, target=nodes[node.parent].expected.copy(),
                                            kind="reverse", outcomes=[node.parent], attempts=base,
                                            successes={node.parent: node.reverse_probability * base})
            reverse_of[k] = next_id
            next_id += 1
        solutions = [[index[i] for i in s] for s in tree.solutions]
        return cls(tree.space, nodes, actions, reverse_of, solutions, options, tree_index=order, goal=goal,
                   goal_tolerance=goal_tolerance, clustering=clustering, next_id=next_id)

    def rebuild(self) -> None:
        """Recompute edge probabilities and costs, the goal vertices and Dijkstra (CONSTRUCTPOLICY, 5.3.4)."""
        o = self.options
        n = len(self.nodes)
        edges: list[PolicyEdge] = []
        for action in self.actions.values():
            probabilities = {v: action.probability(v) for v in action.outcomes}
            for v in action.outcomes:
                p = probabilities[v]
                if p <= 0:
                    continue
                back = sum(probabilities[w] * self._return_probability(w, action.source)
                           for w in action.outcomes if w != v)
                retry = min(1.0, back / (1.0 - p)) if p < 1.0 else 1.0
                effective = min(1.0, effective_probability(p, retry, o.attempts))
                needed = attempts_needed(p, retry, o.p_goal, o.attempts)
                edges.append(PolicyEdge(action.id, action.source, v, p, retry, effective, needed, needed / p))
        self.edges = edges
        goals = {s[-1] for s in self.solutions}
        goals.update(i for i, node in enumerate(self.nodes) if node.goal_fraction >= o.p_goal > 0)
        self.goals = {g for g in goals if self.nodes[g].goal_fraction > 0}
        incoming: list[list[PolicyEdge]] = [[] for _ in range(n)]
        for e in edges:
            incoming[e.outcome].append(e)
        dist = np.full(n, np.inf)
        best: list[PolicyEdge | None] = [None] * n
        heap = []
        for g in self.goals:
            dist[g] = 1.0 / self.nodes[g].goal_fraction
            heap.append((dist[g], g))
        heapq.heapify(heap)
        done = np.zeros(n, dtype=bool)
        while heap:
            d, v = heapq.heappop(heap)
            if done[v]:
                continue
            done[v] = True
            for e in incoming[v]:
                candidate = d + e.cost
                if candidate < dist[e.source] - 1e-12:
                    dist[e.source] = candidate
                    best[e.source] = e
                    heapq.heappush(heap, (candidate, e.source))
        self.distances = dist
        self.best_edge = best
        probability = np.zeros(n)
        for v in np.argsort(dist, kind="stable"):
            if not np.isfinite(dist[v]):
                break
            e = best[v]
            probability[v] = self.nodes[v].goal_fraction if e is None else e.effective * probability[e.outcome]
        self.probabilities = probability
        for action in self.actions.values():
            for v in action.outcomes:
                node = self.nodes[v]
                if node.parent == action.source and node.action_id == action.id:
                    node.probability = action.probability(v)
            if action.kind == "reverse":
                self.nodes[action.source].reverse_probability = action.probability(self.nodes[action.source].parent)
        for e in edges:
            node = self.nodes[e.outcome]
            if node.parent == e.source and node.action_id == e.action:
                node.effective_probability = e.effective

    def _return_probability(self, node: int, to: int) -> float:
        """Probability that ``node``'s reverse action brings the robot back to ``to`` (0 if it leads elsewhere;
        1 when ``node`` is ``to``: an outcome that stayed at the action's source needs no return)."""
        if node == to:
            return 1.0
        rid = self.reverse_of.get(node)
        if rid is None:
            return 0.0
        action = self.actions[rid]
        return action.probability(to) if to in action.outcomes else 0.0

    # --- reading the policy ----------------------------------------------------------------------------

    def _check_node(self, node: int) -> int:
        if isinstance(node, bool) or not isinstance(node, (int, np.integer)) or not 0 <= node < len(self.nodes):
            raise ConfigError(f"no such policy node (the policy has {len(self.nodes)})", field="node", value=node)
        return int(node)

    def next_action(self, node: int) -> PolicyAction | None:
        """The action minimising edge cost + distance-to-goal of its outcome from ``node`` (thesis 5.3.4);
        ``None`` at a goal vertex where stopping is best, or when no route to the goal exists."""
        e = self.best_edge[self._check_node(node)]
        return None if e is None else self.actions[e.action]

    def first_action(self) -> PolicyAction | None:
        """The action to perform from the start node."""
        return self.next_action(self.start_node)

    def distance(self, node: int) -> float:
        """Dijkstra distance (expected-attempt cost) from ``node`` to the goal; ``inf`` when unreachable."""
        return float(self.distances[self._check_node(node)])

    def goal_probability(self, node: int) -> float:
        """``P(node -> goal)`` along the policy's route: product of effective edge probabilities times the goal
        fraction of the vertex where the route stops (0 when no route exists)."""
        return float(self.probabilities[self._check_node(node)])

    def route(self, node: int) -> list[int]:
        """The vertices the policy plans to visit from ``node`` to the goal vertex where it stops."""
        chain = [self._check_node(node)]
        while self.best_edge[chain[-1]] is not None and len(chain) <= len(self.nodes):
            chain.append(self.best_edge[chain[-1]].outcome)
        return chain

    def is_goal(self, node: int) -> bool:
        """Whether ``node`` is a goal vertex (a solution end, or its goal fraction alone reaches ``P_goal``)."""
        return self._check_node(node) in self.goals

    def edge(self, source: int, outcome: int, action: int | None = None) -> PolicyEdge:
        """The edge ``source -> outcome`` (of ``action`` if given); :class:`ConfigError` when there is none."""
        for e in self.edges:
            if e.source == source and e.outcome == outcome and (action is None or e.action == action):
                return e
        raise ConfigError("no such policy edge", field="edge", value=(source, outcome, action))

    def outcomes(self, action_id: int) -> list[int]:
        """The potential result nodes of an action (thesis Algorithm 4, N_potential)."""
        return list(self._action(action_id).outcomes)

    def _action(self, action_id: int) -> PolicyAction:
        try:
            return self.actions[int(action_id)]
        except (KeyError, TypeError, ValueError):
            raise ConfigError("unknown action id", field="performed_action_id", value=action_id) from None

    # --- query and adaptation (Algorithm 4, 5.3.5) -----------------------------------------------------

    def query(self, q_current: np.ndarray, performed_action_id: int, matcher: Matcher | None = None
              ) -> tuple[PolicyAction | None, int]:
        """Thesis Algorithm 4: ``(next action or None, reached node)``; see :meth:`query_step` for details."""
        step = self.query_step(q_current, performed_action_id, matcher)
        return step.action, step.node

    def query_step(self, q_current: np.ndarray, performed_action_id: int, matcher: Matcher | None = None
                   ) -> PolicyQuery:
        """Match ``q_current`` ``(d,)`` reached by performing ``performed_action_id`` against that action's
        outcomes, update the probabilities (eq. 5.2-5.3), rebuild, and return the next action.

        ``matcher(particles, q) -> bool`` (else :attr:`matcher`) decides whether ``q`` clusters with a node's
        belief.  An unmatched observation is inserted as a new node (thesis 5.3.5).
        """
        matcher = matcher if matcher is not None else self.matcher
        if matcher is None:
            raise PlanningError("the policy query needs a matcher(particles, q) -> bool", field="matcher",
                                value=None)
        q = np.asarray(q_current, dtype=np.float64)
        if q.shape != (self.space.dim,) or not np.all(np.isfinite(q)):
            raise DimensionError(f"q_current must be a finite configuration of shape ({self.space.dim},)",
                                 field="q_current", value=q.tolist())
        action = self._action(performed_action_id)
        matching = [v for v in action.outcomes if matcher(self.nodes[v].particles, q)]
        inserted = relocalized = False
        if matching:
            reached = min(matching, key=lambda v: (self.distances[v], v))
        else:
            known = self._relocalize(q, matcher) if self.options.relocalize else None
            if known is not None:
                reached, relocalized = known, True
                action.outcomes.append(known)
                action.successes.setdefault(known, 0.0)
            else:
                reached, inserted = self.insert(q, action.id), True
        before = {v: action.probability(v) for v in action.outcomes}
        action.attempts += self.options.importance
        action.successes[reached] = action.successes.get(reached, 0.0) + self.options.importance
        changes = [{"action": action.id, "outcome": v, "before": before[v], "after": action.probability(v)}
                   for v in action.outcomes]
        self.rebuild()
        probability = self.goal_probability(reached)
        nxt = self.next_action(reached)
        if probability < self.options.p_goal or (nxt is None and reached not in self.goals):
            status, nxt = "failure", None
        elif nxt is None:
            status = "goal"
        else:
            status = "continue"
        return PolicyQuery(nxt, reached, status, inserted, matching, probability, changes, relocalized)

    def _relocalize(self, q: np.ndarray, matcher: Matcher) -> int | None:
        """The vertex with a route to the goal, nearest to it first, whose belief ``q`` clusters with; or ``None``.

        Every such vertex is asked in order of Dijkstra distance (the matcher is the only judge: its
        thresholds are not known here).  It runs only for observations no planned outcome matched.
        """
        order = [v for v in np.argsort(self.distances, kind="stable") if np.isfinite(self.distances[v])]
        for v in order:
            if matcher(self.nodes[v].particles, q):
                return int(v)
        return None

    def insert(self, q: np.ndarray, action_id: int) -> int:
        """Insert ``n_observed = ({q}, a)`` as a new outcome of action ``action_id`` (thesis 5.3.5).

        Its parent is the node the action was performed from; ``successes = 0`` (the query's update raises
        it); its reverse action back to that node has the prior ``N_attempts = N_successful = 1``.  Returns
        the new vertex index.  The policy is rebuilt by the caller (:meth:`query_step`) or :meth:`rebuild`.
        """
        action = self._action(action_id)
        q = np.asarray(q, dtype=np.float64).reshape(1, -1)
        if q.shape[1] != self.space.dim or not np.all(np.isfinite(q)):
            raise DimensionError(f"q must be a finite configuration of shape ({self.space.dim},)", field="q",
                                 value=q.tolist())
        parent = action.source
        goal_fraction = 0.0
        if self.goal is not None:
            goal_fraction = float(self.space.distance(q[0], self.goal) <= self.goal_tolerance)
        node = BeliefNode(particles=q.copy(), action=action.target.copy(), parent=parent, action_id=action.id,
                          probability=0.0, reverse_probability=1.0, effective_probability=0.0, path_probability=0.0,
                          goal_fraction=goal_fraction, split=True, expected=q[0].copy(), variance=0.0)
        self.nodes.append(node)
        self.tree_index.append(-1)
        k = len(self.nodes) - 1
        action.outcomes.append(k)
        action.successes[k] = 0.0
        rid = self.next_id
        self.next_id += 1
        self.actions[rid] = PolicyAction(id=rid, source=k, target=self.nodes[parent].expected.copy(), kind="reverse",
                                         outcomes=[parent], attempts=1.0, successes={parent: 1.0})
        self.reverse_of[k] = rid
        return k

    # --- files ---------------------------------------------------------------------------------------------

    def to_dict(self) -> dict:
        """JSON-ready description; :meth:`from_dict` rebuilds an equal policy (without its matcher)."""
        return {"kind": self.kind, "space": self.space.to_dict(), "options": asdict(self.options),
                "nodes": [n.to_dict() for n in self.nodes], "tree_index": list(self.tree_index),
                "actions": [a.to_dict() for a in self.actions.values()],
                "reverse_of": [[int(k), int(v)] for k, v in self.reverse_of.items()],
                "solutions": [list(s) for s in self.solutions],
                "goal": None if self.goal is None else self.goal.tolist(), "goal_tolerance": self.goal_tolerance,
                "clustering": self.clustering, "match_thresholds": dict(self.match_thresholds),
                "next_id": self.next_id}

    @classmethod
    def from_dict(cls, data: dict) -> PartialPolicy:
        """The policy :meth:`to_dict` described; raises :class:`ConfigError` naming the malformed field."""
        if data.get("kind") != cls.kind:
            raise ConfigError(f"not a {cls.kind}", field="policy.kind", value=data.get("kind"))
        try:
            space = space_from_dict(data["space"])
            options = build_options(PolicyOptions, data.get("options") or {}, prefix="policy.options")
            nodes = [BeliefNode.from_dict(n) for n in data["nodes"]]
            actions = {a.id: a for a in (PolicyAction.from_dict(x) for x in data["actions"])}
            reverse_of = {int(k): int(v) for k, v in data["reverse_of"]}
            solutions = [[int(i) for i in s] for s in data["solutions"]]
            goal = data.get("goal")
            policy = cls(space, nodes, actions, reverse_of, solutions, options,
                         tree_index=[int(i) for i in data["tree_index"]],
                         goal=None if goal is None else np.asarray(goal, dtype=np.float64),
                         goal_tolerance=float(data.get("goal_tolerance", 0.0)), clustering=data.get("clustering"),
                         next_id=int(data["next_id"]))
            thresholds = data.get("match_thresholds") or {}
            unknown = sorted(set(thresholds) - {"wcr_threshold", "distance_threshold"})
            if unknown:
                raise ConfigError("unknown match thresholds", field="policy.match_thresholds", value=unknown)
            policy.match_thresholds = {k: None if v is None else float(v) for k, v in thresholds.items()}
        except KeyError as exc:
            raise ConfigError("missing field in a partial policy", field=f"policy.{exc.args[0]}") from None
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"malformed partial policy: {exc}", field="policy") from None
        policy._validate()
        return policy

    def _validate(self) -> None:
        n = len(self.nodes)
        for a in self.actions.values():
            if not 0 <= a.source < n or any(not 0 <= o < n for o in a.outcomes):
                raise ConfigError("an action refers to a missing node", field=f"policy.actions[{a.id}]",
                                  value=[a.source, *a.outcomes])
        for k, rid in self.reverse_of.items():
            if rid not in self.actions or not 0 <= k < n:
                raise ConfigError("a reverse action is missing", field="policy.reverse_of", value=[k, rid])

    def use_clustering(self, context, *, wcr_threshold: float | None = None, distance_threshold: float | None = None,
                       rng: np.random.Generator | None = None) -> None:
        """Set :attr:`matcher` to the clustering match of Algorithm 4 (:func:`pliant.planning.clustering.matches`)
        with the policy's clustering method, over a pipeline ``context`` (scene, robot, simulator).

        Thresholds not given come from :attr:`match_thresholds` (what the planner used, saved with the policy),
        else the clustering defaults (WCR 0.75, distance 8 voxels); the ones used are recorded there."""
        from pliant.api import ClusteringContext, matches

        if wcr_threshold is None:
            saved = self.match_thresholds.get("wcr_threshold")
            wcr_threshold = 0.75 if saved is None else saved
        if distance_threshold is None:
            distance_threshold = self.match_thresholds.get("distance_threshold")
        self.match_thresholds = {"wcr_threshold": wcr_threshold, "distance_threshold": distance_threshold}

        method = self.clustering or "distance"
        clustering_context = context if isinstance(context, ClusteringContext) else \
            ClusteringContext.from_context(context)

        def matcher(particles: np.ndarray, q: np.ndarray) -> bool:
            return matches(particles, q, method, clustering_context, wcr_threshold=wcr_threshold,
                           distance_threshold=distance_threshold, rng=rng)

        self.matcher = matcher


def attempts_needed(p: float, retry: float, p_goal: float, cap: int) -> int:
    """Smallest ``k <= cap`` with ``effective_probability(p, retry, k) >= p_goal`` (thesis 5.3.4, step 2: the
    complement of the effective probability); ``cap`` when ``p_goal`` is out of reach within ``cap`` tries.

    ``p`` and ``retry`` are probabilities in [0, 1]; ``cap`` >= 1 (N_attempt).
    """
    if cap < 1:
        raise ConfigError("the attempt cap must be at least 1", field="attempts", value=cap)
    if p <= 0:
        return cap
    if p >= p_goal:
        return 1
    r = (1.0 - p) * retry
    if r <= 0:
        return cap
    if r < 1.0:
        # p (1 - r^k) / (1 - r) >= p_goal  <=>  r^k <= 1 - p_goal (1 - r) / p
        bound = 1.0 - p_goal * (1.0 - r) / p
        if bound <= 0:
            return cap
        k = math.ceil(math.log(bound) / math.log(r) - 1e-12)
    else:
        k = math.ceil(p_goal / p - 1e-12)
    k = max(1, min(cap, k))
    while k > 1 and effective_probability(p, retry, k - 1) >= p_goal:     # guard the rounding of log
        k -= 1
    while k < cap and effective_probability(p, retry, k) < p_goal:
        k += 1
    return k
