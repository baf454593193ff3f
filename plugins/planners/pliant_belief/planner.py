"""The global planner of thesis 5.3.1: an anytime RRT over beliefs, and its baselines (5.4.1).

Until the time limit it samples a target (the goal with probability ``goal_bias``), picks the node of
least PROXIMITY (eq. 5.1)

    dist(expect(b_i), q) * [(1 - P(start -> n_i)) alpha_P + (1 - alpha_P)] * [erf(|var(b_i)|_1) alpha_V + (1 - alpha_V)]

and extends it with the local planner (:mod:`pliant_belief.local`), RRT-Connect style (repeated
EXTENDs toward the target, stopped by a split) until the first solution, then one EXTEND per
iteration.  A node is a solution when ``P(start -> n) * goal fraction >= P_goal``; its branch, up to
the nearest split (or the root), then leaves nearest-neighbour consideration so that later solutions
differ.  Every solution is kept; the partial policy (:mod:`pliant_belief.policy`) is built from all.

Modes (the baselines of thesis 5.4.1, as options of the same planner):

- ``belief``: the planner above.
- ``contact``: Contact RRT — one particle, the simulator's contact and compliance (configure the
  planning simulator without noise), no reversibility estimate.
- ``simple``: Simple RRT — no simulator: straight edges checked every voxel, any contact with the
  scene's static geometry invalid; one particle, probabilities 1; several solutions.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from pliant.api import (
    BudgetExpired,
    ConfigError,
    Path,
    Planner,
    PlannerSpecs,
    PlanningProblem,
    PlanResult,
    ProgressLine,
    Status,
    Termination,
    VoxelGrid,
    option,
    quat_from_axis_angle,
    quat_multiply,
    warm_up,
    wrap_angle,
)
from scipy.special import erf

from pliant_belief.belief import BeliefNode, BeliefTree
from pliant_belief.local import LocalPlannerSettings, extend, goal_fraction
from pliant_belief.policy import PartialPolicy  # importing registers the kind for Policy.from_dict

MODES = ("belief", "contact", "simple")


@dataclass(frozen=True)
class BeliefPlannerOptions:
    """Options of :class:`BeliefPlanner` (distances in the space's metric, times in seconds)."""

    mode: str = option("belief", "belief (thesis 5.3), contact (Contact RRT) or simple (Simple RRT)", choices=MODES)
    particles: int = option(24, "N_particles simulated per action", minimum=1)
    p_goal: float = option(0.5, "P_goal: least probability of reaching the goal for a solution", minimum=0.0,
                           maximum=1.0)
    attempts: int = option(50, "N_attempt: tries (with reversing) counted in the effective probability", minimum=1)
    importance: float = option(500.0, "A_importance of eq. 5.2-5.3: weight of an executed outcome against one "
                               "simulated particle when the policy adapts", minimum=0.0)
    goal_bias: float = option(0.1, "probability of targeting the goal", minimum=0.0, maximum=1.0)
    rotation_spread: float | None = option(None, "sample target orientations within this angle (rad) of the "
                                           "goal's (SE(2), SE(3) robots; not in the thesis, which samples the "
                                           "whole rotation group: the default)", minimum=0.0)
    alpha_p: float = option(0.75, "alpha_P of eq. 5.1: weight of the path probability", minimum=0.0, maximum=1.0)
    alpha_v: float = option(0.75, "alpha_V of eq. 5.1: weight of the belief's variance", minimum=0.0, maximum=1.0)
    max_step: float = option(2.0, "largest distance of one action's target from the node's expected "
                             "configuration", minimum=1e-9)
    clustering: str = option("wcr", "particle clustering of 5.3.3: pc, wcr, ac or distance",
                             choices=("pc", "wcr", "ac", "distance"))
    wcr_threshold: float = option(0.75, "D_WCR threshold of the weakly-convex-region clustering", minimum=0.0,
                                  maximum=1.0)
    distance_threshold: float | None = option(None, "second clustering pass: complete-link threshold (space "
                                              "metric); default the clustering module's", minimum=0.0)
    speed: float = option(1.0, "translation (or joint) speed limit of the actuators (m/s, rad/s): an action is "
                          "simulated as long as its slowest coordinate needs, plus settle", minimum=1e-9)
    angular_speed: float = option(0.125, "rotation speed limit of SE(2)/SE(3) actuators (rad/s)", minimum=1e-9)
    settle: float = option(2.0, "seconds added to every action's simulation", minimum=0.0)
    min_progress: float | None = option(None, "an action whose outcome moved less than this adds nothing "
                                        "(default: the scene resolution)", minimum=0.0)
    retire: str = option("split", "after a solution, leave its branch out of nearest-neighbour lookups back to "
                         "the nearest split (thesis 5.3.1), or the root's whole subtree it starts with (root)",
                         choices=("split", "root"))
    connect: bool = option(True, "RRT-Connect (repeated EXTENDs) until the first solution, then Extend")
    max_time: float | None = option(None, "deprecated: use planning.max_time (the request's wall-clock "
                                    "cap, s)", minimum=0.0)
    max_iterations: int | None = option(None, "deprecated: use planning.max_iterations (the request's "
                                       "work budget)", minimum=1)
    stop_on_first: bool = option(False, "stop at the first solution")
    progress: bool | None = option(None, "show a progress line (default: on a terminal)")


class BeliefPlanner(Planner):
    """Belief-space RRT with particles and partial policies (thesis 5.3); Simple and Contact RRT baselines.

    The result's ``policy`` is a :class:`pliant_belief.policy.PartialPolicy` over every solution; its
    ``path`` is the expected configurations of the most probable solution.  Statistics (thesis 5.4):
    ``iterations``, ``nodes``, ``particles_stored``, ``particles_simulated``, ``solutions``,
    ``time_to_first``, ``best_probability``, ``time``, ``interrupted``, ``extension_cut`` (the budget ran out inside
    an extension, whose unfinished simulations were dropped).

    The request's budget (``planning.max_iterations``, ``planning.max_time``) bounds the whole ``plan`` call: the
    setup comes off the time cap, and the simulator checks the cap every control step of an extension's simulations
    (docs/determinism.md).
    """

    SPECS = PlannerSpecs(needs_simulator=True, returns_policy=True, anytime=True,
                         work_unit="iterations (one sampled target, one or more extensions toward it)")

    Options = BeliefPlannerOptions
    example_scene = "se2-maze"
    example_components = {"simulator": "kinematic"}

    @property
    def specs(self) -> PlannerSpecs:
        """Simple RRT (``mode = "simple"``) checks straight edges and needs no simulator; the others do."""
        return replace(self.SPECS, needs_simulator=self.options.mode != "simple")
    example_options = {"particles": 8}
    example_budget = {"max_iterations": 40}

    def bind(self, context) -> None:
        """Attach to the pipeline and warm up (:func:`pliant.planning.warmup.warm_up`, one control period of the
        simulator included; and the clustering module's scipy imports): one-off loading when the pipeline is built,
        not inside ``max_time``."""
        super().bind(context)
        from pliant.api import ClusteringContext  # noqa: F401  (loads the clustering module and its scipy imports)

        warm_up(context, simulate=self.options.mode != "simple")

    def plan(self, problem: PlanningProblem, rng: np.random.Generator,
             termination: Termination | None = None) -> PlanResult:
        o = self.options
        t0 = time.perf_counter()
        space = problem.space
        start, goal, invalid = problem.checked_endpoints()
        if invalid is not None:
            return PlanResult.invalid_endpoint(invalid, "belief", dict(vars(o)))
        if o.mode != "simple" and problem.simulator is None:
            raise ConfigError(f"mode '{o.mode}' simulates actions: the pipeline needs a simulator",
                              field="simulator", value=None)
        if o.mode != "simple" and o.clustering in ("wcr", "ac") and problem.scene is None:
            raise ConfigError("this clustering needs the scene", field="planner.clustering", value=o.clustering)
        resolution = problem.scene.resolution if problem.scene is not None else o.max_step / 20
        self._min_progress = o.min_progress if o.min_progress is not None else resolution
        n = 1 if o.mode in ("contact", "simple") else o.particles
        settings = LocalPlannerSettings.from_options(o, particles=n, min_progress=self._min_progress,
                                                     reversibility=o.mode == "belief")
        cluster = self._clusterer(problem, rng) if o.mode != "simple" else None
        if o.mode == "simple":
            self._collision = self._collision_checker(problem)
        tree = BeliefTree(space)
        root = np.repeat(start[None], n, axis=0)
        tree.add(BeliefNode(particles=root, action=None, parent=-1, action_id=0,
                            goal_fraction=goal_fraction(problem, root)))
        counters = {"particles_simulated": 0, "extensions": 0, "splits": 0}
        first = first_iteration = None
        # the request's budget bounds the whole call: the setup above (grids, clustering context) comes off its cap
        termination = self.stop_condition(problem, termination, t0, stop_on_first=o.stop_on_first)
        progress = ProgressLine("belief", enabled=o.progress)
        cut = False
        with termination.watch():
            iteration = 0
            while not cut and not termination.should_stop(iteration, solved=bool(tree.solutions)):
                iteration += 1
                target = goal if rng.random() < o.goal_bias else self._sample(space, goal, rng)
                near = self._nearest(tree, target)
                if near < 0:
                    break
                connecting = o.connect and not tree.solutions
                while True:
                    before = float(space.distance(tree.nodes[near].expected, target)) if connecting else 0.0
                    try:
                        # the simulator checks the budget every control step (pliant.termination.checkpoint): an
                        # extension's forward and reverse simulations of many particles can outlast the budget
                        with termination.interruptible():
                            new = self._extend(tree, near, target, problem, cluster, settings, rng, counters)
                    except BudgetExpired:
                        cut = True              # nodes are added only once an extension is complete: the tree
                        break                   # is as it was before this one
                    counters["extensions"] += 1
                    counters["splits"] += len(new) > 1
                    for index in new:
                        if self._record_solution(tree, index, o.p_goal) and first is None:
                            first, first_iteration = termination.elapsed, iteration
                    if not (connecting and len(new) == 1) or tree.solutions or termination.should_stop(iteration):
                        break
                    after = float(space.distance(tree.nodes[new[0]].expected, target))
                    # reached, or trapped (RRT-Connect): an extension in contact can end somewhere new yet no
                    # closer, e.g. sliding back and forth along a face; connecting on from there never ended
                    # (one Baxter run: a single connect of 7,538 extensions filled the whole 240 s)
                    if after <= self._min_progress or after > before - self._min_progress:
                        break
                    near = new[0]
                progress.update(iterations=iteration, nodes=len(tree.nodes), solutions=len(tree.solutions))
                termination.publish(nodes=len(tree.nodes), solutions=len(tree.solutions))
        progress.close()
        stats = {"iterations": iteration, "nodes": len(tree.nodes),
                 "particles_stored": int(sum(len(nd.particles) for nd in tree.nodes)),
                 "particles_simulated": counters["particles_simulated"], "extensions": counters["extensions"],
                 "splits": counters["splits"], "solutions": len(tree.solutions), "time_to_first": first,
                 "iterations_to_first": first_iteration,
                 "time": time.perf_counter() - t0, "interrupted": termination.interrupted, "mode": o.mode,
                 "extension_cut": cut}
        self.tree = tree
        if not tree.solutions:
            return PlanResult(Status.TIMEOUT, planner="belief", statistics=stats, options=dict(vars(o)),
                              message="no solution reaches the goal with P_goal within the budget")
        probabilities = [solution_probability(tree, s) for s in tree.solutions]
        best = tree.solutions[int(np.argmax(probabilities))]
        stats["best_probability"] = float(max(probabilities))
        policy = self._policy(tree, problem)
        path = Path(np.array([tree.nodes[i].expected for i in best]), space_kind=space.kind)
        return PlanResult(Status.SOLVED, path=path, policy=policy, cost=float(len(best) - 1), planner="belief",
                          statistics=stats, options=dict(vars(o)))

    # --- pieces --------------------------------------------------------------------------------------

    def _policy(self, tree: BeliefTree, problem: PlanningProblem):

        o = self.options
        policy = PartialPolicy.from_tree(tree, p_goal=o.p_goal, attempts=o.attempts, importance=o.importance,
                                         goal=problem.goal, goal_tolerance=problem.goal_tolerance,
                                         clustering=o.clustering if o.mode != "simple" else "distance")
        if o.mode != "simple":
            policy.use_clustering(self.clustering_context, wcr_threshold=o.wcr_threshold,
                                  distance_threshold=o.distance_threshold)
        return policy

    def _clusterer(self, problem: PlanningProblem, rng: np.random.Generator):
        from pliant.api import ClusteringContext, cluster_particles

        o = self.options
        scene = problem.scene
        context = ClusteringContext(space=problem.space, robot=problem.robot,
                                    regions=list(scene.regions) if scene is not None else [],
                                    grid=VoxelGrid.from_scene(scene, static_only=True) if scene is not None else None,
                                    simulator=problem.simulator,
                                    goal_tolerance=problem.goal_tolerance or 2 * self._min_progress,
                                    duration=o.settle + o.max_step / o.speed)
        self.clustering_context = context

        def cluster(particles: np.ndarray) -> np.ndarray:
            if len(particles) == 1:
                return np.zeros(1, dtype=np.int64)
            return cluster_particles(particles, o.clustering, context, wcr_threshold=o.wcr_threshold,
                                     distance_threshold=o.distance_threshold, rng=rng)

        return cluster

    def _sample(self, space, goal: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """A uniform sample of the space; with ``rotation_spread``, its orientation replaced by the goal's
        turned by an angle uniform in ``[0, spread]`` (about a uniformly random axis in SE(3))."""
        q = space.sample(rng, 1)[0]
        spread = self.options.rotation_spread
        if spread is None or space.kind not in ("se2", "se3"):
            return q
        if space.kind == "se2":
            q[2] = wrap_angle(goal[2] + rng.uniform(-spread, spread))
            return q
        axis = rng.normal(size=3)
        turn = quat_from_axis_angle(axis / np.linalg.norm(axis), np.array(rng.uniform(0.0, spread)))
        q[3:7] = quat_multiply(goal[3:7], turn)
        return q

    def _nearest(self, tree: BeliefTree, target: np.ndarray) -> int:
        """The node of least PROXIMITY (eq. 5.1) among those not excluded; -1 if none."""
        o = self.options
        expected = tree.expected()
        distance = np.asarray(tree.space.distance(expected, target), dtype=np.float64)
        p = np.array([nd.path_probability for nd in tree.nodes])
        var = np.array([nd.variance for nd in tree.nodes])
        proximity = distance * ((1.0 - p) * o.alpha_p + (1.0 - o.alpha_p)) * (erf(var) * o.alpha_v + (1.0 - o.alpha_v))
        if tree.excluded:
            proximity[list(tree.excluded)] = np.inf
        i = int(np.argmin(proximity))
        return i if np.isfinite(proximity[i]) else -1

    def _extend(self, tree, near, target, problem, cluster, settings, rng, counters) -> list[int]:
        space = problem.space
        target = space.steer(tree.nodes[near].expected, target, self.options.max_step)
        if self.options.mode == "simple":
            return self._extend_simple(tree, near, target, problem)
        return extend(tree, near, target, problem, cluster, settings, rng, counters)

    def _collision_checker(self, problem: PlanningProblem):
        if problem.scene is None or problem.robot is None:
            raise ConfigError("the simple mode checks collisions against the scene: it needs a scene and a robot",
                              field="planner.mode", value="simple")
        grid = VoxelGrid.from_scene(problem.scene, static_only=True)
        occupied = grid.occupied.reshape(-1)
        robot = problem.robot

        def free(q: np.ndarray) -> np.ndarray:
            flat = grid.flat_index(robot.body_points(q))
            hit = np.where(flat >= 0, occupied[np.maximum(flat, 0)], False)
            return problem.is_valid(q) & ~hit.any(axis=1)

        return free

    def _extend_simple(self, tree: BeliefTree, near: int, target: np.ndarray, problem: PlanningProblem) -> list[int]:
        """Simple RRT: the straight edge to ``target`` if collision-free at every voxel, one certain outcome."""
        start = tree.nodes[near].expected
        step = problem.scene.resolution
        edge = problem.space.discretize(start, target, step)[1:]
        # each state, and each motion between consecutive states at voxel resolution (the core's checker)
        free = self._collision(edge) & problem.motions_valid(np.vstack([start[None], edge[:-1]]), edge)
        if not free.all():
            edge = edge[: int(np.argmin(free))]          # advance to the last free state, as RRT-Extend would
            if not len(edge) or float(problem.space.distance(edge[-1], start)) < self._min_progress:
                return []
            target = edge[-1]
        node = BeliefNode(particles=target[None].copy(), action=target.copy(), parent=near,
                          action_id=tree.new_action_id(), path_probability=tree.nodes[near].path_probability,
                          goal_fraction=goal_fraction(problem, target[None]))
        return [tree.add(node)]

    def _record_solution(self, tree: BeliefTree, index: int, p_goal: float) -> bool:
        """Add ``index``'s branch as a solution if it reaches the goal with ``P_goal``; retire the branch."""
        node = tree.nodes[index]
        if node.goal_fraction <= 0 or node.path_probability * node.goal_fraction < p_goal - 1e-12:
            return False
        branch = tree.branch(index)
        tree.solutions.append(branch)
        if self.options.retire == "root":
            retired = _subtree(tree, branch[1]) if len(branch) > 1 else []
        else:
            # thesis 5.3.1: walk toward the root to the base of the solution branch (the root or a split result)
            retired = []
            for i in reversed(branch[1:]):
                retired.append(i)
                if tree.nodes[i].split:
                    break
        tree.excluded.update(retired)
        return True


def _subtree(tree: BeliefTree, root: int) -> list[int]:
    """``root`` and every node below it."""
    children: dict[int, list[int]] = {}
    for i, node in enumerate(tree.nodes):
        children.setdefault(node.parent, []).append(i)
    out, stack = [], [root]
    while stack:
        i = stack.pop()
        out.append(i)
        stack.extend(children.get(i, []))
    return out


def solution_probability(tree: BeliefTree, solution: list[int]) -> float:
    """``P(start -> n) * goal fraction`` of a solution's last node (thesis 5.3.1)."""
    node = tree.nodes[solution[-1]]
    return node.path_probability * node.goal_fraction

