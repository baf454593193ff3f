"""T-RRT and GradienT-RRT over any space and any cost model (thesis 3.2.4; Jaillet et al. 2010; Berenson et al. 2011).

Both grow an RRT whose extensions pass T-RRT's transition test (:mod:`pliant_trrt.transition`) and a
refinement control that keeps the tree exploring: an extension toward a sample already within one
step of the tree only refines it, and refinements may not exceed ``refinement_ratio`` of the nodes.
Edges are checked every ``check_step`` for validity (bounds, finite cost, the problem's extra checks
and, optionally, puncture and cut of the voxel model's objects, thesis 4.3.4).  GradienT-RRT adjusts
an extension that the transition test refused along the negative cost gradient (thesis eq. 3.2) and
keeps it when that made it cheaper and the adjusted node passes the test.

The objective reported is the path cost of :meth:`PlanningProblem.path_cost`: the integral of the
state cost along the path (thesis Table 3.1); as in the thesis, an edge's cost for the transition
test is the change of state cost between a node and its parent.
"""

from __future__ import annotations

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
    perturb,
    shortcut,
    warm_up,
)

from pliant_trrt.transition import TransitionTest


@dataclass(frozen=True)
class TRRTOptions:
    """Options of :class:`TRRTPlanner` (distances in the space's metric; costs in the cost model's units)."""

    max_step: float = option(0.1, "largest extension (space metric units)", minimum=1e-9)
    check_step: float | None = option(None, "edges are checked every this distance (default: the scene "
                                      "resolution, else max_step / 10)", minimum=1e-9)
    goal_bias: float = option(0.05, "probability of sampling the goal", minimum=0.0, maximum=1.0)
    n_fail_max: int = option(10, "refused uphill transitions in a row before the temperature rises (nFailMax)",
                             minimum=0)
    initial_temperature: float = option(1e-6, "initial temperature T", minimum=1e-300)
    temperature_factor: float = option(2.0, "the temperature is divided by this on an uphill acceptance and "
                                       "multiplied by it after n_fail_max refusals", minimum=1.0 + 1e-9)
    cost_scale: float | None = option(None, "K, the cost normalisation (cost per unit distance); default the "
                                      "mean state cost of start and goal, else 1", minimum=1e-300)
    cost_range_cooling: bool = option(False, "after an uphill acceptance, cool by temperature_factor ** (rise / "
                                      "(0.1 x cost range)) (Jaillet et al., IEEE T-RO 2010) instead of by "
                                      "temperature_factor")
    max_cost: float = option(math.inf, "no state of an edge may cost more than this", minimum=0.0)
    refinement_ratio: float = option(0.1, "largest share of refinement nodes (the extension's sample was "
                                     "within max_step of the tree)", minimum=0.0, maximum=1.0)
    max_time: float | None = option(None, "deprecated: use planning.max_time (the request's wall-clock "
                                    "cap, s)", minimum=0.0)
    max_iterations: int | None = option(None, "deprecated: use planning.max_iterations (the request's "
                                       "work budget)", minimum=1)
    stop_on_first: bool = option(True, "return the first solution (else run to the budget and return the "
                                 "cheapest)")
    anytime: str = option("grow", "without stop_on_first: keep growing the same tree (grow) or start a new tree "
                          "after each solution (restart)", choices=("grow", "restart"))
    puncture_check: bool = option(False, "refuse edges that puncture or cut an object of the voxel model "
                                  "(thesis 4.3.4; needs a scene)")
    shortcut_iterations: int = option(0, "cost-aware shortcutting of the solution (pliant.planning.shortcut): "
                                      "attempts; 0 returns T-RRT's own path", minimum=0)
    perturb_iterations: int = option(0, "after shortcutting, random local perturbation of the solution's "
                                     "waypoints (pliant.planning.shortcut.perturb): attempts; 0 for none", minimum=0)
    perturb_spacing: float | None = option(None, "waypoint spacing of the perturbation (space metric units; "
                                           "default 2.5 check steps)", minimum=1e-9)
    perturb_sigma: float | None = option(None, "standard deviation of a perturbation per tangent coordinate "
                                         "(default the check step)", minimum=1e-9)
    progress: bool | None = option(None, "show a progress line (default: on a terminal)")


@dataclass(frozen=True)
class GradientTRRTOptions(TRRTOptions):
    """Options of :class:`GradientTRRTPlanner`: T-RRT's plus the gradient adjustment."""

    gradient_step: float | None = option(None, "length of one step along the negative gradient (space metric "
                                         "units); default the check step", minimum=1e-9)
    gradient_iterations: int = option(10, "most gradient steps per refused extension", minimum=1)


class TRRTPlanner(Planner):
    """T-RRT: an RRT whose uphill extensions pass a temperature-controlled transition test.

    Statistics: ``iterations``, ``nodes``, ``time``, ``time_to_first`` (s), ``cost_history``
    (``[[t, best cost], ...]``), ``temperature`` (final), ``uphill_accepted``, ``refused``,
    ``refinements_skipped``, ``invalid_edges``, ``punctures``, ``gradient_kept`` (GradienT-RRT),
    ``solutions``, ``final_check_refused`` (solutions whose whole path failed the final puncture check),
    ``interrupted``.
    """

    SPECS = PlannerSpecs(anytime=True, work_unit="samples (one extension attempt each)")

    Options = TRRTOptions
    name = "trrt"
    example_scene = "triple-wall"
    example_components = {"cost": "voxel"}
    example_budget = {"max_iterations": 20000}    # conformance: deterministic budget

    # --- the gradient hook (GradienT-RRT overrides) --------------------------------------------------

    def adjust(self, problem: PlanningProblem, q: np.ndarray, cost: float) -> tuple[np.ndarray, float] | None:
        """A cheaper replacement for a refused extension ``q`` (T-RRT: none)."""
        return None

    # --- planning --------------------------------------------------------------------------------

    def bind(self, context) -> None:
        """Attach to the pipeline and warm up (:func:`pliant.planning.warmup.warm_up`: one-off loading when the
        pipeline is built, not inside ``max_time``)."""
        super().bind(context)
        warm_up(context)

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        o = self.options
        t0 = time.perf_counter()
        space = problem.space
        start, goal, invalid = problem.checked_endpoints()
        if invalid is not None:
            return PlanResult.invalid_endpoint(invalid, self.name, self._option_dict())
        self._check_step = o.check_step or (problem.scene.resolution if problem.scene is not None else o.max_step / 10)
        self._punctures = self._puncture_checker(problem) if o.puncture_check else None
        state_cost = self._state_cost(problem)
        c_start = float(state_cost(start[None])[0])
        c_goal = float(state_cost(goal[None])[0]) if problem.goal_region is None else c_start
        k = o.cost_scale or (0.5 * (c_start + c_goal) if c_start + c_goal > 0 else 1.0)
        self._space = space
        self._new_tree(start, c_start, k)
        stats = {"iterations": 0, "refinements_skipped": 0, "invalid_edges": 0, "punctures": 0, "gradient_kept": 0,
                 "trees": 1, "shortcut_time": 0.0, "final_check_refused": 0}
        history: list[list[float]] = []
        best, best_path, best_tree_cost, first, solutions = math.inf, None, math.nan, None, 0
        n_expand = n_refine = 0
        # the request's budget bounds the whole call: the set-up above comes off its max_time, and the
        # post-processing of a solution (shortcut, perturbation) stops when that cap has expired, keeping the path so
        # far; max_iterations counts samples
        termination = self.stop_condition(problem, termination, t0, stop_on_first=o.stop_on_first)
        self._expired = termination.expired
        progress = ProgressLine(self.name, enabled=o.progress)
        with termination.watch():
            iteration = 0
            while not termination.should_stop(iteration, best, solved=solutions > 0):
                iteration += 1
                target = goal if (problem.goal_region is None and rng.random() < o.goal_bias) else \
                    space.sample(rng, 1)[0]
                near = self.tree.nearest(target)
                q_near = self.tree.configurations[near]
                refinement = float(space.distance(q_near, target)) <= o.max_step
                if refinement and n_refine > o.refinement_ratio * (n_expand + n_refine):
                    stats["refinements_skipped"] += 1
                    continue
                node = self._extend(problem, near, space.steer(q_near, target, o.max_step), stats, rng)
                if node < 0:
                    continue
                n_refine += refinement
                n_expand += not refinement
                reached = node if problem.in_goal(self.tree.configurations[node][None])[0] else -1
                if reached < 0 and problem.goal_region is None and \
                        float(space.distance(self.tree.configurations[node], goal)) <= o.max_step:
                    reached = self._extend(problem, node, goal, stats, rng)
                if reached >= 0:
                    solutions += 1
                    if first is None:
                        first = termination.elapsed
                    tree_cost = float(self.tree.path_costs[reached])
                    path, cost = self._finish(problem, self.tree.path_to(reached), tree_cost, rng, stats)
                    if cost < best:
                        best, best_path, best_tree_cost = cost, path, tree_cost
                        history.append([termination.elapsed, cost])
                    if o.anytime == "restart" and not o.stop_on_first:
                        self._new_tree(start, c_start, k)
                        n_expand = n_refine = 0
                        stats["trees"] += 1
                progress.update(iterations=iteration, nodes=len(self.tree), best=best, T=self.test.temperature)
                termination.publish(nodes=len(self.tree))
            stats["iterations"] = iteration
        progress.close()
        stats.update(nodes=len(self.tree), time=time.perf_counter() - t0, time_to_first=first,
                     cost_history=history, temperature=self.test.temperature, k=k,
                     uphill_accepted=self.test.accepted_uphill, refused=self.test.refused,
                     solutions=solutions, interrupted=termination.interrupted, tree_cost=best_tree_cost)
        if best_path is None and stats["final_check_refused"]:
            return PlanResult(Status.TIMEOUT, planner=self.name, statistics=stats, options=self._option_dict(),
                              message=f"no puncture-free solution within the budget: the final check of the whole "
                                      f"path refused all {stats['final_check_refused']} solutions")
        if best_path is None:
            gap = float(np.min(space.distance(self.tree.configurations, goal)))
            return PlanResult(Status.TIMEOUT, planner=self.name, statistics=stats, options=self._option_dict(),
                              message=f"no solution within the budget (closest node {gap:.4g} from the goal)")
        return PlanResult(Status.SOLVED, path=Path(best_path, space_kind=space.kind), cost=best, planner=self.name,
                          statistics=stats, options=self._option_dict())

    def _new_tree(self, start: np.ndarray, c_start: float, k: float) -> None:
        """A fresh tree rooted at the start, with a fresh temperature."""
        o = self.options
        self.test = TransitionTest(o.initial_temperature, k, o.temperature_factor, o.n_fail_max, o.max_cost,
                                   o.cost_range_cooling)
        self.tree = Tree(self._space)
        self.tree.add(start, -1, c_start, 0.0)
        self._topology = [self._punctures.initial_state()] if self._punctures is not None else None

    def _finish(self, problem: PlanningProblem, path: np.ndarray, tree_cost: float, rng: np.random.Generator,
                stats: dict) -> tuple[np.ndarray, float]:
        """A solution as returned: the tree's path, shortcut when ``shortcut_iterations`` asks; and its cost.

        With the puncture check on, the path returned is checked once more as a whole after any post-processing
        (:meth:`_whole_path_ok`); a shortcut path that fails falls back to the tree's path, and a tree path that
        fails is no solution (cost ``inf``, counted in ``final_check_refused``)."""
        o = self.options
        if not self._whole_path_ok(problem, path):
            stats["final_check_refused"] += 1
            return path, math.inf
        if not (o.shortcut_iterations or o.perturb_iterations):
            return path, tree_cost
        tree_path = path
        t = time.perf_counter()
        check = None
        if self._punctures is not None:
            punctures = self._punctures
            check = lambda dense: punctures.check(dense)[0]  # noqa: E731 - the whole path from the start
        cost = tree_cost
        if o.shortcut_iterations:
            path, cost = shortcut(problem, path, rng, step=self._check_step, iterations=o.shortcut_iterations,
                                  check=check, stop=self._expired)
        if o.perturb_iterations:
            path, cost = perturb(problem, path, rng, step=self._check_step,
                                 spacing=o.perturb_spacing or 2.5 * self._check_step,
                                 sigma=o.perturb_sigma or self._check_step, iterations=o.perturb_iterations,
                                 check=check, stop=self._expired)
        stats["shortcut_time"] += time.perf_counter() - t
        if not self._whole_path_ok(problem, path):
            stats["final_check_refused"] += 1
            return tree_path, tree_cost
        return path, cost

    def _whole_path_ok(self, problem: PlanningProblem, path: np.ndarray) -> bool:
        """The final puncture check (thesis 4.3.4): the whole path, densified at the check step as its edges were
        checked, through the same :meth:`PunctureChecker.check`; true without the puncture check."""
        if self._punctures is None:
            return True
        dense = problem.densify(path, self._check_step)
        return bool(self._punctures.check(dense)[0])

    def _option_dict(self) -> dict:
        return dict(vars(self.options))

    @staticmethod
    def _state_cost(problem: PlanningProblem):
        if problem.cost is None:
            return lambda q: np.zeros(len(q))
        return problem.cost.cost

    def _puncture_checker(self, problem: PlanningProblem):
        if problem.scene is None or problem.robot is None:
            raise ConfigError("puncture_check needs a scene and a robot", field="planner.puncture_check", value=True)
        from pliant.api import PunctureChecker, VoxelGrid, arc_margin

        return PunctureChecker(VoxelGrid.from_scene(problem.scene), problem.robot.body_points,
                               arc_margin=arc_margin(problem.scene, problem.space))

    def _edge(self, problem: PlanningProblem, parent: int, q_new: np.ndarray, stats: dict):
        """Check the edge parent -> q_new: ``(state costs of its states after the parent, steps, topology)`` or
        ``None`` when a state is invalid or the motion punctures an object."""
        space = problem.space
        edge = space.discretize(self.tree.configurations[parent], q_new, self._check_step)[1:]
        # the states (cost, validity) at the check step; the motion itself at voxel resolution (core checker)
        if not (problem.is_valid(edge, collisions=False).all()
                and problem.motion_is_valid(self.tree.configurations[parent], q_new)):
            stats["invalid_edges"] += 1
            return None
        costs = self._state_cost(problem)(edge)
        if not np.all(costs <= self.options.max_cost):          # NaN (infeasible) fails too
            stats["invalid_edges"] += 1
            return None
        topology = None
        if self._punctures is not None:
            topology, ok, _ = self._punctures.extend(self._topology[parent], edge,
                                                     start=self.tree.configurations[parent])
            if not ok:
                stats["punctures"] += 1
                return None
        previous = np.vstack([self.tree.configurations[parent][None], edge[:-1]])
        return costs, np.asarray(space.distance(previous, edge), dtype=np.float64), topology

    def _extend(self, problem: PlanningProblem, parent: int, q_new: np.ndarray, stats: dict,
                rng: np.random.Generator) -> int:
        """Add ``q_new`` under ``parent`` if its edge is valid and passes the transition test (or, for
        GradienT-RRT, an adjusted version does); the new node's index, else -1."""
        checked = self._edge(problem, parent, q_new, stats)
        if checked is None:
            return -1
        costs, steps, topology = checked
        c_parent = float(self.tree.state_costs[parent])
        distance = float(np.sum(steps))
        if not self.test(c_parent, float(costs[-1]), distance, rng):
            adjusted = self.adjust(problem, q_new, float(costs[-1]))
            if adjusted is None:
                return -1
            q_new = adjusted[0]
            checked = self._edge(problem, parent, q_new, stats)
            if checked is None:
                return -1
            costs, steps, topology = checked
            if not self.test(c_parent, float(costs[-1]), float(np.sum(steps)), rng):
                return -1
            stats["gradient_kept"] += 1
        node = self.tree.add(q_new, parent, float(costs[-1]),
                             float(self.tree.path_costs[parent] + np.sum(costs * steps)))
        if self._topology is not None:
            self._topology.append(topology)
        return node


class GradientTRRTPlanner(TRRTPlanner):
    """GradienT-RRT: T-RRT whose refused extensions descend the cost gradient (thesis eq. 3.2).

    Needs a cost model with a gradient (``has_gradient``), e.g. the voxel cost.
    """

    SPECS = PlannerSpecs(needs_cost=True, needs_gradient=True, anytime=True,
                         work_unit="samples (one extension attempt each)")

    Options = GradientTRRTOptions
    name = "gradient-trrt"

    def plan(self, problem, rng, termination=None):
        if problem.cost is None or not getattr(problem.cost, "has_gradient", False):
            raise ConfigError("GradienT-RRT needs a cost model with a gradient", field="cost",
                              value=type(problem.cost).__name__)
        return super().plan(problem, rng, termination)

    def adjust(self, problem, q, cost):
        """Descend the cost gradient from ``q`` by fixed steps while the cost does not rise; the cheapest point.

        The voxel cost is piecewise constant at the voxel scale, so a step that leaves it unchanged does
        not end the descent; a rise, an infeasible state or a vanishing gradient does.
        """
        o = self.options
        step = o.gradient_step or self._check_step
        space = problem.space
        here, here_c = q, cost
        best_q, best_c = q, cost
        for _ in range(o.gradient_iterations):
            g = problem.cost.gradient(here[None])[0]
            norm = float(np.linalg.norm(g))
            if not np.isfinite(norm) or norm == 0.0:
                break
            candidate = space.enforce_bounds(space.retract(here, -step * g / norm))
            c = float(problem.cost.cost(candidate[None])[0])
            if not c <= here_c:
                break
            here, here_c = candidate, c
            if c < best_c:
                best_q, best_c = candidate, c
        return (best_q, best_c) if best_c < cost else None
