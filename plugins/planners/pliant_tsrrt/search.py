"""TASK_SPACE_RRT (poster ICHR 2010, "Pseudo code for TS-RRT algorithm"), lines 3-14, and the shortcut that removes
redundant actions.

    3  T.init(s_init)
    4  for i <- 1 to max_nodes
    5  do s_GD <- DIRECTGD(T)
    6    if RAND() > epsilon
    7    then s_samp <- s_GD
    8    else s_samp <- RANDOM_CONFIG()
    9    s_near <- NEAREST_NEIGHBOR(s_samp)
    10   a* <- ARGMIN_a(rho(MODEL(s_near, a), s_samp))
    11   s_new <- MODEL(s_near, a*)
    12   if not IN_COLLISION(s_new)
    13   then ADD_VERTEX(s_new)
    14        ADD_EDGE(s_near -a*-> s_new)

A state is the joint configuration of all ``k`` objects, ``(k, 3)`` poses (m, rad).  An action is a pair (object,
primitive); MODEL moves that object by its class's mean displacement for the primitive
(:func:`pliant_tsrrt.models.compose`).  Choices where the poster is silent (docs/plugins/tsrrt.md):

* **DIRECTGD(T)**: one of the ``gd_pool`` cheapest tree nodes that are not exhausted, moved against the task cost's
  gradient by ``gd_step`` times the mean push length (times a uniform factor in [0.5, 1.5]).  A node whose descent
  brought no cheaper child ``gd_tries`` times, or whose every action is used or invalid, is exhausted.  Line 5 is
  only evaluated when line 7 uses it.
* **rho**: ``sqrt(sum_o |p_o - p'_o|^2 + (r_o dtheta_o)^2)`` with each object's circumscribed radius ``r_o`` (m)
  turning angles into lengths and ``dtheta`` taken modulo the footprint's symmetry (pi for rectangles, pi / 2 for
  squares, ignored for circles).
* **IN_COLLISION** (:class:`pliant_tsrrt.geometry.CollisionChecker`) is checked for every action's outcome at once,
  and line 10 picks the closest *collision-free* outcome (the poster checks only the closest one; here an invalid
  closest outcome does not waste the iteration).  An outcome is invalid when the moved object, halfway or at the
  end, overlaps another object or an obstacle or leaves the table (with ``margin`` clearance), or when the paddle's
  swept area touches another object or an obstacle, or leaves the scene's bounds.  An action already taken from a
  node, and an outcome within ``duplicate`` of an existing node, is not added again; if it reaches that node in
  fewer pushes, the node is re-attached to the shorter way (its subtree follows).
* NEAREST_NEIGHBOR and the duplicate test use the chord approximation of rho (:meth:`ObjectSpace.embed`), one
  batched squared distance over the tree.
* The result is the path to the cheapest node (the one with the fewest pushes among equally cheap ones; poster:
  "returns a plan from the starting state to the most optimal reachable state"), extended by :func:`descend` (the
  steepest single pushes while they lower the cost, the discrete end of DIRECTGD's descent), improved by
  :func:`pliant_tsrrt.refine.improve` (not in the poster: free descent to local minima of the cost, each object
  pushed toward them through the models; ``refine``) and :func:`pliant_tsrrt.refine.final_beam` (a beam over every
  object's pushes by the task cost), then :func:`shortcut`:
  drop any action -- or any pair of opposite actions on one object -- whose removal keeps the plan valid and does
  not raise the final cost, until none can be dropped ("all paths free of collisions and redundant actions").
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from pliant.api import Condition, Termination

from pliant_tsrrt import kernels
from pliant_tsrrt.cost import TaskCost
from pliant_tsrrt.geometry import CIRCLE, CollisionChecker, Footprints, box_corners, wrap
from pliant_tsrrt.models import compose
from pliant_tsrrt.options import PlanningOptions, TSRRTOptions
from pliant_tsrrt.pushing import N_PRIMITIVES, PushSettings, contact_frames, decode_action, paddle_sweep_rows
from pliant_tsrrt.refine import final_beam, improve, optimum_targets, plan_score

#: rho (m) below which a new state counts as an existing node
DUPLICATE = 1e-3


@dataclass
class ObjectSpace:
    """The planning domain: footprints ``fp`` of the ``k`` objects, the mean displacements ``means`` ``(k, P, 3)``,
    the collision checker, the task cost, the push settings and the scene bounds ``(x0, y0, x1, y1)`` (m) that the
    paddle must stay inside.

    ``P`` is six primitives per stroke of ``strokes`` (fractions of a primitive's depth, the whole stroke first:
    ``planning.strokes``): primitive ``p`` is the models' primitive ``p % 6`` pushed with the stroke
    ``strokes[p // 6]``; it moves the object as its ``means`` say (the model's mean times the fraction, built by
    :func:`pliant_tsrrt.planner.build_space`) and is checked with primitive ``p % 6``'s whole stroke's paddle sweep,
    which contains a shorter stroke's.  An action is ``a = P o + p`` (:meth:`decode`)."""

    fp: Footprints
    means: np.ndarray
    checker: CollisionChecker
    cost: TaskCost
    push: PushSettings
    bounds: tuple[float, float, float, float]
    strokes: tuple[float, ...] = (1.0,)
    scale: np.ndarray = field(init=False)
    period: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.means = np.ascontiguousarray(self.means, dtype=np.float64)
        self.k = len(self.fp)
        self.strokes = tuple(float(f) for f in self.strokes)
        if self.means.ndim != 3 or self.means.shape[0] != self.k \
                or self.means.shape[1] != N_PRIMITIVES * len(self.strokes) or self.means.shape[2] != 3:
            raise ValueError(f"means must be (k, 6 x {len(self.strokes)} strokes, 3) for the {self.k} objects, got "
                             f"{self.means.shape}")
        self.scale = np.where(self.fp.kind == CIRCLE, 0.0, self.fp.radius)
        square = np.abs(self.fp.half[:, 0] - self.fp.half[:, 1]) < 1e-9
        self.period = np.where(square, np.pi / 2, np.pi)
        # a whole push's mean travel (m), DIRECTGD's unit step: the six primitives of the whole stroke, not the
        # fractions a space with more primitives adds after them
        self.step_length = float(np.mean(np.linalg.norm(self.means[:, :N_PRIMITIVES, :2], axis=-1)))
        self.frames = contact_frames(self.fp, self.push.turn_offset)
        self.n_prims = self.means.shape[1]
        # the paddle's swept box per (object, primitive) in the object's frame (paddle_sweep_rows): its centre, its
        # heading and its half extents, for the compiled validity check
        objs, prims = np.divmod(np.arange(self.k * self.n_prims), self.n_prims)
        pose, half = paddle_sweep_rows(np.zeros((len(objs), 3)), objs, prims % N_PRIMITIVES, self.fp, self.push,
                                       self.frames)
        self._sweep = (np.ascontiguousarray(pose[:, :2].reshape(self.k, self.n_prims, 2)),
                       np.ascontiguousarray(pose[:, 2].reshape(self.k, self.n_prims)),
                       np.ascontiguousarray(half.reshape(self.k, self.n_prims, 2)))

    def warm_up(self) -> None:
        """Call every compiled kernel once (:mod:`pliant_tsrrt.kernels`), so that their compilation -- some 10 s on
        the first run after installation, a fraction of a second when numba's cache has them -- is not charged to a
        planning budget."""
        s = self.random_config(np.random.default_rng(0))      # a warm-up: any arrangement, no result depends on it
        self.checker.in_collision(s)
        self.cost.cost(s[None])
        self.valid_actions(s, self.outcomes(s))
        self.valid_steps(s[None], s[None], np.zeros(1, dtype=np.int64), valid_before=True)
        self.rollout(s, [0])
        kernels.beam_expand(s[:1].copy(), self.means[0].copy(), s[0].copy(), 0.1, np.pi, 0.01)

    def decode(self, action: int) -> tuple[int, int, float]:
        """Action ``a = P o + p`` as ``(object o, primitive p % 6 of PRIMITIVES, stroke)`` (:func:`decode_action`)."""
        return decode_action(action, self.strokes)

    # --- MODEL, rho, IN_COLLISION ------------------------------------------------------------------------------

    def outcomes(self, s: np.ndarray) -> np.ndarray:
        """MODEL(s, a) for every action ``a = P o + p``: ``(P k, k, 3)``."""
        out = np.repeat(s[None], self.k * self.n_prims, axis=0)
        moved = compose(np.repeat(s, self.n_prims, axis=0), self.means.reshape(-1, 3))
        idx = np.arange(self.k * self.n_prims)
        out[idx, idx // self.n_prims] = moved
        return out

    def step(self, s: np.ndarray, action: int) -> np.ndarray:
        """MODEL(s, a) for one action (object ``action // P``, primitive ``action % P``)."""
        o, p = divmod(int(action), self.n_prims)
        out = s.copy()
        out[o] = compose(s[o], self.means[o, p])
        return out

    def embed(self, states: np.ndarray) -> np.ndarray:
        """Features ``(..., 4 k)`` whose Euclidean distance approximates :meth:`rho` (the angle term as the chord
        ``2 (r / w) sin(w dtheta / 2)``, ``w = 2 pi / period``): nearest neighbours and duplicates in one batched
        operation."""
        w = 2 * np.pi / self.period
        a = states[..., 2] * w
        rw = self.scale / w
        f = np.stack([states[..., 0], states[..., 1], rw * np.cos(a), rw * np.sin(a)], axis=-1)
        return f.reshape(*states.shape[:-2], 4 * self.k)

    def rho(self, states: np.ndarray, target: np.ndarray) -> np.ndarray:
        """The distance ``(n,)`` of arrangements ``(n, k, 3)`` from ``target`` ``(k, 3)`` (m)."""
        d = states - target
        dtheta = wrap(d[..., 2], self.period)
        return np.sqrt(np.sum(d[..., 0] ** 2 + d[..., 1] ** 2 + (self.scale * dtheta) ** 2, axis=-1))

    def valid_actions(self, s: np.ndarray, outcomes: np.ndarray, actions: np.ndarray | None = None) -> np.ndarray:
        """Bool ``(a,)``: which of the outcomes ``(a, k, 3)`` of ``actions`` (default all ``P k``) from ``s`` are valid
        (see the module docstring)."""
        if actions is None:
            actions = np.arange(self.k * self.n_prims)
        return self.valid_steps(np.repeat(s[None], len(actions), axis=0), outcomes, np.asarray(actions))

    def valid_steps(self, before: np.ndarray, after: np.ndarray, actions: np.ndarray,
                    valid_before: bool = False) -> np.ndarray:
        """Bool ``(m,)``: whether each step ``before[j] -a_j-> after[j]`` (``(m, k, 3)`` each) is valid, batched;
        compiled (:func:`pliant_tsrrt.kernels.valid_steps`, the same tests as :meth:`valid_steps_numpy`).
        ``valid_before``: the arrangements before are known to be free of collisions (states of the tree or of a
        beam), so only the moved object's pairs need checking after the step (the same answer, cheaper)."""
        actions = np.asarray(actions, dtype=np.int64)
        c = self.checker
        return kernels.valid_steps(np.ascontiguousarray(before, dtype=np.float64),
                                   np.ascontiguousarray(after, dtype=np.float64), actions // self.n_prims,
                                   actions % self.n_prims, self.means, c.objects.kind, c.objects.half,
                                   c.obstacles.kind, c.obstacles.half, c.obstacle_poses, c._table, float(c.margin),
                                   *self._sweep, np.asarray(self.bounds, dtype=np.float64), bool(valid_before))

    def valid_steps_numpy(self, before: np.ndarray, after: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """:meth:`valid_steps` in batched numpy."""
        m = len(actions)
        rows = np.arange(m)
        objs, prims = actions // self.n_prims, actions % self.n_prims
        half = after.copy()
        half[rows, objs] = compose(before[rows, objs], 0.5 * self.means[objs, prims])
        hit = self.checker.in_collision_numpy(np.concatenate([after, half]))
        ok = ~hit[:m] & ~hit[m:]
        boxes, sh = paddle_sweep_rows(before[rows, objs], objs, prims % N_PRIMITIVES, self.fp, self.push, self.frames)
        ok &= ~self.checker.boxes_hit(before, boxes, sh, objs)
        corners = box_corners(boxes, sh)
        x0, y0, x1, y1 = self.bounds
        ok &= np.all((corners[..., 0] >= x0) & (corners[..., 0] <= x1) & (corners[..., 1] >= y0)
                     & (corners[..., 1] <= y1), axis=-1)
        return ok

    def random_config(self, rng: np.random.Generator) -> np.ndarray:
        """RANDOM_CONFIG: every object uniformly on the table (centre within it), any orientation."""
        x0, y0, x1, y1 = self.checker.table
        xy = rng.uniform([x0, y0], [x1, y1], size=(self.k, 2))
        return np.concatenate([xy, rng.uniform(-np.pi, np.pi, (self.k, 1))], axis=1)

    def rollout(self, s0: np.ndarray, actions: list[int]) -> tuple[np.ndarray, bool]:
        """The predicted states ``(m + 1, k, 3)`` of an action sequence and whether every action was valid
        (compiled: :func:`pliant_tsrrt.kernels.rollout`)."""
        acts = np.asarray(actions, dtype=np.int64).reshape(-1)
        states = kernels.rollout(np.ascontiguousarray(s0, dtype=np.float64), acts // self.n_prims,
                                 acts % self.n_prims, self.means)
        if not len(acts):
            return states, True
        return states, bool(np.all(self.valid_steps(states[:-1], states[1:], acts)))


@dataclass
class SearchResult:
    """A plan: ``actions`` (``P o + p`` each, ``P`` the space's ``n_prims``), predicted ``states``
    ``(m + 1, k, 3)``, their ``cost`` (the final state's), the tree's ``states`` / ``parents`` / ``costs`` and
    statistics."""

    actions: list[int]
    states: np.ndarray
    cost: float
    tree_states: np.ndarray
    tree_parents: np.ndarray
    tree_costs: np.ndarray
    statistics: dict


#: members per pool of starts of the first improvement run's optimum under a time budget alone
LIGHT_POPULATION = 64


def _improvement_phase(space: ObjectSpace, s0: np.ndarray, plan: list[int], rng: np.random.Generator, imp,
                       stats: dict, *, goal: np.ndarray | None, deadline: float | None, anytime: bool,
                       floor: float) -> list[int]:
    """The improvement phase (:func:`~pliant_tsrrt.refine.improve`) on ``plan`` from ``s0``, run ``refine_restarts``
    times, each from the plan the previous run left and with the targets of a new multi-start optimum (its own
    child stream of ``rng``): the optimiser's best basin varies from one stream to the next by several per cent on
    five objects.  ``anytime`` (a time budget without a work budget): the runs go on until ``deadline``, so that a
    longer budget buys more of them, and the first uses a light optimum (:data:`LIGHT_POPULATION` members, one basin:
    with three objects and 5 s the full one left two plans of ten without a connection).  A replanning (``goal``
    given) runs once.  Returns the plan; ``stats`` gets the runs' statistics (``refine_runs``,
    ``refine_run_gains``; the last run's targets; ``refine_branch``, how many of the tree's pushes the result kept,
    and ``refine_pushes``, how many follow them; ``refine_connects`` and ``refine_gain`` summed)."""
    k = space.k
    goals = None if goal is None else np.asarray(goal, dtype=np.float64).reshape(-1, k, 3)
    runs, connects, gains, kept = 0, 0, [], len(plan)
    while True:
        path, _ = space.rollout(s0, plan)
        optimum, optimum_orders = None, None
        if imp.refine_optimum and goal is None:      # a replanning's goal (the first plan's end) is target enough
            # its own child stream: the draws after it are those of a run without it.  Under a time budget it takes
            # at most half of the improvement phase's time left, so that connecting to its targets gets the rest
            # (with a work budget the deadline is only the cap's)
            cut = deadline if deadline is None or not anytime else \
                time.perf_counter() + 0.5 * max(0.0, deadline - time.perf_counter())
            # on the clock, a first run with the light optimum of before (64 members, one basin) makes sure of a
            # connection within a short budget; the runs the rest of the time buys use the full one
            light = anytime and runs == 0
            optimum, optimum_orders = optimum_targets(
                space, rng.spawn(1)[0], imp.refine_optimum, imp.refine_optimum_orders, deadline=cut,
                population=min(LIGHT_POPULATION, imp.refine_optimum_population) if light else
                imp.refine_optimum_population, basins=1 if light else imp.refine_optimum_basins)
        _, keep, extra, more = improve(space, path, rng, count=imp.refine_targets,
                                       rounds=imp.refine_rounds, slack=imp.refine_slack,
                                       depth=imp.refine_depth, width=imp.refine_width,
                                       passes=imp.refine_passes, branch_points=imp.refine_branches,
                                       deadline=deadline, goals=goals, optimum=optimum,
                                       optimum_orders=optimum_orders, optimum_turns=imp.refine_optimum_turns,
                                       randoms=imp.refine_randoms, packed=imp.refine_patterns,
                                       sweeps=imp.refine_sweeps, turn_first=imp.refine_turn_first,
                                       yaw_quota=imp.refine_yaw_quota, push_cost=imp.push_cost,
                                       enough=floor)
        runs += 1
        kept = min(kept, keep)                      # how much of the tree's own plan is still in the result
        connects += int(more["refine_connects"])
        gains.append(float(more["refine_gain"]))
        stats.update(more)
        plan = plan[:keep] + extra
        if goal is not None or not imp.refine_optimum:
            break                                   # nothing new to draw: a second run would repeat the first
        if anytime:
            if deadline is None or time.perf_counter() >= deadline:
                break
        elif runs >= imp.refine_restarts:
            break
    stats.update(refine_runs=runs, refine_run_gains=gains, refine_branch=kept, refine_pushes=len(plan) - kept,
                 refine_connects=connects, refine_gain=float(sum(gains)))
    return plan


def grow(space: ObjectSpace, s0: np.ndarray, rng: np.random.Generator, settings: TSRRTOptions,
         termination: Condition | None = None, seed_plan: list[int] | None = None,
         goal: np.ndarray | None = None, enough: float | None = None) -> SearchResult:
    """TASK_SPACE_RRT lines 3-14 from ``s0`` ``(k, 3)`` until ``max_nodes`` nodes or ``termination``; returns the
    (shortcut) plan to the cheapest node.  Ctrl-C inside returns the best plan so far.  ``seed_plan``: actions whose
    valid prefix, rolled out from ``s0``, starts the tree as one branch (replanning during execution seeds the tree
    with the rest of the plan it replaces, so a new plan is never worse than carrying on).  ``goal`` ``(k, 3)``: an
    arrangement the improvement phase also connects to (replanning: the one the first plan ends in).  ``enough``: a
    task cost below which lower costs count as ``enough`` after the tree (improvement phase, final beam, descent,
    shortcut), so that of the plans that reach it the shortest wins (replanning: the first plan's cost)."""
    t0 = time.perf_counter()
    imp = settings.improvement
    k = space.k
    n_actions = k * space.n_prims
    cap = 1024
    states = np.empty((cap, k, 3))
    parents = np.full(cap, -1, dtype=np.int64)
    actions = np.full(cap, -1, dtype=np.int64)
    costs = np.empty(cap)
    fails = np.zeros(cap, dtype=np.int64)
    depth = np.zeros(cap, dtype=np.int64)
    used = np.zeros((cap, n_actions), dtype=bool)
    checked = np.zeros(cap, dtype=bool)            # the node's outcomes have been collision-checked (cached)
    grads: dict[int, np.ndarray] = {}              # DIRECTGD's cost gradients per node (cached)
    feats = np.empty((cap, 4 * k))
    states[0] = s0
    feats[0] = space.embed(s0)
    costs[0] = float(space.cost.cost(s0[None])[0])
    n = 1
    best = 0
    history = [[0.0, costs[0]]]
    stats = {"gd_samples": 0, "random_samples": 0, "invalid": 0, "duplicates": 0, "rewired": 0, "exhausted": 0}
    for a in seed_plan or ():
        prev = n - 1
        s_new = space.step(states[prev], a)
        if n >= cap or used[prev, a] or not space.valid_actions(states[prev], s_new[None], np.array([a]))[0]:
            break
        used[prev, a] = True
        states[n], parents[n], actions[n], feats[n], depth[n] = s_new, prev, a, space.embed(s_new), depth[prev] + 1
        costs[n] = float(space.cost.cost(s_new[None])[0])
        if costs[n] < costs[best] - 1e-12:
            best = n
        n += 1
    termination = termination or Termination()
    # a time budget covers the tree (1 - refine_share of it), the improvement phase (until 85 %) and the shortcut
    # (pair drops until 90 %; the rest is the final descent and single drops until none is left).  With a work
    # budget (max_iterations: tree extensions) the tree runs to it, the improvement phase and the shortcut to their
    # own work bounds (refine_rounds, refine_passes..., the shortcut's trials), and the time shares only guard the
    # cap: the plan is then the same on any machine while the cap does not bind (docs/determinism.md)
    budget = getattr(termination, "max_time", None)
    share = imp.refine_share if imp.refine else 0.0
    work = getattr(termination, "max_iterations", None) is not None
    tree_end = None if budget is None or work else t0 + (1.0 - share) * budget
    deadline = None if budget is None else t0 + 0.85 * budget
    iteration = 0
    with termination.watch():
        while n < settings.max_nodes and not termination.should_stop(iteration, costs[best], solved=True):
            if tree_end is not None and time.perf_counter() >= tree_end:
                termination.note_stop("time")             # the tree's time share: the plan depends on the clock
                break
            iteration += 1
            gd_node = -1
            if rng.random() > settings.planning.epsilon:
                gd_node, sample = _directgd(space, states, costs, fails, used, n, rng, settings.planning, grads)
            if gd_node < 0:
                sample = space.random_config(rng)
                stats["random_samples"] += 1
            else:
                stats["gd_samples"] += 1
            near = int(np.argmin(np.sum((feats[:n] - space.embed(sample)) ** 2, axis=1)))
            out = space.outcomes(states[near])
            if not checked[near]:                # invalid actions stay invalid from this node: mark them used
                used[near] |= ~space.valid_actions(states[near], out)
                checked[near] = True
            valid = ~used[near]
            if not valid.any():
                stats["invalid"] += 1
                fails[near] = settings.planning.gd_tries
                if gd_node >= 0 and gd_node != near:
                    fails[gd_node] += 1
                continue
            rho = np.where(valid, space.rho(out, sample), np.inf)
            a = int(np.argmin(rho))
            used[near, a] = True
            s_new = out[a]
            f_new = space.embed(s_new)
            d2 = np.sum((feats[:n] - f_new) ** 2, axis=1)
            dup = int(np.argmin(d2))
            if d2[dup] < DUPLICATE ** 2:
                stats["duplicates"] += 1
                if depth[near] + 1 < depth[dup] and not _is_ancestor(parents, dup, near):
                    parents[dup], actions[dup], depth[dup] = near, a, depth[near] + 1   # a shorter way there
                    stats["rewired"] += 1
                if gd_node >= 0:
                    fails[gd_node] += 1
                continue
            if n == cap:
                cap *= 2
                states, feats = _grow(states, cap), _grow(feats, cap)
                parents, actions, costs, fails, depth = (_grow(x, cap) for x in (parents, actions, costs, fails, depth))
                used, checked = _grow(used, cap), _grow(checked, cap)
            states[n], parents[n], actions[n], feats[n] = s_new, near, a, f_new
            depth[n] = depth[near] + 1
            costs[n] = float(space.cost.cost(s_new[None])[0])
            if gd_node >= 0 and costs[n] >= costs[gd_node]:
                fails[gd_node] += 1
            if costs[n] < costs[best] - 1e-12:
                best = n
                history.append([time.perf_counter() - t0, costs[n]])
            elif costs[n] <= costs[best] + 1e-12 and depth[n] < depth[best]:
                best = n                          # as cheap, fewer pushes
            n += 1
        interrupted = termination.interrupted
    ties = np.nonzero(costs[:n] <= costs[best] + 1e-12)[0][:500]
    best = int(min(ties, key=lambda i: (_path_length(parents, int(i)), costs[i])))    # fewest pushes among the best
    plan = []
    node = best
    while node > 0:
        plan.append(int(actions[node]))
        node = int(parents[node])
    plan.reverse()
    tree_time = time.perf_counter() - t0
    raw_length = len(plan)
    stats.update(refine_targets=[], refine_connects=0, refine_gain=0.0, refine_pushes=0, refine_branch=len(plan),
                 beam_pushes=0)
    floor = -np.inf if enough is None else float(enough)
    plan, polished = descend(space, s0, plan, push_cost=imp.push_cost, enough=floor)
    if imp.refine and not interrupted:
        plan = _improvement_phase(space, s0, plan, rng, imp, stats, goal=goal, deadline=deadline,
                                  anytime=budget is not None and not work, floor=floor)
    if imp.refine and imp.beam_depth > 0 and not interrupted:
        end = space.rollout(s0, plan)[0][-1]
        _, extra = final_beam(space, end, depth=imp.beam_depth, width=imp.beam_width, deadline=deadline,
                              push_cost=imp.push_cost, enough=floor)
        plan += extra
        stats["refine_pushes"] += len(extra)
        stats["beam_pushes"] = len(extra)
    refine_time = time.perf_counter() - t0 - tree_time
    if stats["refine_pushes"]:
        plan, more_polished = descend(space, s0, plan, push_cost=imp.push_cost, enough=floor)
        polished += more_polished
    plan, path_states, final = shortcut(space, s0, plan, deadline=None if budget is None else t0 + 0.9 * budget,
                                        push_cost=imp.push_cost, enough=floor)
    stats.update(iterations=iteration, nodes=n, time=time.perf_counter() - t0, tree_time=tree_time,
                 refine_time=refine_time,
                 cost_history=history, tree_best_cost=float(costs[best]), actions_before_shortcut=raw_length,
                 actions=len(plan), polish_pushes=polished, interrupted=interrupted,
                 exhausted=int(np.sum(fails[:n] >= settings.planning.gd_tries)))
    return SearchResult(plan, path_states, final, states[:n].copy(), parents[:n].copy(), costs[:n].copy(), stats)


def _path_length(parents: np.ndarray, node: int) -> int:
    count = 0
    while parents[node] >= 0:
        node, count = int(parents[node]), count + 1
    return count


def _is_ancestor(parents: np.ndarray, node: int, of: int) -> bool:
    """Whether ``node`` lies on the path from the root to ``of`` (``of`` itself included)."""
    while of >= 0:
        if of == node:
            return True
        of = int(parents[of])
    return False


def _grow(x: np.ndarray, cap: int) -> np.ndarray:
    out = np.zeros((cap, *x.shape[1:]), dtype=x.dtype)
    out[: len(x)] = x
    return out


def _directgd(space: ObjectSpace, states, costs, fails, used, n, rng, settings: PlanningOptions, grads) -> tuple[int,
                                                                                              np.ndarray | None]:
    """DIRECTGD(T) (line 5): a node among the cheapest non-exhausted ones, moved down the cost gradient; ``-1`` when
    every node is exhausted."""
    open_nodes = np.nonzero((fails[:n] < settings.gd_tries) & ~used[:n].all(axis=1))[0]
    if len(open_nodes) == 0:
        return -1, None
    pool = open_nodes[np.argsort(costs[open_nodes], kind="stable")[: settings.gd_pool]]
    node = int(pool[rng.integers(len(pool))])
    s = states[node]
    g = grads.get(node)
    if g is None:
        g = grads[node] = space.cost.gradient(s[None])[0]
    metric = np.sqrt(np.sum(g[:, :2] ** 2) + np.sum((g[:, 2] / np.maximum(space.scale, 1e-9)) ** 2))
    if not np.isfinite(metric) or metric < 1e-12:
        fails[node] = settings.gd_tries
        return -1, None
    length = settings.gd_step * space.step_length * rng.uniform(0.5, 1.5)
    direction = g.copy()
    direction[:, 2] = g[:, 2] / np.maximum(space.scale, 1e-9) ** 2
    sample = s - length * direction / metric
    if settings.gd_noise > 0:               # a stochastic descent: also try the moves across the gradient
        jitter = rng.normal(0.0, settings.gd_noise * space.step_length, s.shape)
        jitter[:, 2] /= np.maximum(space.scale, 1e-3)
        sample = sample + jitter
    return node, sample


def descend(space: ObjectSpace, s0: np.ndarray, plan: list[int], limit: int = 200,
            push_cost: float = 0.0, enough: float = -np.inf) -> tuple[list[int], int]:
    """From the plan's final state, append the valid action that lowers the cost most, while one lowers it by more
    than ``push_cost`` (task cost per push; at most ``limit``): the discrete end of DIRECTGD's descent, so the plan
    ends in a local minimum over single pushes; not below ``enough``.  Returns the plan and how many pushes were
    appended."""
    states, _ = space.rollout(s0, plan)
    s = states[-1]
    cost = float(space.cost.cost(s[None])[0])
    added = 0
    plan = list(plan)
    while added < limit and cost > enough:
        out = space.outcomes(s)
        c = np.where(space.valid_actions(s, out), space.cost.cost(out), np.inf)
        a = int(np.argmin(c))
        if not c[a] < cost - max(push_cost, 1e-12):
            break
        plan.append(a)
        s, cost, added = out[a], float(c[a]), added + 1
    return plan, added


def shortcut(space: ObjectSpace, s0: np.ndarray, plan: list[int], budget: int = 4000,
             deadline: float | None = None, push_cost: float = 0.0,
             enough: float = -np.inf) -> tuple[list[int], np.ndarray, float]:
    """Drop actions -- single ones, then pairs of opposite actions on one object -- while the plan stays valid and its
    final cost does not rise (by more than ``push_cost``, task cost per push, times the pushes dropped: a push that
    gains less is not worth its execution; costs below ``enough`` count as ``enough``), until none can be dropped;
    returns the plan, its predicted states and
    its final cost.
    Pairs are tried until ``budget`` trial plans have been checked or ``deadline`` (a ``time.perf_counter()``
    value); rounds of single drops always go on until none can be dropped (a pair drop may make a single one
    redundant; a round costs one rollout per action), so that no action of the result can be dropped alone."""
    plan = list(plan)
    states, _ = space.rollout(s0, plan)
    cost = float(space.cost.cost(states[-1][None])[0])
    trials = 0

    def attempt(drop: tuple[int, ...]) -> bool:
        nonlocal plan, states, cost, trials
        trials += 1
        first = drop[0]
        trial = [a for i, a in enumerate(plan) if i not in drop]
        tail, ok = space.rollout(states[first], trial[first:])     # the states before the first drop stay
        c = float(space.cost.cost(tail[-1][None])[0])
        if ok and plan_score(c, len(trial), push_cost, enough) <= plan_score(cost, len(plan), push_cost, enough) \
                + 1e-12:
            plan, states, cost = trial, np.concatenate([states[:first], tail]), c
            return True
        return False

    changed = True
    while changed and plan:
        late = (deadline is not None and time.perf_counter() >= deadline) or trials >= budget
        changed = False
        j = len(plan) - 1
        while j >= 0:                                  # from the end: a drop there changes the fewest states
            if attempt((j,)):
                changed = True
            j = min(j, len(plan)) - 1
        if late:                                       # past the deadline or the budget: single drops only
            continue
        for i in range(len(plan)):
            for k in range(i + 1, len(plan)):
                if trials >= budget or i >= len(plan) or k >= len(plan) or \
                        (deadline is not None and time.perf_counter() >= deadline):
                    break
                a, b = plan[i], plan[k]
                if a // space.n_prims == b // space.n_prims and (a % space.n_prims) ^ 1 == b % space.n_prims \
                        and attempt((i, k)):
                    changed = True
                    break
    return plan, states, cost


def redundant_actions(space: ObjectSpace, s0: np.ndarray, plan: list[int]) -> int:
    """How many actions of ``plan`` could be dropped alone with a valid plan of no higher final cost."""
    states, _ = space.rollout(s0, plan)
    cost = float(space.cost.cost(states[-1][None])[0])
    count = 0
    for j in range(len(plan)):
        trial_states, ok = space.rollout(s0, plan[:j] + plan[j + 1:])
        if ok and float(space.cost.cost(trial_states[-1][None])[0]) <= cost + 1e-12:
            count += 1
    return count
