"""Particle clustering of thesis 5.3.3: which forward-simulated particles form one belief.

After an extension the local planner (thesis 5.3.2) holds ``N`` particles; :func:`cluster_particles`
groups them into the outcomes of the action (one cluster: no split; several: a split).  Every method
runs two passes of complete-link hierarchical clustering (``scipy.cluster.hierarchy.linkage(method=
"complete")`` cut with ``fcluster(criterion="distance")``, so in every cluster *every pair* of members
is within the threshold):

1. a spatial-feature pass, one of

   - ``"pc"``, Particle Connectivity: the local planner (``simulator.simulate``) is run from every
     particle to every other one, ``N^2 - N`` simulations in one batch; a pair is connected (distance 0)
     only if both directions end within ``goal_tolerance`` (m, in ``space.distance``) of their target,
     else distance 1; threshold 0, so clusters are cliques of mutually reachable particles.  The exact
     but expensive method.
   - ``"wcr"``, Weakly Convex Region signature: the signature of ``q`` records, for every robot body
     point, which of the scene's hand-labelled convex regions contain it (a boolean ``(m, R)``);
     ``D_WCR(q1, q2)`` is the fraction of body points whose two region sets do not intersect.  A body
     point outside every region shares no region with anything (it counts as "not shared" in every
     pair, itself included).  Threshold ``wcr_threshold`` (thesis 5.4.1: 0.75 is best).
   - ``"ac"``, Actuation Centre: the straight segments between corresponding actuation centres of two
     configurations (a rigid body's frame origin; an articulated robot's joint centres) are checked
     against the static voxel grid, sampled every half voxel; collision-free gives distance 0, else 1;
     threshold 0.

2. a distance pass that refines each first-pass cluster by complete-link clustering on
   ``space.distance`` with ``distance_threshold`` (default ``8 * grid.resolution``, see
   :func:`default_distance_threshold`).  Method ``"distance"`` runs this pass alone.

Labels are ``0..k-1`` numbered by first appearance, so the same particles always get the same labels.
:func:`matches` is the test of thesis Algorithm 4 (5.3.5): an observed configuration reached a planned
node when it clusters with the node's belief into a single cluster.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
from scipy.cluster.hierarchy import linkage

from pliant.components import RobotModel, Simulator, refused_starts
from pliant.errors import ConfigError, DimensionError
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.spaces import Space

CLUSTERING_METHODS = ("pc", "wcr", "ac", "distance")

#: default second-pass threshold in voxels of the scene grid (see :func:`default_distance_threshold`)
DISTANCE_THRESHOLD_VOXELS = 8.0


@dataclass(frozen=True)
class ClusteringContext:
    """What the clustering methods need, built once per planner from the pipeline's components (thesis 5.3.3).

    space: the configuration space; its ``distance`` is the metric of the second pass.
    robot: the robot model; ``body_points(q)`` ``(n, m, 3)`` (m) gives the points of the WCR signature,
        ``rigid_placement`` / joint frames give the actuation centres of AC.
    regions: the scene's convex regions (``Region.lower`` / ``upper``, axis-aligned boxes in metres,
        2-D boxes bound ``(x, y)`` only); needed by ``"wcr"``.
    grid: the voxel grid of the environment; occupied voxels (``object_id != -1``) block AC segments.
        May be ``None`` (no scene) for the methods other than ``"ac"``.
    simulator: the local planner of ``"pc"`` (``simulate`` from particles to particles); may be ``None``
        for the other methods.
    goal_tolerance: ``epsilon_goal`` of ``"pc"`` (units of ``space.distance``): a simulation ending within
        it of its target succeeds.
    duration: seconds of simulation per ``"pc"`` test.
    """

    space: Space
    robot: RobotModel
    regions: list
    grid: VoxelGrid | None
    simulator: Simulator | None = None
    goal_tolerance: float = 0.1
    duration: float = 5.0

    def __post_init__(self) -> None:
        for name in ("goal_tolerance", "duration"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ConfigError("must be a positive finite number", field=name, value=value)

    @classmethod
    def from_context(cls, context, *, goal_tolerance: float | None = None, duration: float = 5.0,
                     grid: VoxelGrid | None = None) -> ClusteringContext:
        """Build from a pipeline :class:`~pliant.interfaces.Context` (scene and robot required).

        ``goal_tolerance`` defaults to the scene's (m), or two voxels when the scene sets none; ``grid`` to
        ``VoxelGrid.from_scene(scene)`` (every object at its scene pose, as the kinematic simulator holds
        them); ``duration`` in seconds.
        """
        if context.scene is None:
            raise ConfigError("clustering needs a scene", field="scene", value=None)
        if context.robot is None:
            raise ConfigError("clustering needs a robot", field="robot", value=None)
        scene = context.scene
        if goal_tolerance is None:
            goal_tolerance = scene.goal_tolerance if scene.goal_tolerance > 0 else 2.0 * scene.resolution
        tol = goal_tolerance
        return cls(space=context.robot.space, robot=context.robot, regions=list(scene.regions),
                   grid=VoxelGrid.from_scene(scene) if grid is None else grid, simulator=context.simulator,
                   goal_tolerance=float(tol), duration=float(duration))

    # --- derived data, computed once --------------------------------------------------------

    @cached_property
    def region_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(R, 3)`` lower and upper corners (m) of the regions; 2-D regions are unbounded in z."""
        lower = np.full((len(self.regions), 3), -np.inf)
        upper = np.full((len(self.regions), 3), np.inf)
        for r, region in enumerate(self.regions):
            lo = np.asarray(region.lower, dtype=np.float64)
            hi = np.asarray(region.upper, dtype=np.float64)
            if lo.shape != hi.shape or lo.ndim != 1 or len(lo) not in (2, 3):
                raise ConfigError("a region must have 2-D or 3-D lower and upper corners",
                                  field=f"regions[{r}]", value=getattr(region, "name", r))
            lower[r, : len(lo)] = lo
            upper[r, : len(hi)] = hi
        return lower, upper

    @cached_property
    def region_axes(self) -> tuple[int, ...]:
        """The axes (0 x, 1 y, 2 z) some region bounds; 2-D regions leave z out."""
        lower, upper = self.region_bounds
        return tuple(k for k in range(3) if np.isfinite(lower[:, k]).any() or np.isfinite(upper[:, k]).any())

    @cached_property
    def padded_occupancy(self) -> tuple[np.ndarray, np.ndarray]:
        """Flat bool occupancy of the grid padded by one blocked voxel on every side, and the padded shape."""
        padded = np.pad(self.grid.occupied, 1, constant_values=True)
        return padded.ravel(), np.array(padded.shape, dtype=np.intp)


def default_distance_threshold(context: ClusteringContext) -> float:
    """Second-pass threshold used when none is given: ``8 * grid.resolution`` (units of ``space.distance``;
    ``8 * goal_tolerance`` when the context has no grid).

    Eight voxels is the value of the authors' 2-D experiments (1.0 at resolution 0.125, with extension
    steps of 10 voxels): wide enough that the spread of one outcome under actuation noise (a few voxels)
    stays one cluster, narrow enough that particles ending at distinct places of one convex region
    (e.g. stuck at a corner vs. slid along a wall) split.  For joint spaces, whose distance is not in
    metres, pass ``distance_threshold`` explicitly (the authors used pi/2 for Baxter).
    """
    if context.grid is None:
        return DISTANCE_THRESHOLD_VOXELS * float(context.goal_tolerance)
    return DISTANCE_THRESHOLD_VOXELS * float(context.grid.resolution)


# --- validation ---------------------------------------------------------------------------------

def _check_particles(particles, space: Space, field: str = "particles") -> np.ndarray:
    try:
        q = np.asarray(particles, dtype=np.float64)
    except (TypeError, ValueError):
        raise DimensionError("must be an array of numbers", field=field, value=particles) from None
    if q.ndim != 2 or q.shape[1] != space.dim or len(q) == 0:
        raise DimensionError(f"must be (n, {space.dim}) configurations with n >= 1", field=field,
                             value=list(q.shape))
    if not np.all(np.isfinite(q)):
        raise DimensionError("must be finite (no NaN or infinity)", field=field,
                             value=q.tolist() if q.size <= 60 else list(q.shape))
    return q


def _check_method(method: str, context: ClusteringContext) -> None:
    if method not in CLUSTERING_METHODS:
        raise ConfigError(f"unknown clustering method; one of {', '.join(CLUSTERING_METHODS)}", field="method",
                          value=method)
    if method == "wcr" and not context.regions:
        raise ConfigError("WCR clustering needs the scene's convex regions, and this scene has none",
                          field="regions", value=[])
    if method == "ac" and context.grid is None:
        raise ConfigError("AC clustering needs the scene's voxel grid", field="grid", value=None)
    if method == "pc" and context.simulator is None:
        raise ConfigError("PC clustering needs a simulator (the local planner)", field="simulator", value=None)


def _check_thresholds(wcr_threshold: float, distance_threshold: float | None,
                      context: ClusteringContext) -> tuple[float, float]:
    if not (isinstance(wcr_threshold, (int, float)) and 0.0 <= wcr_threshold <= 1.0):
        raise ConfigError("must be a fraction in [0, 1]", field="wcr_threshold", value=wcr_threshold)
    if distance_threshold is None:
        return float(wcr_threshold), default_distance_threshold(context)
    if not (isinstance(distance_threshold, (int, float)) and np.isfinite(distance_threshold)
            and distance_threshold > 0):
        raise ConfigError("must be a positive finite distance", field="distance_threshold",
                          value=distance_threshold)
    return float(wcr_threshold), float(distance_threshold)


# --- pairwise distances of the spatial-feature pass ----------------------------------------------

def wcr_signatures(q: np.ndarray, context: ClusteringContext) -> np.ndarray:
    """Convex region signatures, bool ``(R, n, m)``: region ``r`` contains body point ``j`` of ``q[i]`` (5.3.3).

    Region boxes are closed (a point on a face is inside); 2-D regions test ``(x, y)`` only.
    """
    lower, upper = context.region_bounds
    pts = context.robot.body_points(q)                                      # (n, m, 3)
    n, m, _ = pts.shape
    inside = np.ones((len(lower), n * m), dtype=bool)
    for k in context.region_axes:                                           # the long axis innermost
        pk = pts[:, :, k].reshape(1, -1)
        inside &= (lower[:, k, None] <= pk) & (pk <= upper[:, k, None])
    return inside.reshape(len(lower), n, m)


def wcr_distances(q: np.ndarray, context: ClusteringContext) -> np.ndarray:
    """``(n, n)`` D_WCR: fraction of body points whose region sets at ``q[a]`` and ``q[b]`` are disjoint (5.3.3).

    The region sets are packed as bit masks (one byte per 8 regions); two sets intersect when the AND
    of their masks is non-zero, evaluated for all pairs and points at once (``(n, n, m)``).  A point in
    no region has an empty mask and so shares nothing.  The diagonal is 0.
    """
    sig = wcr_signatures(q, context)                                        # (R, n, m)
    m = sig.shape[2]
    packed = np.packbits(sig, axis=0)                                       # (B, n, m) uint8
    shared = packed[:, :, None, :] & packed[:, None, :, :]                  # (B, n, n, m)
    shared = np.bitwise_or.reduce(shared, axis=0) if len(packed) > 1 else shared[0]
    d = 1.0 - np.count_nonzero(shared, axis=2) / m
    np.fill_diagonal(d, 0.0)
    return d


def actuation_centres(q: np.ndarray, context: ClusteringContext) -> np.ndarray:
    """Actuation centres ``(n, c, 3)`` (m) of configurations ``(n, d)`` (thesis 5.3.3, AC).

    - a rigid body (``robot.rigid_placement(q)`` is not ``None``): its frame origin, ``c = 1``;
    - an articulated robot exposing ``urdf_description().joint_names`` and a public
      ``frame_position(q, name)`` (as the pinocchio robot does): the origin of every planned joint;
    - otherwise (fallback): the centroid of the body points, ``c = 1``.
    """
    robot = context.robot
    placement = robot.rigid_placement(q)
    if placement is not None:
        return np.asarray(placement[1], dtype=np.float64)[:, None, :]
    frame_position = getattr(robot, "frame_position", None)
    description = robot.urdf_description()
    if callable(frame_position) and description is not None and description.joint_names:
        return np.stack([np.asarray(frame_position(q, name), dtype=np.float64)
                         for name in description.joint_names], axis=1)
    return robot.body_points(q).mean(axis=1, keepdims=True)


def _segments_free(a: np.ndarray, b: np.ndarray, context: ClusteringContext) -> np.ndarray:
    """Bool ``(p,)``: every segment ``a[i, k] -> b[i, k]`` (``(p, c, 3)``, m) is free, sampled every half voxel.

    Every segment gets the sample count of the longest one (``ceil(2 L / resolution) + 1``); samples
    outside the grid count as blocked (the robot cannot leave the workspace).
    """
    grid = context.grid
    padded, shape = context.padded_occupancy
    u0 = (a - grid.lower) / grid.resolution + 1.0                           # padded voxel coordinates
    du = (b - a) / grid.resolution
    longest = float(np.sqrt((du * du).sum(axis=-1)).max(initial=0.0))
    t = np.linspace(0.0, 1.0, max(int(np.ceil(2.0 * longest)) + 1, 2))
    flat = None
    for k in range(3):                                                      # per axis: samples innermost
        uk = u0[:, :, k, None] + du[:, :, k, None] * t                      # (p, c, s)
        np.clip(uk, 0.0, shape[k] - 1.0, out=uk)                            # outside -> the blocked border
        ik = uk.astype(np.intp)
        flat = ik if flat is None else flat * shape[k] + ik
    return ~padded[flat].reshape(len(a), -1).any(axis=1)


def ac_connected(a: np.ndarray, b: np.ndarray, context: ClusteringContext) -> np.ndarray:
    """Bool ``(n,)``: configurations ``a[i]`` and ``b[i]`` (``(n, d)`` each) are AC-connected, the segments between
    their corresponding actuation centres free (thesis 5.3.3; used by the path metric's reachability check, 6.6.2)."""
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    if len(a) == 0:
        return np.zeros(0, dtype=bool)
    return _segments_free(actuation_centres(a, context), actuation_centres(b, context), context)


def ac_distances(q: np.ndarray, context: ClusteringContext, pairs: tuple[np.ndarray, np.ndarray] | None = None
                 ) -> np.ndarray:
    """``(n, n)`` AC distances: 0 when the segments between corresponding actuation centres are free, else 1."""
    n = len(q)
    centres = actuation_centres(q, context)
    i, j = _triu(n) if pairs is None else pairs
    d = np.zeros((n, n))
    if len(i):
        free = _segments_free(centres[i], centres[j], context)
        d[i, j] = d[j, i] = np.where(free, 0.0, 1.0)
    return d


def pc_distances(q: np.ndarray, context: ClusteringContext, rng: np.random.Generator,
                 pairs: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """``(n, n)`` PC distances: 0 when the local planner connects both ways, else 1 (thesis 5.3.3).

    All ``2 |pairs|`` simulations (``N^2 - N`` for all pairs) run as one ``simulate`` batch of
    ``context.duration`` seconds; a run succeeds when it ends within ``goal_tolerance`` of its target.
    """
    n = len(q)
    i, j = _triu(n) if pairs is None else pairs
    d = np.zeros((n, n))
    if not len(i):
        return d
    starts = np.concatenate([q[i], q[j]])
    targets = np.concatenate([q[j], q[i]])
    out = context.simulator.simulate(starts, targets, rng, context.duration)
    ok = np.asarray(context.space.distance(out.final, targets)) <= context.goal_tolerance
    both = ok[: len(i)] & ok[len(i):]
    d[i, j] = d[j, i] = np.where(both, 0.0, 1.0)
    return d


def space_distances(q: np.ndarray, context: ClusteringContext) -> np.ndarray:
    """``(n, n)`` pairwise ``space.distance`` (the metric of the second pass)."""
    d = np.asarray(context.space.distance(q[:, None, :], q[None, :, :]), dtype=np.float64)
    d = 0.5 * (d + d.T)
    np.fill_diagonal(d, 0.0)
    return d


# --- complete-link clustering -------------------------------------------------------------------

@lru_cache(maxsize=64)
def _triu(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The pairs ``i < j`` of ``n`` items (cached: ``np.triu_indices`` costs as much as a small clustering)."""
    i, j = np.triu_indices(n, 1)
    i.flags.writeable = j.flags.writeable = False
    return i, j


def _first_appearance(roots: np.ndarray) -> np.ndarray:
    """Relabel ``(n,)`` cluster keys to ``0..k-1`` in order of first appearance."""
    keys, first, inverse = np.unique(roots, return_index=True, return_inverse=True)
    rank = np.empty(len(keys), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(keys))
    return rank[inverse.ravel()]


def _cut(tree: np.ndarray, n: int, threshold: float) -> np.ndarray:
    """Flat clusters of a monotone linkage ``tree`` cut at ``threshold``, labels by first appearance.

    Equal to ``fcluster(tree, threshold, criterion="distance")`` up to the label numbering (checked by the
    tests); done here because ``fcluster`` spends most of its ~100 us validating the tree.  The merges
    at heights ``<= threshold`` are a prefix of a complete-link tree (its heights never decrease); every
    leaf's cluster is its topmost ancestor within that prefix, found by pointer jumping.
    """
    merges = int(np.searchsorted(tree[:, 2], threshold, side="right"))
    parent = np.arange(n + merges, dtype=np.intp)
    children = tree[:merges, :2].astype(np.intp)
    parent[children[:, 0]] = parent[children[:, 1]] = np.arange(n, n + merges)
    for _ in range(max(1, int(np.ceil(np.log2(n + merges))))):
        parent = parent[parent]
    return _first_appearance(parent[:n])


def complete_link(distances: np.ndarray, threshold: float, groups: np.ndarray | None = None) -> np.ndarray:
    """Complete-link hierarchical clustering of a distance matrix ``(n, n)`` cut at ``threshold``.

    Every pair in a returned cluster is within ``threshold``.  With ``groups`` ``(n,)``, particles of
    different groups are never merged (each group is clustered on its own: one linkage, cross-group
    distances raised above the threshold).  Returns labels ``(n,)`` in ``0..k-1`` by first appearance.
    """
    n = len(distances)
    d = distances
    if groups is not None:
        same = groups[:, None] == groups[None, :]
        if not same.all():
            big = 2.0 * max(float(threshold), float(d.max(initial=0.0))) + 1.0
            d = np.where(same, d, big)
        elif d.max(initial=0.0) <= threshold:
            return np.zeros(n, dtype=np.int64)
    elif d.max(initial=0.0) <= threshold:
        # complete link's last merge is at the largest pairwise distance: one cluster exactly then
        return np.zeros(n, dtype=np.int64)
    if n == 1:
        return np.zeros(1, dtype=np.int64)
    condensed = d[_triu(n)]
    tree = linkage(condensed, method="complete")
    return _cut(tree, n, threshold)


def _feature_distances(q: np.ndarray, method: str, context: ClusteringContext,
                       rng: np.random.Generator | None, pairs=None) -> tuple[np.ndarray, float | None]:
    if method == "wcr":
        return wcr_distances(q, context), None
    if method == "ac":
        return ac_distances(q, context, pairs), 0.0
    rng = np.random.default_rng(0) if rng is None else rng
    return pc_distances(q, context, rng, pairs), 0.0


def cluster_particles(particles: np.ndarray, method: str, context: ClusteringContext, *,
                      wcr_threshold: float = 0.75, distance_threshold: float | None = None,
                      rng: np.random.Generator | None = None) -> np.ndarray:
    """Labels ``(n,)`` int, ``0..k-1`` by first appearance, of configurations ``(n, d)`` (thesis 5.3.3).

    ``method``: ``"pc"``, ``"wcr"`` or ``"ac"`` (spatial-feature pass, then the distance pass) or
    ``"distance"`` (distance pass only).  ``wcr_threshold``: the D_WCR cut, a fraction of body points in
    [0, 1].  ``distance_threshold``: the second-pass cut in units of ``space.distance`` (default
    :func:`default_distance_threshold`).  ``rng`` drives the simulator's noise in ``"pc"`` (a fixed
    ``default_rng(0)`` when omitted, so the result is reproducible).

    Raises :class:`~pliant.errors.DimensionError` for particles of the wrong shape or non-finite, and
    :class:`~pliant.errors.ConfigError` for an unknown method, a bad threshold, ``"wcr"`` without regions
    or ``"pc"`` without a simulator.
    """
    _check_method(method, context)
    wcr_t, dist_t = _check_thresholds(wcr_threshold, distance_threshold, context)
    q = _check_particles(particles, context.space)
    if len(q) == 1:
        return np.zeros(1, dtype=np.int64)
    groups = None
    if method != "distance":
        feature, threshold = _feature_distances(q, method, context, rng)
        groups = complete_link(feature, wcr_t if threshold is None else threshold)
    return complete_link(space_distances(q, context), dist_t, groups)


def matches(belief_particles: np.ndarray, q: np.ndarray, method: str, context: ClusteringContext, *,
            wcr_threshold: float = 0.75, distance_threshold: float | None = None,
            rng: np.random.Generator | None = None) -> bool:
    """Whether configuration ``q`` ``(d,)`` reached the belief ``(k, d)``: ``|ClusterParticles(b + {q})| = 1``.

    Thesis Algorithm 4 (5.3.5).  Complete-link clustering yields a single cluster exactly when every
    pairwise distance is within the threshold, so this checks, for both passes, the largest distance
    over all pairs of ``b + {q}`` — without building the hierarchy.  For ``"pc"`` only the ``2k``
    simulations between ``q`` and the particles run: the belief's own particles were found mutually
    connected when it was planned (re-simulating them would cost ``k^2 - k`` runs per query); a ``q`` the
    simulator refuses as a start (outside its world or inside an obstacle) matches no belief.
    Arguments and errors as in :func:`cluster_particles`.
    """
    _check_method(method, context)
    wcr_t, dist_t = _check_thresholds(wcr_threshold, distance_threshold, context)
    b = _check_particles(belief_particles, context.space, "belief_particles")
    x = _check_particles(np.atleast_2d(np.asarray(q, dtype=np.float64)), context.space, "q")
    if len(x) != 1:
        raise DimensionError("must be one configuration (d,)", field="q", value=list(np.shape(q)))
    allq = np.concatenate([b, x])
    dist = space_distances(allq, context)
    if dist.max() > dist_t:
        return False
    if method == "distance":
        return True
    n = len(allq)
    pairs = None
    if method == "pc":
        if len(refused_starts(context.simulator, x)[0]):
            # the connectivity test cannot start from q (e.g. an observation outside the planning simulator's
            # world, or inside one of its obstacles): in the planner's model q connects to nothing
            return False
        pairs = (np.arange(n - 1), np.full(n - 1, n - 1))
    feature, threshold = _feature_distances(allq, method, context, rng, pairs)
    return bool(feature.max() <= (wcr_t if threshold is None else threshold))
