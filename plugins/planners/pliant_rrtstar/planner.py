"""RRT* over any space and any cost model (Karaman & Frazzoli 2011), with the checks of thesis 4.3.4.

Each iteration samples a configuration (or, with probability ``goal_bias``, the goal or a sampled goal
configuration of a task-space target), steers the nearest node toward it by at most ``max_step``,
then **chooses the parent** among the nodes within the radius ``r(n)`` of :mod:`pliant_rrtstar.radius`
that gives the new node the cheapest valid path from the start, and **rewires** the other near nodes
through the new node when that makes their path cheaper.  The objective is additive over edges:

    cost(path) = sum_j c(q_j) d(q_{j-1}, q_j)  +  length_weight * length(path)

— the integral of the state cost along the path discretised at ``check_step``
(:meth:`PlanningProblem.path_cost`, thesis Table 3.1) plus an optional length term — so rewiring a
node shifts the cost of its whole subtree by the same amount.

**Puncture and cut detection** (thesis 4.3.4, :class:`pliant.geometry.topology.PunctureChecker`): every node
stores the voxels its path from the start has swept out of each watched object.  An extension is
checked from its parent's state; a rewire re-derives the state of the rewired node from its new
parent and then of every descendant from its own parent, and is refused if any of them punctures or
cuts an object — so every node's whole path from the start is always checked.  Every edge is swept from its
parent's configuration (``extend(..., start=parent)``), so the per-edge states are exactly the whole path's
sweep; the path returned is checked once more as a whole (:meth:`RRTStarPlanner._final_check`) and, should that
ever refuse it, the next cheapest solution is returned, or a failure status when none passes.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
from pliant.api import (
    ConfigError,
    Path,
    Planner,
    PlannerSpecs,
    PlanningProblem,
    PlanResult,
    ProgressLine,
    Status,
    Termination,
    Tree,
    option,
    warm_up,
)

from pliant_rrtstar.edges import evaluate_edges, state_costs, state_validity
from pliant_rrtstar.goal import TaskSpaceGoal
from pliant_rrtstar.radius import near_radius, rrt_star_gamma

#: an edge's verdict while a node is added: its motion not checked yet, checked and collision-free, or invalid (a
#: state of the edge or its motion)
UNCHECKED, VALID, INVALID = 0, 1, -1


@dataclass(frozen=True)
class RRTStarOptions:
    """Options of :class:`RRTStarPlanner` (distances in the space's metric; costs in the cost model's units)."""

    max_step: float = option(0.1, "largest extension, and largest near radius (space metric units)", minimum=1e-9)
    check_step: float | None = option(None, "edges are checked and their cost integrated every this distance "
                                      "(default: the scene resolution, else max_step / 10)", minimum=1e-9)
    goal_bias: float = option(0.05, "probability of sampling the goal (or a goal configuration of the target)",
                              minimum=0.0, maximum=1.0)
    rewire_factor: float = option(1.1, "gamma = this x Karaman & Frazzoli's lower bound (> 1 for asymptotic "
                                  "optimality)", minimum=1.0)
    gamma: float | None = option(None, "the radius constant gamma (metric units); default from the space's "
                                 "volume (pliant_rrtstar.radius)", minimum=1e-12)
    k_nearest: bool = option(False, "choose parents and rewire among the k = e (1 + 1/d) log n nearest nodes "
                             "(Karaman & Frazzoli's k-nearest RRT*) instead of the radius ball")
    path_bias: float = option(0.0, "after the first solution, probability of sampling near the best path (a "
                              "uniform point on it plus a Gaussian of path_bias_sigma per tangent coordinate; "
                              "Akgun & Stilman 2011's local biasing)", minimum=0.0, maximum=1.0)
    path_bias_sigma: float | None = option(None, "standard deviation of the path-bias samples (space metric "
                                           "units; default max_step)", minimum=1e-12)
    length_weight: float = option(0.0, "path cost = integral of the state cost + this x path length (cost per "
                                  "metric unit)", minimum=0.0)
    max_cost: float = option(math.inf, "no state of an edge may cost more than this", minimum=0.0)
    tip: tuple[float, ...] | None = option(None, "task-space goal: a point of a rigid robot in its body frame (m, "
                                           "3 values); needs target")
    tip_index: int | None = option(None, "task-space goal: the index of one of the robot's body points (any "
                                   "robot); needs target", minimum=0)
    target: tuple[float, ...] | None = option(None, "task-space goal: the world point the tip must reach (m, 3 "
                                              "values); replaces the goal configuration")
    target_tolerance: float = option(0.01, "task-space goal: largest tip-to-target distance (m)", minimum=0.0)
    goal_samples: int = option(20, "most goal configurations sampled for a task-space target", minimum=1)
    max_time: float | None = option(None, "deprecated: use planning.max_time (the request's wall-clock "
                                    "cap, s)", minimum=0.0)
    max_iterations: int | None = option(None, "deprecated: use planning.max_iterations (the request's "
                                       "work budget)", minimum=1)
    stop_on_first: bool = option(False, "return the first solution instead of improving it to the budget")
    puncture_check: bool | None = option(None, "refuse extensions and rewirings that puncture or cut an object "
                                         "(thesis 4.3.4); default on when the problem has a scene and a robot")
    progress: bool | None = option(None, "show a progress line (default: on a terminal)")

    def validate(self) -> None:
        """Cross-field checks: a target needs exactly one of tip / tip_index, and points have 3 values."""
        for name in ("tip", "target"):
            value = getattr(self, name)
            if value is not None and len(value) != 3:
                raise ConfigError("must have 3 values (x, y, z) in metres", field=name, value=value)
        if self.target is not None and (self.tip is None) == (self.tip_index is None):
            raise ConfigError("a target needs exactly one of tip or tip_index", field="tip",
                              value=[self.tip, self.tip_index])
        if self.target is None and (self.tip is not None or self.tip_index is not None):
            raise ConfigError("tip and tip_index need a target", field="target", value=None)


class RRTStarPlanner(Planner):
    """RRT* (Karaman & Frazzoli 2011): asymptotically optimal, anytime.

    Statistics: ``iterations``, ``nodes``, ``time``, ``time_to_first`` (s), ``cost_history``
    (``[[t, best cost], ...]``, strictly decreasing), ``rewires``, ``rewires_refused`` (by puncture
    or cut), ``punctures_refused`` (extensions and rewirings refused by puncture or cut),
    ``invalid_edges`` (found invalid: motions are checked lazily), ``gamma``, ``radius`` (final),
    ``goal_states`` (sampled for a task-space target), ``solutions`` (nodes in the goal), ``puncture_check``,
    ``final_check_refused`` (solutions whose whole path failed the final puncture check; 0 when the per-edge checks
    and the whole path agree), ``interrupted``.
    """

    SPECS = PlannerSpecs(anytime=True, work_unit="samples (one tree extension attempt each)")

    Options = RRTStarOptions
    name = "rrtstar"
    example_scene = "triple-wall"
    example_components = {"cost": "voxel"}
    example_budget = {"max_iterations": 300}      # conformance: quick and deterministic (solves triple-wall)

    def bind(self, context) -> None:
        """Attach to the pipeline and warm up (:func:`pliant.planning.warmup.warm_up`: one-off loading when the
        pipeline is built, not inside ``max_time``)."""
        super().bind(context)
        warm_up(context)

    def goal_region(self, problem: PlanningProblem):
        """The task-space target's goal test (the tip within ``target_tolerance``) when ``target`` is set."""
        return self.goal.contains if getattr(self, "goal", None) is not None else None

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        o = self.options
        t0 = time.perf_counter()
        self.goal = None
        if o.target is not None:
            self.goal = TaskSpaceGoal(problem.robot, problem.space, o.target, o.target_tolerance, tip=o.tip,
                                      tip_index=o.tip_index)
            problem = dataclasses.replace(problem, goal_region=self.goal.contains)
        self.problem = problem
        space = problem.space
        start, goal, invalid = problem.checked_endpoints()
        if invalid is not None:
            return PlanResult.invalid_endpoint(invalid, self.name, self._option_dict())
        c_start = float(state_costs(problem, start[None])[0])
        if not state_validity(problem, start[None], np.array([c_start]), o.max_cost)[0]:
            return PlanResult(Status.INVALID_START, planner=self.name, options=self._option_dict(),
                              message="the start configuration costs more than max_cost")
        if self.goal is not None:
            self.goal.valid = lambda q: state_validity(problem, q, state_costs(problem, q), o.max_cost)
        self.check_step = o.check_step or (problem.scene.resolution if problem.scene is not None else o.max_step / 10)
        self.gamma = o.gamma or rrt_star_gamma(space, o.rewire_factor)
        self.punctures = self._puncture_checker(problem)
        self.tree = Tree(space)
        self.tree.add(start, -1, c_start, 0.0)
        self.topology = [self.punctures.initial_state()] if self.punctures is not None else None
        #: per node, the voxels its incoming edge sweeps (PunctureChecker.sweep): rewiring re-derives the states
        #: below a node from them without sweeping those edges again
        self.swept = [[np.zeros(0, dtype=np.int64) for _ in self.punctures.ids]] if self.punctures is not None \
            else None
        self.stats = {"rewires": 0, "rewires_refused": 0, "punctures_refused": 0, "invalid_edges": 0}
        self.goal_nodes: list[int] = []
        self.goal_pool: list[np.ndarray] = []
        self.best_node = -1
        self._best_path = None
        history: list[list[float]] = []
        best, best_node, first, radius = math.inf, -1, None, o.max_step
        # the request's budget bounds the whole call: the set-up above (puncture checker, goal sampler) comes off
        # its max_time; max_iterations counts samples
        termination = self.stop_condition(problem, termination, t0, stop_on_first=o.stop_on_first)
        progress = ProgressLine(self.name, enabled=o.progress)
        with termination.watch():
            iteration = 0
            while not termination.should_stop(iteration, best, solved=best_node >= 0):
                iteration += 1
                radius = near_radius(len(self.tree) + 1, space.tangent_dim, self.gamma, o.max_step)
                self.best_node = best_node
                node = self._iterate(rng, goal, radius)
                if node >= 0 and problem.in_goal(self.tree.configurations[node][None])[0]:
                    self.goal_nodes.append(node)
                if self.goal_nodes:
                    costs = self.tree.path_costs[self.goal_nodes]
                    i = int(np.argmin(costs))
                    if costs[i] < best:
                        if first is None:
                            first = termination.elapsed
                        best, best_node = float(costs[i]), self.goal_nodes[i]
                        history.append([termination.elapsed, best])
                progress.update(iterations=iteration, nodes=len(self.tree), best=best, r=radius)
                termination.publish(nodes=len(self.tree))
        progress.close()
        stats = dict(self.stats, iterations=iteration, nodes=len(self.tree), time=time.perf_counter() - t0,
                     time_to_first=first, cost_history=history, gamma=self.gamma, radius=radius,
                     goal_states=len(self.goal_pool), solutions=len(self.goal_nodes),
                     puncture_check=self.punctures is not None, interrupted=termination.interrupted)
        best_node, best, refused = self._final_check(best_node, best)
        stats["final_check_refused"] = refused
        if best_node < 0 and refused:
            return PlanResult(Status.TIMEOUT, planner=self.name, statistics=stats, options=self._option_dict(),
                              message=f"no puncture-free solution within the budget: the final check of the whole "
                                      f"path refused all {refused} solutions ({self._refused_reason})")
        if best_node < 0:
            target = self.goal.target if self.goal is not None else None
            gap = float(np.min(np.linalg.norm(self.goal.tip(self.tree.configurations) - target, axis=-1))) \
                if self.goal is not None else float(np.min(space.distance(self.tree.configurations, goal)))
            return PlanResult(Status.TIMEOUT, planner=self.name, statistics=stats, options=self._option_dict(),
                              message=f"no solution within the budget (closest node {gap:.4g} from the goal)")
        return PlanResult(Status.SOLVED, path=Path(self.tree.path_to(best_node), space_kind=space.kind), cost=best,
                          planner=self.name, statistics=stats, options=self._option_dict())

    # --- one iteration -----------------------------------------------------------------------------

    def _sample(self, rng: np.random.Generator, goal: np.ndarray) -> np.ndarray:
        o = self.options
        if self.best_node >= 0 and o.path_bias > 0 and rng.random() < o.path_bias:
            return self._sample_near_best(rng)
        if rng.random() >= o.goal_bias:
            return self.problem.space.sample(rng, 1)[0]
        if self.goal is None:
            return goal
        if len(self.goal_pool) < o.goal_samples and (not self.goal_pool or rng.random() < 0.5):
            q = self.goal.sample(rng)
            if q is not None:
                self.goal_pool.append(q)
        if not self.goal_pool:
            return self.problem.space.sample(rng, 1)[0]
        return self.goal_pool[int(rng.integers(len(self.goal_pool)))]

    def _sample_near_best(self, rng: np.random.Generator) -> np.ndarray:
        """A uniform point along the best path (by arc length) moved by a Gaussian in the tangent space."""
        space = self.problem.space
        # the best path changes only when the best node or its cost does (a rewire lowers the cost)
        key = (self.best_node, float(self.tree.path_costs[self.best_node]))
        if self._best_path is None or self._best_path[0] != key:
            path = self.tree.path_to(self.best_node)
            ends = np.cumsum(np.atleast_1d(space.distance(path[:-1], path[1:]))) if len(path) > 1 else np.zeros(0)
            self._best_path = (key, path, ends)
        _, path, ends = self._best_path
        sigma = self.options.path_bias_sigma or self.options.max_step
        if len(path) == 1:
            base = path[0]
        else:
            at = rng.random() * float(ends[-1])
            k = min(int(np.searchsorted(ends, at)), len(ends) - 1)
            start = float(ends[k - 1]) if k > 0 else 0.0
            length = float(ends[k]) - start
            base = space.interpolate(path[k], path[k + 1], (at - start) / length if length > 0 else 0.0)
        moved = space.retract(np.asarray(base)[None], rng.normal(0.0, sigma, (1, space.tangent_dim)))
        return space.enforce_bounds(moved)[0]

    def _iterate(self, rng: np.random.Generator, goal: np.ndarray, radius: float) -> int:
        """Sample, steer, choose the parent, add the node and rewire; the new node's index or -1."""
        o, tree, problem = self.options, self.tree, self.problem
        space = problem.space
        target = self._sample(rng, goal)
        to_target = tree.distances(target)
        nearest = int(np.argmin(to_target))
        q_new = space.steer(tree.configurations[nearest], target, o.max_step)
        c_new = state_costs(problem, q_new[None])
        if not state_validity(problem, q_new[None], c_new, o.max_cost)[0]:
            return -1
        # the near nodes: by the triangle inequality only nodes with |d(x, target) - d(q_new, target)| <= r can be
        # within r of q_new, so the exact distance is computed for those alone
        if o.k_nearest:
            k = min(len(tree), math.ceil(math.e * (1.0 + 1.0 / space.tangent_dim) * math.log(len(tree) + 1)))
            d_all = tree.distances(q_new)
            near = np.argpartition(d_all, k - 1)[:k] if k < len(tree) else np.arange(len(tree))
            near = near[np.argsort(d_all[near], kind="stable")]
        else:
            candidates = np.nonzero(np.abs(to_target - float(space.distance(q_new, target))) <= radius)[0]
            d_new = np.atleast_1d(np.asarray(space.distance(tree.configurations[candidates], q_new),
                                             dtype=np.float64))
            inside = d_new <= radius
            near = candidates[inside][np.argsort(d_new[inside], kind="stable")]
        if nearest not in near:
            near = np.append(near, nearest)
        # the motions are checked lazily: only those of the candidates tried as the parent, cheapest first, and
        # later those rewiring needs -- the same parent and rewires as checking every motion first
        edges = evaluate_edges(problem, tree.configurations[near], q_new, self.check_step, o.length_weight,
                               o.max_cost, check_motions=False)
        verdicts = np.where(edges.valid, UNCHECKED, INVALID).astype(np.int8)
        totals = tree.path_costs[near] + edges.cost
        order = np.argsort(totals, kind="stable")
        order = order[np.isfinite(totals[order])]
        parent, topology = -1, None
        for rank, i in enumerate(order):
            if verdicts[i] == UNCHECKED:       # this candidate's motion, with as many after it as were tried before
                batch = order[rank:rank + max(1, rank)]
                batch = batch[verdicts[batch] == UNCHECKED]
                verdicts[batch] = np.where(problem.motions_valid(tree.configurations[near[batch]], q_new),
                                           VALID, INVALID)
            if verdicts[i] == INVALID:
                continue
            if self.punctures is not None:
                swept = self.punctures.sweep(edges.of(i), start=tree.configurations[near[i]])
                topology, ok, _ = self.punctures.extend_swept(self.topology[near[i]], swept)
                if not ok:
                    self.stats["punctures_refused"] += 1
                    continue
            parent = int(near[i])
            break
        if parent < 0:
            self.stats["invalid_edges"] += int(np.count_nonzero(verdicts == INVALID))
            return -1
        node = tree.add(q_new, parent, float(c_new[0]), float(totals[i]))
        if self.topology is not None:
            self.topology.append(topology)
            self.swept.append(swept)
        others = near != parent
        rest = verdicts[others]                 # a copy: _rewire adds the verdicts it finds
        self._rewire(node, near[others], rest)
        self.stats["invalid_edges"] += int(np.count_nonzero(rest == INVALID))
        return node

    # --- rewiring ----------------------------------------------------------------------------------

    def _rewire(self, node: int, near: np.ndarray, verdicts: np.ndarray) -> None:
        """Re-parent each of ``near`` under ``node`` when that makes its path cheaper (and valid, and no puncture).

        ``verdicts`` (int8, updated in place): each near node's edge to ``node`` as the parent choice left it --
        ``INVALID`` (a state or the motion), ``VALID`` (the motion checked) or ``UNCHECKED``.  A motion is valid
        both ways or neither, so the rewiring edge ``node -> near`` takes that edge's motion verdict; the unchecked
        ones are checked (that way round, as the parent choice would have) for the near nodes the new edge would
        make cheaper, and only for those: a node's cost only drops while rewiring, so no other can come to need
        one."""
        if len(near) == 0:
            return
        o, tree = self.options, self.tree
        q_node = tree.configurations[node]
        edges = evaluate_edges(self.problem, q_node, tree.configurations[near], self.check_step, o.length_weight,
                               o.max_cost, check_motions=False)
        # the near nodes on the new node's own branch: rewiring one would make a cycle (rewiring others under the new
        # node leaves its branch as it is, so this holds for the whole loop)
        ancestor = np.isin(near, tree.branch(node))
        valid = edges.valid & (verdicts != INVALID)
        need = valid & (verdicts == UNCHECKED) & (tree.path_costs[node] + edges.cost < tree.path_costs[near])
        need &= ~ancestor
        if need.any():
            verdicts[need] = np.where(self.problem.motions_valid(tree.configurations[near[need]], q_node),
                                      VALID, INVALID)
            valid &= verdicts != INVALID
        for i in np.argsort(np.where(valid, edges.cost, np.inf), kind="stable"):
            if not valid[i]:
                continue
            x = int(near[i])
            new_cost = float(tree.path_costs[node] + edges.cost[i])
            if not new_cost < tree.path_costs[x] or ancestor[i]:      # costs may have dropped by an earlier rewire
                continue
            if self.punctures is not None and not self._rewire_topology(node, x, edges.of(i)):
                self.stats["rewires_refused"] += 1
                self.stats["punctures_refused"] += 1
                continue
            tree.rewire(x, node, new_cost)
            self.stats["rewires"] += 1

    def _rewire_topology(self, node: int, x: int, edge: np.ndarray) -> bool:
        """Re-derive the puncture state of ``x`` under ``node`` and of its descendants; commit if all pass.

        A descendant's state is its parent's extended by its own edge's sweep (kept per node), so the subtree is
        walked level by level and a branch whose state comes out unchanged is not followed further: everything
        below it is unchanged too."""
        tree, checker = self.tree, self.punctures
        swept = checker.sweep(edge, start=tree.configurations[node])
        state, ok, _ = checker.extend_swept(self.topology[node], swept)
        if not ok:
            return False
        new = {x: state}
        parents = tree.parents
        frontier = [x] if not _same(state, self.topology[x]) else []
        while frontier:
            changed = []
            for d in np.nonzero(np.isin(parents, frontier))[0].tolist():
                new[d], ok, _ = checker.extend_swept(new[int(parents[d])], self.swept[d])
                if not ok:
                    return False
                if not _same(new[d], self.topology[d]):
                    changed.append(d)
            frontier = changed
        for k, s in new.items():
            self.topology[k] = s
        self.swept[x] = swept
        return True

    def _final_check(self, best_node: int, best: float) -> tuple[int, float, int]:
        """The cheapest solution whose whole path passes the puncture check (thesis 4.3.4), ``(node, cost,
        solutions refused)``; ``node`` is -1 when none does.

        The path returned is checked once more as a whole, densified at ``check_step`` exactly as its edges were
        checked, by the same :meth:`PunctureChecker.check` -- a guard that the per-edge states (built from each
        parent's, re-derived on every rewire) and the path agree.  With the edges swept from their parents they do,
        so ``final_check_refused`` stays 0; should it not, the next cheapest solution is tried."""
        self._refused_reason = ""
        if best_node < 0 or self.punctures is None:
            return best_node, best, 0
        nodes = np.unique(np.asarray(self.goal_nodes, dtype=np.int64))
        refused = 0
        for node in nodes[np.argsort(self.tree.path_costs[nodes], kind="stable")]:
            dense = self.problem.densify(self.tree.path_to(int(node)), self.check_step)
            ok, reason = self.punctures.check(dense)
            if ok:
                return int(node), float(self.tree.path_costs[node]), refused
            refused += 1
            self._refused_reason = self._refused_reason or reason
        return -1, math.inf, refused

    # --- helpers -----------------------------------------------------------------------------------

    def _option_dict(self) -> dict:
        return dict(vars(self.options))

    def _puncture_checker(self, problem: PlanningProblem):
        wanted = self.options.puncture_check
        available = problem.scene is not None and problem.robot is not None
        if wanted and not available:
            raise ConfigError("puncture_check needs a scene and a robot", field="planner.puncture_check", value=True)
        if not (wanted or (wanted is None and available)):
            return None
        from pliant.api import PunctureChecker, VoxelGrid, arc_margin

        checker = PunctureChecker(VoxelGrid.from_scene(problem.scene), problem.robot.body_points,
                                  arc_margin=arc_margin(problem.scene, problem.space))
        return checker if checker.ids else None             # nothing the robot may enter: nothing to check


def _same(a, b) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(a.removed, b.removed))
