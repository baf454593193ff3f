"""The belief tree of thesis ch. 5: nodes ``n_i = (b_i, a_i)`` holding particles and the action that produced them.

Every node stores its belief as particles (configurations ``(k, d)``, forward-simulated by the local
planner, thesis 5.3.2), the action (a target configuration) that produced it, and the probabilities
the planner estimated for the edge from its parent:

- ``probability``: ``P(parent -> node | action)``, the fraction of the action's particles that ended
  in this node's cluster (``|b_new| / N_particles``; the siblings of a split share the action);
- ``reverse_probability``: the fraction of particles simulated back toward the parent that reached it;
- ``effective_probability``: the probability of having reached the node after ``N_attempt`` attempts,
  reversing to the parent and retrying after each miss (thesis 5.3.2);
- ``path_probability``: ``P(start -> node)``, the product of ``probability`` along the branch (eq. 5.1);
- ``goal_fraction``: the fraction of the node's particles within the goal tolerance.

``action_id`` identifies one EXTEND call: the nodes of a split share it, so an executed action can be
matched against every outcome it may have had (thesis Algorithm 4).  The tree is plain data: the
planner grows it, the policy is built from it, and it saves to JSON.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pliant.api import ConfigError, Space


def effective_probability(p: float, reverse: float, attempts: int) -> float:
    """Probability of reaching a node within ``attempts`` tries (thesis 5.3.2).

    Each try succeeds with ``p``; after a miss (the action ended in another outcome) the robot returns to
    the parent with probability ``reverse`` (the planner uses the missed outcomes' reverse probability)
    and tries again; a failed return ends the retries:
    ``p * sum_{k=0}^{attempts-1} ((1 - p) * reverse)^k``.
    """
    if attempts < 1:
        raise ConfigError("attempts must be at least 1", field="attempts", value=attempts)
    retry = (1.0 - p) * reverse
    if retry >= 1.0:
        return p * attempts
    return p * (1.0 - retry ** attempts) / (1.0 - retry)


@dataclass
class BeliefNode:
    """One node of the belief tree (see the module docstring for the probabilities)."""

    particles: np.ndarray
    action: np.ndarray | None
    parent: int
    action_id: int
    probability: float = 1.0
    reverse_probability: float = 1.0
    effective_probability: float = 1.0
    path_probability: float = 1.0
    goal_fraction: float = 0.0
    split: bool = False
    expected: np.ndarray | None = None
    variance: float = 0.0

    def to_dict(self) -> dict:
        return {"particles": self.particles.tolist(), "action": None if self.action is None else self.action.tolist(),
                "parent": self.parent, "action_id": self.action_id, "probability": self.probability,
                "reverse_probability": self.reverse_probability,
                "effective_probability": self.effective_probability, "path_probability": self.path_probability,
                "goal_fraction": self.goal_fraction, "split": self.split,
                "expected": None if self.expected is None else self.expected.tolist(), "variance": self.variance}

    @classmethod
    def from_dict(cls, data: dict) -> BeliefNode:
        expected = data.get("expected")
        try:
            return cls(particles=np.asarray(data["particles"], dtype=np.float64),
                       action=None if data["action"] is None else np.asarray(data["action"], dtype=np.float64),
                       parent=int(data["parent"]), action_id=int(data["action_id"]),
                       probability=float(data["probability"]), reverse_probability=float(data["reverse_probability"]),
                       effective_probability=float(data["effective_probability"]),
                       path_probability=float(data["path_probability"]), goal_fraction=float(data["goal_fraction"]),
                       split=bool(data["split"]),
                       expected=None if expected is None else np.asarray(expected, dtype=np.float64),
                       variance=float(data.get("variance", 0.0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"malformed belief node: {exc}", field="policy.nodes") from None


@dataclass
class BeliefTree:
    """The planner's tree: nodes in insertion order (node 0 is the start) and the solutions found.

    ``solutions``: each a list of node indices from the root to a node whose probability of reaching the
    goal, ``path_probability * goal_fraction``, is at least ``P_goal`` (thesis 5.3.1).
    ``excluded``: nodes removed from nearest-neighbour consideration (solved branches, thesis 5.3.1).
    """

    space: Space
    nodes: list[BeliefNode] = field(default_factory=list)
    solutions: list[list[int]] = field(default_factory=list)
    excluded: set[int] = field(default_factory=set)
    _actions: int = 0

    def new_action_id(self) -> int:
        """A fresh identifier for one EXTEND call (shared by the outcomes of a split)."""
        self._actions += 1
        return self._actions

    def add(self, node: BeliefNode) -> int:
        """Append ``node`` (its ``expected`` and ``variance`` computed here when missing); returns its index."""
        if node.parent >= len(self.nodes) or (node.parent < 0 and self.nodes):
            raise ConfigError("a node's parent must be an existing node (only the first node is a root)",
                              field="parent", value=node.parent)
        if node.expected is None:
            node.expected = self.space.mean(node.particles)
        if not node.variance:
            node.variance = float(np.sum(self.space.variance(node.particles)))
        self.nodes.append(node)
        return len(self.nodes) - 1

    def branch(self, index: int) -> list[int]:
        """Node indices from the root to ``index``."""
        chain = [index]
        while self.nodes[chain[-1]].parent >= 0:
            chain.append(self.nodes[chain[-1]].parent)
        return chain[::-1]

    def expected(self) -> np.ndarray:
        """``(n, d)`` expected configurations of every node."""
        return np.array([n.expected for n in self.nodes])
