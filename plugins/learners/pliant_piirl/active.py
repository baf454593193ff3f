"""Active learning of which demonstrations to ask for: Algorithm 2 of thesis 4.3.2.

The preference graph ``G`` has the objects as nodes and an edge ``less -> more`` sensitive for every
demonstration: the object a demonstration deforms more is the less sensitive one.  ``collect(first, second)``
asks for one demonstration between two adjacent objects and returns the features it deformed; the algorithm
grows ``G`` as a chain (new objects by most adjacencies, attached where the graph is deepest) and, after each new
object, asks for the demonstrations that ENSURERANKING needs until every pair of comparable objects is ordered
by a directed path.  Choices the listing leaves open, documented:

- ties in the argmax choices are broken at random (the chapter's "random selections"), with the given generator;
- ENSURERANKING's ``return ENSURERANKING(G)`` is read as inside DIRECTLYCOMPARABLE (otherwise the listing would
  recurse forever on an incomparable pair); it is run as a loop;
- a pair is never asked twice: a demonstration that deforms both objects equally (no preference) adds no edge,
  and the pair is not asked again;
- ``depth`` is the longest directed path ending at a node; a preference that would close a cycle (an
  inconsistent demonstrator) is recorded but not added to ``G``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


@dataclass
class PreferenceGraph:
    """``nodes`` and directed ``edges`` (less sensitive, more sensitive)."""

    nodes: set[str] = field(default_factory=set)
    edges: set[tuple[str, str]] = field(default_factory=set)

    def successors(self, node: str) -> set[str]:
        return {b for a, b in self.edges if a == node}

    def reaches(self, a: str, b: str) -> bool:
        """Whether a directed path leads from ``a`` to ``b``."""
        seen, stack = set(), [a]
        while stack:
            n = stack.pop()
            if n == b:
                return True
            if n not in seen:
                seen.add(n)
                stack.extend(self.successors(n))
        return False

    def depth(self, node: str) -> int:
        """Length of the longest directed path in the graph that ends at ``node``."""
        predecessors = {a for a, b in self.edges if b == node}
        return 1 + max(self.depth(p) for p in predecessors) if predecessors else 0

    def ranking(self) -> list[str]:
        """The nodes in an order consistent with every edge (least sensitive first)."""
        return sorted(self.nodes, key=lambda n: (self.depth(n), n))


@dataclass
class ActiveLearningResult:
    """The graph, the asked pairs in order, and the preferences each demonstration showed."""

    graph: PreferenceGraph
    asked: list[tuple[str, str]]
    preferences: list[tuple[str, str] | None]


def collect_demonstrations(adjacency: dict[str, set[str]], collect: Callable[[str, str], dict[str, float]],
                           rng: np.random.Generator, limit: int | None = None) -> ActiveLearningResult:
    """Algorithm 2.  ``adjacency``: ``{object: adjacent objects}``; ``collect(o1, o2)`` returns the demonstrated
    deformation ``{object: V}``; ``limit``: most demonstrations (default: every adjacent pair)."""
    g = PreferenceGraph()
    asked: list[tuple[str, str]] = []
    preferences: list[tuple[str, str] | None] = []
    pairs = {frozenset((a, b)) for a in adjacency for b in adjacency[a]}
    limit = len(pairs) if limit is None else limit

    def degree(o: str) -> int:
        return len(adjacency.get(o, ()))

    def pick(candidates, key):
        candidates = sorted(candidates)
        best = max(key(c) for c in candidates)
        top = [c for c in candidates if key(c) == best]
        return top[int(rng.integers(len(top)))]

    def ask(o1: str, o2: str) -> None:
        asked.append((o1, o2))
        deformed = collect(o1, o2)
        g.nodes.update((o1, o2))
        v1, v2 = float(deformed.get(o1, 0.0)), float(deformed.get(o2, 0.0))
        if v1 == v2:
            preferences.append(None)
            return
        edge = (o1, o2) if v1 > v2 else (o2, o1)
        preferences.append(edge)
        if not g.reaches(edge[1], edge[0]):
            g.edges.add(edge)

    def was_asked(a: str, b: str) -> bool:
        return any({a, b} == set(p) for p in asked)

    def ensure_ranking() -> None:
        while len(asked) < limit:
            found = None
            for o1 in sorted(g.nodes):
                for o2 in sorted(g.nodes):
                    if o2 == o1 or g.depth(o2) < g.depth(o1):
                        continue
                    if not g.reaches(o1, o2) and not g.reaches(o2, o1) and o2 in adjacency.get(o1, ()) \
                            and not was_asked(o1, o2):
                        found = (o1, o2)
                        break
                if found:
                    break
            if found is None:
                return
            ask(*found)

    if not pairs:
        return ActiveLearningResult(g, asked, preferences)
    first = pick([o for o in adjacency if degree(o) > 0], degree)
    ask(first, pick(adjacency[first], degree))
    while len(asked) < limit:
        missing = [o for o in adjacency if o not in g.nodes and degree(o) > 0]
        if not missing:
            break
        anchors = [o for o in g.nodes if set(adjacency.get(o, ())) - g.nodes]
        if not anchors:                      # a component is done: start the next one as the first demonstration
            first = pick(missing, degree)
            ask(first, pick(adjacency[first], degree))
        else:
            o1 = pick(anchors, g.depth)
            ask(o1, pick(set(adjacency[o1]) - g.nodes, degree))
        ensure_ranking()
    return ActiveLearningResult(g, asked, preferences)
