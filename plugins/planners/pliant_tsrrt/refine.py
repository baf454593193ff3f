"""The final improvement phase of TS-RRT: DIRECTGD's descent carried to a local minimum of the task cost (free
placement), and the tree's best node connected to it through the learned models.

The tree (lines 3-14) moves toward DIRECTGD's samples one push at a time; with pushes of 4-5 cm and turns of 11-13
degrees it ends a push length or a few degrees from the arrangement the cost wants, while the cost's edge and area
terms reward packing the objects to within the clearance margin.  This phase, run on the tree's result:

1. **targets** (:func:`free_descent`): a batched stochastic descent of the task cost over *free* placements
   (collision-free with ``margin + slack``: the slack leaves room for the pushes' quantisation), started from the
   tree's best arrangement -- the continuous end of DIRECTGD -- and from its *variants*: every box turned a quarter
   turn, every pair of objects with their places swapped (the local minima of the cost are separated by 45 degree
   turns, where orthogonality costs most, and by objects passing each other, which the tree rarely does in a few
   seconds).  The cheapest ``targets`` distinct minima are kept.
2. **connect** (:func:`connect`): for each target and each order of the objects, each object in turn is pushed
   toward its target pose by a beam search over its six primitives through MODEL (every step checked by
   IN_COLLISION and the paddle's sweep, the other objects where they are then; at most ``yaw_quota`` poses per yaw
   bin of a box); the state closest to the target is where that object stops, and the whole sequence is cut after
   its push of lowest task cost.  Only the learned models' mean displacements are used, as in the
   tree.
3. The cheapest of the connected plans (if cheaper than the tree's) is the result; further passes start from it,
   and :func:`final_beam` (a beam search over every object's pushes ordered by the task cost) finishes it, before
   the final descent and the shortcut of :mod:`pliant_tsrrt.search`.

Everything is bounded by a deadline (``time.perf_counter()`` value; None: no limit) and returns the best so far.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import replace

import numpy as np
from pliant.api import PlanningError

from pliant_tsrrt import kernels
from pliant_tsrrt.geometry import wrap
from pliant_tsrrt.models import compose
from pliant_tsrrt.pushing import N_PRIMITIVES


def _late(deadline: float | None) -> bool:
    return deadline is not None and time.perf_counter() >= deadline


def variants(space, s: np.ndarray) -> np.ndarray:
    """``s`` ``(k, 3)`` and its variants ``(v, k, 3)``: the objects' positions permuted among themselves (all
    permutations up to four objects, else each pair swapped), each combined with every subset of the boxes turned by
    a quarter turn (up to three boxes, else one at a time)."""
    k = space.k
    perms = list(itertools.permutations(range(k))) if k <= 4 else [tuple(range(k))] + [
        tuple(np.where(np.arange(k) == a, b, np.where(np.arange(k) == b, a, np.arange(k))))
        for a, b in itertools.combinations(range(k), 2)]
    boxes = np.nonzero(space.scale > 0)[0]
    turns = [c for r in range(len(boxes) + 1) for c in itertools.combinations(boxes, r)] if len(boxes) <= 3 else \
        [()] + [(b,) for b in boxes]
    out = []
    for perm in perms:
        for turn in turns:
            t = s.copy()
            t[:, :2] = s[list(perm), :2]
            t[list(turn), 2] += 0.5 * np.pi
            out.append(t)
    return np.array(out)


def free_descent(space, starts: np.ndarray, rng: np.random.Generator, rounds: int = 300, slack: float = 0.003,
                 sigma_start: float = 0.02, sigma_end: float = 5e-4, deadline: float | None = None,
                 snap=None) -> tuple[np.ndarray, np.ndarray]:
    """A batched stochastic descent of the task cost from ``starts`` ``(p, k, 3)`` over collision-free placements
    (margin grown by ``slack`` m): each round moves one random object of every member by a Gaussian step (``sigma``
    m, ``sigma / r_o`` rad, shrinking geometrically) and keeps cheaper collision-free moves.  ``snap``: a function
    of arrangements ``(p, k, 3)`` applied to the starts and to every step (:func:`reachable_targets` keeps the
    boxes' yaws on what their turns reach).  Returns the members and their costs (inf for a member that never was
    collision-free)."""
    check = replace(space.checker, margin=space.checker.margin + slack)
    pop = np.array(starts, dtype=np.float64)
    if snap is not None:
        pop = snap(pop)
    p = len(pop)
    cost = space.cost.cost(pop)
    cost[check.in_collision(pop)] = np.inf
    scale = np.maximum(space.fp.radius, 1e-3)
    rows = np.arange(p)
    for r in range(rounds):
        if r % 16 == 0 and _late(deadline):
            break
        sigma = sigma_start * (sigma_end / sigma_start) ** (r / max(1, rounds - 1))
        trial = pop.copy()
        obj = rng.integers(space.k, size=p)
        step = rng.normal(0.0, sigma, (p, 3))
        step[:, 2] /= scale[obj]
        trial[rows, obj] += step
        if snap is not None:
            trial = snap(trial)
        c = space.cost.cost(trial)
        better = (c < cost) & ~check.in_collision(trial)
        pop[better], cost[better] = trial[better], c[better]
    return pop, cost


def _collision_free(space, rng: np.random.Generator, count: int, margin: float, batch: int,
                    tries: int) -> list[np.ndarray]:
    """Up to ``count`` random arrangements (RANDOM_CONFIG) free of collisions with clearance ``margin`` (m), drawn
    ``batch`` at a time for at most ``tries`` batches."""
    check = replace(space.checker, margin=margin)
    out: list[np.ndarray] = []
    for _ in range(tries):
        if len(out) >= count:
            break
        drawn = np.stack([space.random_config(rng) for _ in range(batch)])
        out.extend(drawn[~check.in_collision(drawn)])
    return out[:count]


def random_free(space, rng: np.random.Generator, count: int, margin: float, tries: int = 20) -> np.ndarray:
    """Up to ``count`` random arrangements ``(c, k, 3)`` (RANDOM_CONFIG) free of collisions with clearance
    ``margin`` (m); fewer when the table is too crowded to find them in ``tries`` batches."""
    return np.array(_collision_free(space, rng, count, margin, 4 * count, tries)).reshape(-1, space.k, 3)


def random_arrangements(space, rng: np.random.Generator, count: int, tries: int = 2000,
                        clearance: float = 0.0) -> np.ndarray:
    """``count`` collision-free arrangements ``(count, k, 3)``, each object uniform on the table with any yaw, every
    footprint at least ``clearance`` (m) from the others, the obstacles and the table's edge (besides the margin);
    a :class:`PlanningError` when ``tries`` batches of 256 do not hold that many."""
    out = _collision_free(space, rng, count, space.checker.margin + 0.5 * clearance, 256, tries)
    if len(out) < count:
        raise PlanningError("could not place the objects without collision on the table", field="objects",
                            value=space.k)
    return np.array(out)


#: arrangements closer than this (m, per object: centre, or a box's corner through its yaw) are one basin
BASIN_DISTANCE = 0.02


def reference_optimum(space, rng: np.random.Generator, rounds: int = 4000, population: int = 64,
                      starts: np.ndarray | None = None, pattern_count: int = 512,
                      restarts: int = 2, deadline: float | None = None) -> tuple[np.ndarray, float]:
    """The reference optimum of the task cost over collision-free free placements (the figure of merit's
    denominator): the cheapest of several multi-start descents (:func:`optimum_basins`, the same arguments).  A work
    budget (rounds, members), so the same answer under a seed on any machine -- unless ``deadline`` (a
    ``time.perf_counter()`` value) cuts the descents short."""
    members, cost = _multistart(space, rng, rounds, population, starts, pattern_count, restarts, deadline)
    if not len(members) or not np.isfinite(cost.min()):
        return None, np.inf
    i = int(np.argmin(cost))
    return members[i].copy(), float(cost[i])


def optimum_basins(space, rng: np.random.Generator, count: int, rounds: int = 4000, population: int = 64,
                   starts: np.ndarray | None = None, pattern_count: int = 512, restarts: int = 2,
                   deadline: float | None = None, distance: float = BASIN_DISTANCE) -> tuple[np.ndarray, np.ndarray]:
    """Up to ``count`` minima of the multi-start optimisation in different basins, cheapest first ``(m, k, 3)``, and
    their costs: the cheapest member, then each next-cheapest member whose arrangement differs from every one kept by
    more than ``distance`` (m: some object's centre, or a box's corner through its yaw modulo a half turn).  The
    first is :func:`reference_optimum`'s answer.  A stronger optimiser finds tighter packings that pushing may not
    reach from a given start; the runners-up give the connections a second and third way.

    Starts: random collision-free arrangements (each box's yaw either uniform or snapped to a multiple of 90
    degrees: multi-start over orientations), the ``population`` cheapest of ``pattern_count`` packed
    :func:`patterns` (rows, columns, shelves), and ``starts`` (e.g. the planner's result).  Each of ``restarts``
    rounds descends (:func:`free_descent`, ``rounds`` rounds) from a wide step and then polishes the best members with
    a narrow one; the polished members of every round are the candidates."""
    members, cost = _multistart(space, rng, rounds, population, starts, pattern_count, restarts, deadline)
    order = np.argsort(cost, kind="stable")
    order = order[np.isfinite(cost[order])]
    box = space.scale > 0
    reach = np.where(box, space.scale, 0.0)
    kept: list[int] = []
    for i in order:
        if len(kept) >= count:
            break
        if all(_arrangement_distance(members[i], members[j], box, reach) > distance for j in kept):
            kept.append(int(i))
    return members[kept].copy(), cost[kept].copy()


def _arrangement_distance(a: np.ndarray, b: np.ndarray, box: np.ndarray, reach: np.ndarray) -> float:
    """The largest per-object distance between arrangements ``a`` and ``b`` ``(k, 3)`` (m): centres, and for boxes
    the yaw difference modulo a half turn (a box is symmetric) times the box's half diagonal."""
    d = np.linalg.norm(a[:, :2] - b[:, :2], axis=1)
    turn = np.abs((a[:, 2] - b[:, 2] + 0.5 * np.pi) % np.pi - 0.5 * np.pi)
    return float(np.max(np.where(box, np.maximum(d, turn * reach), d)))


def _multistart(space, rng: np.random.Generator, rounds: int, population: int, starts: np.ndarray | None,
                pattern_count: int, restarts: int, deadline: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The polished members of every round of the multi-start optimisation (:func:`optimum_basins`) and their
    costs (inf: never collision-free)."""
    k = space.k
    rand = random_arrangements(space, rng, population)
    snapped = rand.copy()
    box = space.scale > 0
    half = rng.random(population) < 0.5
    snapped[np.ix_(half, box, [2])] = (np.pi / 2) * rng.integers(0, 4, (int(half.sum()), int(box.sum()), 1))
    snapped = snapped[~space.checker.in_collision(snapped)]
    pats = patterns(space, rng, pattern_count)
    if len(pats):
        pats = pats[np.argsort(space.cost.cost(pats))[:population]]
    pools = [rand, snapped, pats]
    if starts is not None and len(starts):
        s = np.asarray(starts, dtype=np.float64).reshape(-1, k, 3)
        pools.append(s[~space.checker.in_collision(s)])
    pop = np.concatenate([p for p in pools if len(p)])
    found, found_cost = [], []
    for _ in range(restarts):
        desc, cost = free_descent(space, pop, rng, rounds=rounds, slack=0.0, sigma_start=0.05, sigma_end=5e-4,
                                  deadline=deadline)
        top = desc[np.argsort(cost)[: max(8, population // 4)]]
        fine, fcost = free_descent(space, np.repeat(top, 2, axis=0), rng, rounds=rounds, slack=0.0,
                                   sigma_start=0.005, sigma_end=1e-5, deadline=deadline)
        found.append(fine)
        found_cost.append(fcost)
        pop = np.concatenate([fine[np.argsort(fcost)[: len(pop) // 2]], pop[: len(pop) - len(pop) // 2]])
    return np.concatenate(found), np.concatenate(found_cost)


def table_mirrors(space, s: np.ndarray) -> np.ndarray:
    """Arrangement ``s`` ``(k, 3)`` and its mirror images across the table's two centre lines and both, those that
    are collision-free ``(m, k, 3)`` (``m`` <= 4).  Boxes and circles are symmetric, so a mirrored pose is a pose of the
    same object; without obstacles or a table setting the task cost is the same for all four, but from a given start
    one may be far nearer to reach by pushing than another."""
    x0, y0, x1, y1 = space.cost.table
    out = [np.asarray(s, dtype=np.float64)]
    for flip_x, flip_y in ((True, False), (False, True), (True, True)):
        m = out[0].copy()
        if flip_x:
            m[:, 0] = x0 + x1 - m[:, 0]
        if flip_y:
            m[:, 1] = y0 + y1 - m[:, 1]
        # a heading theta mirrored across a vertical line is pi - theta, across a horizontal one -theta
        theta = m[:, 2]
        theta = (np.pi - theta) if flip_x and not flip_y else (-theta if flip_y and not flip_x else theta + np.pi)
        m[:, 2] = (theta + np.pi) % (2 * np.pi) - np.pi
        out.append(m)
    out = np.array(out)
    return out[~space.checker.in_collision(out)]


def interchangeable(space) -> list[list[int]]:
    """Groups (two or more objects each) of objects the task cost cannot tell apart: the same footprint (kind and
    half extents) and named in no relation of a table setting.  Swapping the poses of two objects of a group leaves
    the cost and the collisions of an arrangement unchanged."""
    fp, relations = space.fp, np.asarray(space.cost.relations).reshape(-1, 4)
    related = set(relations[:, 0].astype(int).tolist()) | set(relations[:, 1].astype(int).tolist())
    groups: list[list[int]] = []
    for o in range(space.k):
        if o in related:
            continue
        for g in groups:
            if fp.kind[g[0]] == fp.kind[o] and np.array_equal(fp.half[g[0]], fp.half[o]):
                g.append(o)
                break
        else:
            groups.append([o])
    return [g for g in groups if len(g) > 1]


def _distinct(arrangements: np.ndarray) -> np.ndarray:
    """``arrangements`` ``(m, k, 3)`` without exact repeats, in the order of their first occurrence."""
    if not len(arrangements):
        return arrangements
    _, first = np.unique(arrangements.reshape(len(arrangements), -1), axis=0, return_index=True)
    return arrangements[np.sort(first)]


def nearest_assignments(space, targets: np.ndarray, states: np.ndarray) -> np.ndarray:
    """``targets`` ``(g, k, 3)`` and, for each target and each state of ``states`` ``(s, k, 3)``, the target with the
    poses of interchangeable objects (:func:`interchangeable`) reassigned to minimise the summed pose error from that
    state (an assignment problem per group); the same cost, a shorter way there.  Duplicates removed, the given
    targets first."""
    from scipy.optimize import linear_sum_assignment

    targets = np.asarray(targets, dtype=np.float64).reshape(-1, space.k, 3)
    groups = interchangeable(space)
    if not groups or not len(targets):
        return targets
    out = list(targets)
    for target in targets:
        for s in np.asarray(states, dtype=np.float64).reshape(-1, space.k, 3):
            moved = target.copy()
            for g in groups:
                errors = np.array([_pose_error(space, o, s[o], target[g]) for o in g])     # object x place
                rows, cols = linear_sum_assignment(errors)
                moved[np.asarray(g)[rows]] = target[np.asarray(g)[cols]]
            out.append(moved)
    return _distinct(np.array(out))


def optimum_targets(space, rng: np.random.Generator, rounds: int, orders: int = 0,
                    deadline: float | None = None, population: int = 64, basins: int = 1) -> tuple[np.ndarray, list]:
    """Targets from the multi-start free-placement optimum (:func:`optimum_basins` with ``rounds`` rounds and
    ``population`` members per pool of starts): its ``basins`` cheapest minima in different basins, each with its
    mirror images (:func:`table_mirrors`), ``(m, k, 3)``, none when the table is too crowded to place random starts;
    and the orders of the objects to connect to them in: every permutation when there are at most
    ``orders`` of them (120 for five objects), else ``orders`` drawn at random.  In a compact arrangement an object
    pushed into place early can block the paddle's way to the next, so which order works depends on the start: of
    five objects' 120 orders, the rotations of the identity alone reached the optimum within 6 % from two of four
    starts, all 120 from three (docs/plugins/tsrrt.md).  ``deadline``: the descents stop there (a time budget)."""
    k = space.k
    try:
        minima, _ = optimum_basins(space, rng, basins, rounds=rounds, population=population, deadline=deadline)
    except PlanningError:
        return np.zeros((0, k, 3)), []
    if not len(minima):
        return np.zeros((0, k, 3)), []
    if orders <= 0:
        chosen: list = []
    elif math.factorial(k) <= orders:
        chosen = list(itertools.permutations(range(k)))
    else:
        chosen = [tuple(int(i) for i in rng.permutation(k)) for _ in range(orders)]
    return np.concatenate([table_mirrors(space, m) for m in minima]), chosen


#: yaw resolution of :func:`yaw_lattice` (rad): net turns closer than this are one (a sixteenth of a degree, a
#: quarter of the beams' yaw bins); with learned turns of irregular sizes, or fractions of a stroke, the exact set
#: of net turns grows with every turn, and merging them keeps it to the few thousand values that matter
YAW_RESOLUTION = math.radians(0.25) / 4


def yaw_lattice(space, o: int, turns: int, threshold: float = 0.01) -> np.ndarray | None:
    """The net yaw changes (rad, sorted) that object ``o``'s primitives make in at most ``turns`` of them, counting
    the primitives that turn it by at least ``threshold`` rad (the models' mean yaw), net turns within
    :data:`YAW_RESOLUTION` of one another merged (each kept value is an exact sum of turns); None for a circle,
    whose yaw does not matter.  With the hand-made 0.2 rad turns: ``0.2 j`` for ``|j| <= turns``."""
    if space.scale[o] <= 0:
        return None
    yaws = space.means[o, :, 2]
    steps = np.unique(np.round(yaws[np.abs(yaws) >= threshold], 9))
    nets = frontier = np.zeros(1)
    seen = np.zeros(1, dtype=np.int64)                      # the merged values' bins
    for _ in range(turns):
        if not len(steps):
            break
        reached = np.round((frontier[:, None] + steps[None, :]).ravel(), 9)
        bins = np.round(reached / YAW_RESOLUTION).astype(np.int64)
        bins, first = np.unique(bins, return_index=True)
        new = ~np.isin(bins, seen)
        if not new.any():
            break
        frontier = reached[first[new]]
        nets, seen = np.concatenate([nets, frontier]), np.concatenate([seen, bins[new]])
    return np.sort(nets)


def yaw_snapper(space, state: np.ndarray, turns: int):
    """A function that moves every box's yaw in arrangements ``(..., k, 3)`` to the nearest (modulo the box's
    symmetry) of the yaws its turns reach from ``state`` ``(k, 3)`` in at most ``turns`` turns
    (:func:`yaw_lattice`); positions, circles and boxes that no primitive turns unchanged."""
    lattices = []
    for o in range(space.k):
        lat = yaw_lattice(space, o, turns)
        if lat is not None and len(lat) > 1:
            period = float(space.period[o])
            allowed = np.unique(np.mod(state[o, 2] + lat, period))       # sorted, in [0, period)
            lattices.append((o, allowed, period))

    def snap(arrangements: np.ndarray) -> np.ndarray:
        out = np.array(arrangements, dtype=np.float64)
        for o, allowed, period in lattices:
            yaw = out[..., o, 2]
            x = np.mod(yaw, period)
            i = np.searchsorted(allowed, x)
            below = allowed[(i - 1) % len(allowed)]            # the neighbours on the circle of the symmetry
            above = allowed[i % len(allowed)]
            d_below, d_above = wrap(x - below, period), wrap(x - above, period)
            out[..., o, 2] = yaw - np.where(np.abs(d_below) <= np.abs(d_above), d_below, d_above)
        return out
    return snap


def reachable_targets(space, targets: np.ndarray, states: np.ndarray, rng: np.random.Generator, turns: int,
                      rounds: int = 1000, copies: int = 4, deadline: float | None = None) -> np.ndarray:
    """``targets`` ``(g, k, 3)`` made reachable in yaw from each of ``states`` ``(s, k, 3)``: every box's yaw moved
    to the nearest yaw its turns reach from that state in at most ``turns`` turns (:func:`yaw_snapper`), then the
    positions (and yaws, on those values) descended again (:func:`free_descent`, ``rounds`` rounds, no extra slack)
    from ``copies`` members per target, its positions spread about their centre by 0, 4, 8, ... % (a turned box
    may overlap a neighbour, and a member in collision moves only by a step that frees it).  A free-placement
    optimum asks a box for a yaw its 0.2 rad turns cannot make; pushed toward it, the box ends up to 0.1 rad off
    square, and the positions chosen for the exact yaw no longer fit.  Returns the cheapest collision-free member
    per target and state ``(m, k, 3)`` (none for a target already reachable), duplicates removed.  ``deadline``:
    the descents stop there (a time budget)."""
    targets = np.asarray(targets, dtype=np.float64).reshape(-1, space.k, 3)
    snapped: dict[bytes, tuple] = {}            # the same snapped target from two states is descended once
    for state in np.asarray(states, dtype=np.float64).reshape(-1, space.k, 3):
        snap = yaw_snapper(space, state, turns)
        for target, moved in zip(targets, snap(targets)):
            if not np.allclose(moved, target):
                snapped.setdefault(np.round(moved, 9).tobytes(), (moved, snap))
    out = []
    spread = 1.0 + 0.04 * np.arange(copies)                # a turned box may overlap its neighbours: spread them
    for moved, snap in snapped.values():
        members = np.repeat(moved[None], copies, axis=0)
        centre = moved[:, :2].mean(axis=0)
        members[:, :, :2] = centre + spread[:, None, None] * (moved[:, :2] - centre)
        pop, cost = free_descent(space, members, rng, rounds=rounds, slack=0.0, sigma_start=0.01, sigma_end=1e-4,
                                 deadline=deadline, snap=snap)
        i = int(np.argmin(cost))
        if np.isfinite(cost[i]):
            out.append(pop[i])
    return _distinct(np.array(out).reshape(-1, space.k, 3))


def _extent(fp, o: int, quarter: int) -> tuple[float, float]:
    """Object ``o``'s full width and height (m) along the table's axes at yaw ``quarter * pi / 2``."""
    hx, hy = fp.half[o]
    return (2 * hy, 2 * hx) if quarter % 2 else (2 * hx, 2 * hy)


def patterns(space, rng: np.random.Generator, count: int, gap: float | None = None) -> np.ndarray:
    """Up to ``count`` packed, table-aligned arrangements ``(c, k, 3)`` centred on the table: the objects in one
    row, one column, or two to four rows (shelves), in a random order, every box at yaw 0 or 90 degrees, each
    shelf aligned on its top, middle or bottom, neighbours ``gap`` apart (default: twice the clearance margin plus
    0.5 mm).  Duplicates and colliding ones are dropped.  Starts for the reference's descent: a compact arrangement
    is the task cost's kind of optimum, and a random start rarely finds the packing of many objects."""
    k = space.k
    fp = space.fp
    gap = 2 * space.checker.margin + 5e-4 if gap is None else gap
    x0, y0, x1, y1 = space.checker.table
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
    out = []
    for _ in range(count):
        order = rng.permutation(k)
        quarters = rng.integers(0, 2, k)
        transpose = bool(rng.integers(2))            # rows along x (False) or along y (True)
        shelves = int(rng.integers(1, min(4, k) + 1))
        cuts = np.sort(rng.choice(np.arange(1, k), size=shelves - 1, replace=False)) if shelves > 1 else []
        groups = np.split(order, cuts)
        pose = np.zeros((k, 3))
        ext = {o: _extent(fp, o, quarters[o] + (1 if transpose else 0)) for o in range(k)}
        y = 0.0
        rows = []
        for g in groups:
            h = max(ext[o][1] for o in g)
            align = rng.integers(3)              # bottom, middle, top
            x = 0.0
            for o in g:
                w, ho = ext[o]
                dy = (ho / 2) if align == 0 else (h / 2 if align == 1 else h - ho / 2)
                pose[o, :2] = (x + w / 2, y + dy)
                x += w + gap
            rows.append((g, x - gap))
            y += h + gap
        width = max(wd for _, wd in rows)
        for g, wd in rows:                        # each shelf centred along the row
            pose[g, 0] += (width - wd) / 2
        pose[:, 0] -= width / 2
        pose[:, 1] -= (y - gap) / 2
        if transpose:
            pose[:, :2] = pose[:, [1, 0]]
        pose[:, :2] += centre
        pose[:, 2] = quarters * (np.pi / 2)
        out.append(pose)
    pop = np.unique(np.round(np.array(out), 9), axis=0) if out else np.zeros((0, k, 3))
    return pop[~space.checker.in_collision(pop)] if len(pop) else pop


def targets(space, s: np.ndarray, rng: np.random.Generator, count: int = 2, rounds: int = 800,
            slack: float = 0.003, deadline: float | None = None, randoms: int = 0, packed: int = 0) -> np.ndarray:
    """The ``count`` cheapest distinct local minima ``(c, k, 3)`` of the free descent from ``s`` and its
    :func:`variants`, each as it is and with the positions spread by a factor 1.3 about their mean (a variant that
    overlaps cannot descend; spread out it can), and from ``randoms`` random collision-free arrangements (the basins
    that no variant of ``s`` lies in, e.g. the objects in a row where ``s`` has them in a cluster).  The first member
    descends from ``s`` itself.  ``packed``: the cheapest of ``8 packed`` packed table-aligned arrangements (rows,
    columns, shelves: :func:`patterns`) descend too (the basins of compact arrangements of
    many objects, which neither ``s`` nor random starts tend to lie in)."""
    v = variants(space, s)
    spread = v.copy()
    centre = v[:, :, :2].mean(axis=1, keepdims=True)
    spread[:, :, :2] = centre + 1.3 * (v[:, :, :2] - centre)
    starts = np.concatenate([v, spread])
    if randoms > 0:
        starts = np.concatenate([starts, random_free(space, rng, randoms, space.checker.margin + slack)])
    if packed > 0:
        pats = patterns(space, rng, 8 * packed, gap=2 * (space.checker.margin + slack) + 5e-4)
        if len(pats):
            starts = np.concatenate([starts, pats[np.argsort(space.cost.cost(pats))[:packed]]])
    pop, cost = free_descent(space, starts, rng, rounds=rounds, slack=slack, sigma_start=0.04, deadline=deadline)
    order = np.argsort(cost)
    picked: list[int] = []
    for i in order:
        if not np.isfinite(cost[i]) or len(picked) == count:
            break
        if all(space.rho(pop[j][None], pop[i])[0] > 0.02 for j in picked):
            picked.append(int(i))
    return pop[picked]


def _pose_error(space, o: int, poses: np.ndarray, target: np.ndarray) -> np.ndarray:
    d = poses - target
    dtheta = wrap(d[..., 2], space.period[o])
    return np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2 + (space.scale[o] * dtheta) ** 2)


def push_toward(space, s: np.ndarray, o: int, target: np.ndarray, depth: int = 20, width: int = 64,
                deadline: float | None = None, stop: str = "closest", yaw_quota: int = 0) -> tuple[
                    float, list[int], np.ndarray]:
    """Object ``o`` of arrangement ``s`` pushed toward pose ``target`` ``(3,)``: a beam search over its primitives
    (the ``width`` outcomes closest to the target per depth, duplicates within 0.5 mm / 0.1 degree merged, every step
    valid), up to ``depth`` pushes, stopping early within 1 mm of the target or when four pushes came no closer.
    Returns the task cost, the actions and the state of where the object stops: ``stop`` ``closest``, the state
    closest to the target (fewest pushes among equally close ones; :func:`connect` then cuts the whole sequence
    where the cost is lowest), or ``cost``, the state of lowest task cost seen (``s`` itself when no push lowers
    it: an object whose way to its target first raises the cost then stays)."""
    means = np.ascontiguousarray(space.means[o])
    target = np.asarray(target, dtype=np.float64)
    scale, period = float(space.scale[o]), float(space.period[o])
    prims = np.arange(space.n_prims)
    clean = not space.checker.in_collision(s)[0]          # then only the moved object's pairs need checking
    poses = s[o][None]                                     # the beam: object o's poses (the others stay)
    back: list[tuple[np.ndarray, np.ndarray]] = []         # per depth: the kept outcomes' parents and actions

    def sequence(d: int, j: int) -> list[int]:
        out = []
        while d >= 0:
            parent, acts = back[d]
            out.append(int(acts[j]))
            j, d = int(parent[j]), d - 1
        return out[::-1]

    def state(pose: np.ndarray) -> np.ndarray:
        out = s.copy()
        out[o] = pose
        return out

    best = (float(space.cost.cost(s[None])[0]), [], s)
    closest, stale = float(_pose_error(space, o, s[o], target)), 0
    near = (closest, [], s)
    for d in range(depth):
        if _late(deadline) or closest < 1e-3 or stale >= 4:      # there, or no closer for four pushes
            break
        b = len(poses)
        from_pose = np.repeat(poses, space.n_prims, axis=0)
        prim = np.tile(prims, b)
        to_pose, err, key, all_bins = kernels.beam_expand(poses, means, target, scale, period, np.radians(0.25))
        _, first = np.unique(key, return_index=True)
        if yaw_quota and scale > 0:
            # at most yaw_quota outcomes per yaw (0.25 degree bins, modulo the footprint's symmetry), so that the
            # beam keeps the different numbers of turns: a box's yaw is set by how many turns of each sense it had,
            # and a combination that ends within a degree of the target's yaw may pass through poses farther off
            bins = all_bins[first]
            order = np.lexsort((err[first], bins))
            sb = bins[order]
            starts = np.r_[0, np.nonzero(np.diff(sb))[0] + 1]
            rank = np.arange(len(sb)) - np.repeat(starts, np.diff(np.r_[starts, len(sb)]))
            first = first[order[rank < yaw_quota]]
        keep = first[np.argsort(err[first], kind="stable")][: 2 * width]
        before = np.repeat(s[None], len(keep), axis=0)
        before[:, o] = from_pose[keep]
        after = before.copy()
        after[:, o] = to_pose[keep]
        ok = space.valid_steps(before, after, prim[keep] + space.n_prims * o, valid_before=clean)
        keep = keep[ok][:width]
        if not len(keep):
            break
        back.append((keep // space.n_prims, prim[keep] + space.n_prims * o))
        poses = to_pose[keep]
        if err[keep[0]] < closest - 1e-4:
            closest, stale = float(err[keep[0]]), 0
        else:
            stale += 1
        if err[keep[0]] < near[0] - 1e-9:
            near = (float(err[keep[0]]), sequence(d, 0), state(poses[0]))
        if stop == "cost":
            frontier = np.repeat(s[None], len(poses), axis=0)
            frontier[:, o] = poses
            c = space.cost.cost(frontier)
            j = int(np.argmin(c))
            if c[j] < best[0] - 1e-12:
                best = (float(c[j]), sequence(d, j), frontier[j])
    if stop == "cost":
        return best
    return float(space.cost.cost(near[2][None])[0]), near[1], near[2]


def plan_score(cost, pushes, push_cost: float = 0.0, enough: float = -np.inf):
    """What the choices after the tree compare (lower is better): the task ``cost`` (a number or an array), costs
    below ``enough`` counting as ``enough``, plus ``push_cost`` (task cost per push) times ``pushes``."""
    return np.maximum(cost, enough) + push_cost * pushes


def turned_first(space, s: np.ndarray, o: int, target: np.ndarray, hit: tuple, depth: int, width: int,
                 deadline: float | None, stop: str, yaw_quota: int) -> tuple[float, list[int], np.ndarray]:
    """Box ``o`` of ``s`` turned to ``target``'s yaw where it is, then pushed to ``target`` (two
    :func:`push_toward` searches), instead of the direct search's result ``hit`` when that leaves its yaw more than
    5 mm off at its half diagonal and the turned-first one ends closer to the target.  A thin box pushed straight to
    a place among others arrives there unturned, with no room left to turn (``improvement.refine_turn_first``)."""
    pose = hit[2][o]
    if abs(float(wrap(pose[2] - target[2], space.period[o]))) * space.scale[o] < 5e-3:
        return hit
    mid = s[o].copy()
    mid[2] = target[2]
    _, seq1, s1 = push_toward(space, s, o, mid, depth, width, deadline, stop, yaw_quota)
    c2, seq2, s2 = push_toward(space, s1, o, target, depth, width, deadline, stop, yaw_quota)
    if _pose_error(space, o, s2[o], target) < _pose_error(space, o, pose, target) - 1e-4:
        return c2, seq1 + seq2, s2
    return hit


def connect(space, s: np.ndarray, target: np.ndarray, order, depth: int = 20, width: int = 64,
            deadline: float | None = None, sweeps: int = 1, cache: dict | None = None,
            stop: str = "closest", yaw_quota: int = 0, push_cost: float = 0.0,
            enough: float = -np.inf, turn_first: bool = False) -> tuple[float, list[int]]:
    """The objects pushed toward ``target`` ``(k, 3)`` one after another in ``order`` (:func:`push_toward`),
    ``sweeps`` times over (a later sweep moves the objects an earlier one left blocked by objects that have moved
    since, while one is more than 5 mm off); returns the final cost and the actions, cut after the push of lowest
    task cost (``stop``: see :func:`push_toward`); with ``push_cost`` (task cost per push) after the push of lowest
    task cost plus ``push_cost`` times the pushes so far, so that a tail of pushes that each gain less than
    ``push_cost`` is left off (``enough``: a task cost below which lower costs count as ``enough``, so the sequence
    stops where it first reaches it).  ``cache``: a dict that keeps :func:`push_toward`'s results across calls
    (orders that begin alike share their first searches).  ``turn_first``: a box left turned off its target's yaw is
    also tried turned where it is first (:func:`turned_first`)."""
    actions: list[int] = []
    start = s
    cost = float(space.cost.cost(s[None])[0])
    for sweep in range(sweeps):
        if sweep and max(float(_pose_error(space, int(o), s[int(o)], target[int(o)])) for o in order) < 5e-3:
            break
        for o in order:
            key = (s.tobytes(), int(o), target.tobytes(), depth, width, stop, yaw_quota, turn_first)
            hit = cache.get(key) if cache is not None else None
            if hit is None:
                hit = push_toward(space, s, int(o), target[int(o)], depth, width, deadline, stop, yaw_quota)
                if turn_first and space.scale[int(o)] > 0:
                    hit = turned_first(space, s, int(o), target[int(o)], hit, depth, width, deadline, stop,
                                       yaw_quota)
                if cache is not None and not _late(deadline):        # a search cut short is not kept
                    cache[key] = hit
            cost, seq, s = hit
            actions += seq
    if stop == "closest" and actions:              # the way there may cost more than the start: cut at the cheapest
        states, _ = space.rollout(start, actions)
        costs = space.cost.cost(states)
        cut = int(np.argmin(plan_score(costs, np.arange(len(costs)), push_cost, enough)))
        return float(costs[cut]), actions[:cut]
    return cost, actions


def improve(space, path: np.ndarray, rng: np.random.Generator, *, count: int = 2, rounds: int = 800,
            slack: float = 0.003, depth: int = 20, width: int = 64, max_orders: int = 6, passes: int = 2,
            branch_points: int = 3, deadline: float | None = None, goals: np.ndarray | None = None,
            randoms: int = 0, sweeps: int = 1, yaw_quota: int = 0, push_cost: float = 0.0,
            enough: float = -np.inf, packed: int = 0, optimum: np.ndarray | None = None,
            optimum_orders: list | None = None, optimum_turns: int = 0,
            turn_first: bool = False) -> tuple[float, int, list[int], dict]:
    """The improvement phase on the tree's best path ``path`` ``(m + 1, k, 3)`` (its states, start to best node):
    :func:`targets` from the best node (after the given ``goals`` ``(g, k, 3)`` in the first pass: when replanning
    during execution, the arrangement the first plan ends in), then :func:`connect` to each target from the best
    node and from ``branch_points - 1`` earlier nodes of the path (evenly spaced, the root included; the objects
    have more room there), for up to ``max_orders`` orders of the objects (all of them for three objects; else the
    identity and its rotations), the orders outermost.  ``randoms``: random arrangements whose free descent adds
    targets (first pass).  Later passes (up to ``passes``) start from the previous pass's result; after a pass
    without gain the next one connects with a beam twice as wide, up to four times ``width``, then the phase ends.
    ``yaw_quota``: see :func:`push_toward`.  ``push_cost`` (task cost per push): connections are compared by their
    final cost plus ``push_cost`` times the whole plan's pushes (kept ones included), so that of two connections of
    nearly equal cost the shorter wins, and a connection must gain more than ``push_cost`` per push it adds;
    ``enough``: a final cost below it counts as ``enough`` (replanning during execution: no cheaper than the first
    plan is needed, so the shortest connection that gets there wins).  ``optimum`` ``(g, k, 3)`` and
    ``optimum_orders``: more targets (:func:`optimum_targets`) for the first pass, connected to from each branch
    point in the usual orders and each of those, after the others; with them the same targets with identical
    objects' places reassigned nearest to the start and to the best node (:func:`nearest_assignments`), and with
    ``optimum_turns`` those targets made reachable in yaw from the start and the best node
    (:func:`reachable_targets`, at most that many turns per box; on a child stream of ``rng``).  ``turn_first``:
    see :func:`connect`.
    Returns the cheapest cost reached, how many of the path's actions to keep, the actions to append, and statistics."""
    s = path[-1]
    base = best_cost = float(space.cost.cost(s[None])[0])
    keep = len(path) - 1
    if optimum is not None and len(optimum):
        # identical objects may take each other's places in the optimum: from the start and from the tree's best
        # node, the assignment nearest to where the objects are
        optimum = nearest_assignments(space, optimum, path[[0, -1]])
        if optimum_turns:
            optimum = np.concatenate([optimum, reachable_targets(space, optimum, path[[0, -1]], rng.spawn(1)[0],
                                                                 optimum_turns, deadline=deadline)])
    best_score = plan_score(best_cost, keep, push_cost, enough)
    k = space.k
    orders = list(itertools.permutations(range(k))) if k <= 3 else [tuple(np.roll(np.arange(k), -i)) for i in range(k)]
    orders = orders[:max_orders]
    branches = sorted({round(float(x)) for x in np.linspace(len(path) - 1, 0, max(1, branch_points))}, reverse=True)
    best_actions: list[int] = []
    tried, goal_costs = 0, []
    cache: dict = {}
    w = width
    gains: list[bool] = []
    for p in range(passes):
        if _late(deadline):
            break
        found_targets = targets(space, s, rng, count=count, rounds=rounds, slack=slack, deadline=deadline,
                                randoms=randoms if p == 0 else 0, packed=packed if p == 0 else 0)
        if p == 0 and goals is not None and len(goals):
            found_targets = np.concatenate([np.asarray(goals, dtype=np.float64).reshape(-1, k, 3),
                                            found_targets.reshape(-1, k, 3)])
        groups = [(orders, found_targets)]
        if p == 0 and optimum is not None and len(optimum):
            # the usual orders first, then the optimum's own (every permutation, or a random sample of them)
            groups.append((list(dict.fromkeys([*orders, *(optimum_orders or [])])), optimum))
        for _, group in groups:
            goal_costs += [float(c) for c in space.cost.cost(group)] if len(group) else []
        found = None
        # order-major within each group, so that a deadline leaves every target and branch point tried with the first
        # orders
        connections = itertools.chain.from_iterable(
            itertools.product(group_orders, group, branches if p == 0 else [None]) for group_orders, group in groups)
        for order, goal, b in connections:
            if _late(deadline):
                break
            tried += 1
            cost, actions = connect(space, s if b is None else path[b], goal, order, depth, w, deadline, sweeps,
                                    cache, yaw_quota=yaw_quota, push_cost=push_cost, enough=enough,
                                    turn_first=turn_first)
            score = plan_score(cost, (keep + len(best_actions) if b is None else b) + len(actions), push_cost,
                               enough)
            if score < best_score - 1e-12:
                best_cost, best_score, found = cost, score, (b, actions)
        gains.append(found is not None)
        if found is None:
            if p == 0 or w >= 4 * width:
                break
            w *= 2                  # no gain: the next pass (new targets) with a beam twice as wide
            continue
        b, actions = found
        if b is not None:
            keep, best_actions = b, actions
            s = space.rollout(path[b], actions)[0][-1]
        else:
            best_actions = best_actions + actions
            s = space.rollout(s, actions)[0][-1]
    stats = {"refine_targets": goal_costs, "refine_connects": tried, "refine_gain": base - best_cost,
             "refine_branch": keep, "refine_pass_gains": gains, "refine_last_width": w}
    return best_cost, keep, best_actions, stats


def final_beam(space, s: np.ndarray, depth: int = 4, width: int = 128, deadline: float | None = None,
               push_cost: float = 0.0, enough: float = -np.inf) -> tuple[float, list[int]]:
    """A beam search over every object's primitives from arrangement ``s``, ordered by the task cost: per depth the
    ``width`` cheapest valid outcomes (duplicates within 0.5 mm / 0.1 degree merged), up to ``depth`` pushes.  Returns
    the lowest cost seen and the actions to it (none when no sequence lowers the cost; with ``push_cost``, task cost
    per push: the lowest cost plus ``push_cost`` times the pushes, none unless that is below the cost of ``s``;
    costs below ``enough`` count as ``enough``).
    Unlike the greedy descent
    (:func:`pliant_tsrrt.search.descend`) it goes through pushes that first raise the cost -- one object moved out
    of the way, or a turn that needs a push after it -- and moves any objects together."""
    n_actions = space.k * space.n_prims
    acts_all = np.arange(n_actions)
    objs, prims = acts_all // space.n_prims, acts_all % space.n_prims
    best = (float(space.cost.cost(s[None])[0]), [])
    best_score = plan_score(best[0], 0, push_cost, enough)
    frontier = s[None]
    seqs: list[list[int]] = [[]]
    for d in range(depth):
        if _late(deadline):
            break
        b = len(frontier)
        before = np.repeat(frontier, n_actions, axis=0)
        acts = np.tile(acts_all, b)
        after = before.copy()
        rows = np.arange(len(acts))
        o = np.tile(objs, b)
        after[rows, o] = compose(before[rows, o], space.means[o, np.tile(prims, b)])
        c = space.cost.cost(after)
        key = np.round(after[:, :, :2] / 5e-4).astype(np.int64).reshape(len(after), -1)
        key = np.concatenate([key, np.round(((after[:, :, 2] + np.pi) % (2 * np.pi)) / 2e-3).astype(np.int64)], 1)
        _, first = np.unique(key, axis=0, return_index=True)
        keep = first[np.argsort(c[first], kind="stable")][: 2 * width]
        ok = space.valid_steps(before[keep], after[keep], acts[keep])
        keep = keep[ok][:width]
        if not len(keep):
            break
        seqs = [seqs[i // n_actions] + [int(acts[i])] for i in keep]
        frontier = after[keep]
        score = plan_score(float(c[keep[0]]), d + 1, push_cost, enough)
        if score < best_score - 1e-12:
            best, best_score = (float(c[keep[0]]), seqs[0]), score
    return best


def finishing_push(space, s: np.ndarray, scales: tuple[float, ...] = (1.0,)) -> tuple[float, int, float,
                                                                                       np.ndarray] | None:
    """The one push from arrangement ``s`` ``(k, 3)`` predicted to lower the task cost the most, over every object's
    primitives made with each stroke of ``scales`` (fractions of the primitive's depth; the predicted displacement
    is the model's mean times the fraction, to first order: after the guarded approach the paddle's travel is what
    moves the object).  Returns ``(predicted cost, action, fraction, predicted arrangement)``, or ``None`` when no
    valid push is predicted to lower the cost by 0.1 %.  The closed-loop finishing of an execution
    (``execution.finish_steps``): fractions of a stroke make corrections finer than a whole push (a turn of 0.2 rad
    cannot take out a yaw error of 0.1 rad; a third of one can).  Only the whole strokes of ``space``'s actions are
    scaled (a space that plans with fractions, ``planning.strokes``, has them as well): the action returned is a
    whole stroke's, the stroke to push with is the fraction."""
    whole = (np.arange(space.k)[:, None] * space.n_prims + np.arange(N_PRIMITIVES)).ravel()   # whole strokes
    acts = np.tile(whole, len(scales))
    scale = np.repeat(np.asarray(scales, dtype=np.float64), len(whole))
    objs, prims = acts // space.n_prims, acts % space.n_prims
    before = np.repeat(s[None], len(acts), axis=0)
    after = before.copy()
    rows = np.arange(len(acts))
    after[rows, objs] = compose(before[rows, objs], scale[:, None] * space.means[objs, prims])
    cost_now = float(space.cost.cost(s[None])[0])
    c = space.cost.cost(after)
    order = np.argsort(c, kind="stable")
    order = order[c[order] < cost_now * (1 - 1e-3)]
    for start in range(0, len(order), 64):             # the cheapest valid one: check validity in small batches
        chunk = order[start:start + 64]
        ok = space.valid_steps(before[chunk], after[chunk], acts[chunk])
        if ok.any():
            i = int(chunk[np.argmax(ok)])
            return float(c[i]), int(acts[i]), float(scale[i]), after[i]
    return None
