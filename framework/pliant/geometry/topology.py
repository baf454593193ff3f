"""Topology of voxel objects, and puncture and cut detection along paths (thesis 4.3.4).

Thesis 4.3.4 keeps a planned path from puncturing or cutting a deformable object: the voxels swept
by the robot along the path from the start are removed from each object's voxel model, and the
motion is invalid when an object gains a hole (a tunnel), loses a void (a cavity opened to the
outside) or falls apart into more pieces than it started with.  Objects that are hollow or have
holes at the start are legal: the counts are compared with the object's own initial counts.

Two independent ways of counting are implemented, and they agree (``tests/framework/geometry/test_topology.py``):

* :func:`topology` — connected-component labelling plus the Euler characteristic of the cubical
  complex (vertices - edges + faces - cubes): tunnels = components + cavities - Euler number.
* :func:`surface_topology` — the thesis's method after Chen et al. (ref. [88] of the thesis): the
  surface vertices of the voxel surface, the number of surface neighbours of each, and
  ``holes = 1 + (M5 + 2 M6 - M3) / 8`` per closed surface (see its docstring for the exact form).

Connectivity (both methods): **26-connected foreground, 6-connected background**.  A voxel is the
closed unit cube; the object is the union of its closed cubes.  Two closed cubes that share only a
vertex or an edge touch, so the object is 26-connected; a background voxel is connected to another
only through an open shared face (an edge or vertex shared with the object belongs to the object),
so the background is 6-connected.  This is the standard consistent (well-posed) pair in 3-D: the
digital Jordan theorem holds and Alexander duality relates the two sides — a closed 26-object's
tunnels equal its complement's tunnels and its cavities are the bounded 6-components of the
background — which is what makes ``tunnels = components + cavities - euler`` valid with the Euler
number of exactly that cubical complex.  (The pairs (26, 26) or (6, 6) are not consistent: a
diagonal pair of voxels would both separate and not separate the background.)

:class:`PunctureChecker` applies this per object of a :class:`~pliant.geometry.voxelgrid.VoxelGrid` and per
tree extension of a sampling planner, with a compact per-node state (the sorted indices of the
voxels removed so far from each watched object), so that every check covers the whole path from
the start — also after a rewiring changes a node's parent (re-extend from the new parent's state).
Each edge is swept from its parent's configuration, segment by segment, so checking a path edge by
edge and checking it whole sweep the same voxels: the planners' per-edge checks and their final check
of the path returned agree (issue 31).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from pliant.errors import ConfigError, DimensionError
from pliant.geometry import topology_kernels as kernels
from pliant.geometry.voxelgrid import VoxelGrid

__all__ = ["Topology", "SurfaceTopology", "euler_number", "topology", "surface_topology", "PunctureState",
           "PunctureChecker"]

_FOREGROUND = np.ones((3, 3, 3), dtype=bool)                     # 26-connectivity
_BACKGROUND = ndimage.generate_binary_structure(3, 1)            # 6-connectivity
#: removed sets whose puncture verdicts a checker remembers, and the most bytes their keys may take (8 per voxel);
#: the memory is cleared when either is reached
VERDICTS_KEPT = 2048
VERDICT_BYTES = 16 * 2**20


# --- the Euler-number method -------------------------------------------------------------------------


@dataclass(frozen=True)
class Topology:
    """Topological counts of a 3-D voxel object (thesis 4.3.4), with 26/6 connectivity.

    components: 26-connected foreground components (pieces of the object).
    cavities: voids — 6-connected background components that do not reach the grid's border.
    tunnels: holes (handles; the first Betti number) = components + cavities - euler.
    euler: Euler characteristic of the union of the closed voxel cubes.
    """

    components: int
    cavities: int
    tunnels: int
    euler: int


def _check_mask(mask: np.ndarray, name: str = "mask") -> np.ndarray:
    mask = np.asarray(mask)
    if mask.ndim != 3:
        raise DimensionError("must be a 3-D array (nx, ny, nz)", field=name, value=list(mask.shape))
    if mask.dtype != bool:
        if not np.issubdtype(mask.dtype, np.number):
            raise DimensionError("must be boolean or numeric", field=name, value=str(mask.dtype))
        mask = mask != 0
    return mask


def _pad(mask: np.ndarray) -> np.ndarray:
    padded = np.zeros(tuple(s + 2 for s in mask.shape), dtype=bool)
    padded[1:-1, 1:-1, 1:-1] = mask
    return padded


def _euler_padded(p: np.ndarray) -> int:
    """Euler number of the closed cubes of ``p``, whose outermost layer must be empty."""
    cubes = int(np.count_nonzero(p))
    if cubes == 0:
        return 0
    a = p[:-1] | p[1:]                       # x-neighbour pairs: faces normal to x
    b = a[:, :-1] | a[:, 1:]                 # ... and y-neighbours: edges along z
    c = a[:, :, :-1] | a[:, :, 1:]           # ... and z-neighbours: edges along y
    vertices = np.count_nonzero(b[:, :, :-1] | b[:, :, 1:])
    d = p[:, :-1] | p[:, 1:]                 # y-neighbour pairs: faces normal to y
    edges_x = np.count_nonzero(d[:, :, :-1] | d[:, :, 1:])
    faces_z = np.count_nonzero(p[:, :, :-1] | p[:, :, 1:])
    edges = edges_x + np.count_nonzero(c) + np.count_nonzero(b)
    faces = np.count_nonzero(a) + np.count_nonzero(d) + faces_z
    return int(vertices - edges + faces - cubes)


def euler_number(mask: np.ndarray) -> int:
    """Euler characteristic of a 3-D voxel object (thesis 4.3.4), dimensionless.

    The object is the union of the closed unit cubes of the ``True`` voxels of ``mask``
    ``(nx, ny, nz)`` (26-connected; the background 6-connected).  Counted exactly as
    vertices - edges + faces - cubes of that cubical complex (a lattice vertex, edge or face
    belongs to it when any voxel around it does), vectorised with numpy.
    """
    return _euler_padded(_pad(_check_mask(mask)))


def _topology_padded(p: np.ndarray) -> Topology:
    """:func:`topology` of ``p`` whose outermost layer is empty (so the outside is one 6-component)."""
    _, components = ndimage.label(p, structure=_FOREGROUND)
    if components == 0:
        return Topology(0, 0, 0, 0)
    _, background = ndimage.label(~p, structure=_BACKGROUND)
    cavities = background - 1                 # the component containing the empty border is the outside
    euler = _euler_padded(p)
    return Topology(int(components), int(cavities), int(components + cavities - euler), euler)


def topology(mask: np.ndarray) -> Topology:
    """Components, cavities (voids) and tunnels (holes) of a 3-D voxel object (thesis 4.3.4).

    ``mask`` ``(nx, ny, nz)``: bool (or numeric, nonzero = object).  Components are 26-connected,
    cavities are 6-connected background components not touching the border of ``mask`` (voxels
    outside ``mask`` are background), and tunnels = components + cavities - :func:`euler_number`
    (Alexander duality; see the module docstring for why the 26/6 pair is the consistent one).
    Examples: a solid box (1, 0, 0), a ring (1, 0, 1), a hollow shell (1, 1, 0), a plate with two
    holes (1, 0, 2), a cube with three orthogonal tunnels through its centre (1, 0, 5).
    """
    return _topology_padded(_pad(_check_mask(mask)))


# --- the surface-vertex method (Chen et al., thesis 4.3.4) --------------------------------------------

# A lattice vertex is the common corner of a 2x2x2 block of voxels; voxel (dx, dy, dz) of the block
# is bit 4 dx + 2 dy + dz of the block's code.  The lattice edge from the vertex along +a (-a) is
# surrounded by the 4 block voxels whose a-bit is 1 (0): its "ring".


def _block_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per block code (256): surface-vertex copies, degree counts, edge-copy owners, pinch flag."""
    copies = np.zeros(256, dtype=np.int64)
    degree_counts = np.zeros((256, 13), dtype=np.int64)
    owner = np.full((256, 6, 2), -1, dtype=np.int64)      # (code, direction 2a+s, ring component) -> copy
    pinch = np.zeros(256, dtype=bool)
    bits = [(b >> 2 & 1, b >> 1 & 1, b & 1) for b in range(8)]
    for code in range(256):
        fg = [bool(code >> b & 1) for b in range(8)]
        if all(fg) or not any(fg):
            continue
        # background components of the block, 6-adjacency (voxels differing in one coordinate)
        label = [-1] * 8
        n = 0
        for start in range(8):
            if fg[start] or label[start] >= 0:
                continue
            stack, label[start] = [start], n
            while stack:
                v = stack.pop()
                for axis in range(3):
                    w = v ^ (4 >> axis)
                    if not fg[w] and label[w] < 0:
                        label[w] = n
                        stack.append(w)
            n += 1
        copies[code] = n
        degree = [0] * n
        for a in range(3):
            others = [i for i in range(3) if i != a]
            for s in (0, 1):
                ring = sorted((b for b in range(8) if bits[b][a] == s), key=lambda b: 2 * bits[b][others[0]]
                              + bits[b][others[1]])               # ring position 2 b + c, same seen from both ends
                ring_fg = [fg[b] for b in ring]
                if all(ring_fg) or not any(ring_fg):
                    continue
                # background components of the ring (positions 0-1-3-2-0 form the cycle), ordered by position
                seen, r = set(), 0
                for pos in range(4):
                    if ring_fg[pos] or pos in seen:
                        continue
                    comp, stack = {pos}, [pos]
                    while stack:
                        q = stack.pop()
                        for nb in (q ^ 1, q ^ 2):
                            if not ring_fg[nb] and nb not in comp:
                                comp.add(nb)
                                stack.append(nb)
                    seen |= comp
                    copy = label[ring[pos]]
                    owner[code, 2 * a + s, r] = copy
                    degree[copy] += 1
                    r += 1
        for k in degree:
            degree_counts[code, k] += 1
        on = [b for b in range(8) if fg[b]]
        pinch[code] = len(on) == 2 and on[0] ^ on[1] == 7       # two voxels sharing only this vertex
    return copies, degree_counts, owner, pinch


_COPIES, _DEGREE_COUNTS, _OWNER, _PINCH = _block_tables()


@dataclass(frozen=True)
class SurfaceTopology:
    """Counts of the surface-vertex method (thesis 4.3.4, after Chen et al.).

    holes: tunnels of the object (the sum of the genera of its closed surfaces).
    surfaces: closed surface components (= components + cavities of :class:`Topology`).
    degree_counts: ``M[k]`` = surface vertices with ``k`` surface neighbours, ``k = 0 .. 12`` (only
        3 .. 7 occur; 7 only where a surface edge is duplicated, see :func:`surface_topology`).
    pinches: vertices where two voxels of the object meet at a single corner only.
    """

    holes: int
    surfaces: int
    degree_counts: tuple[int, ...]
    pinches: int


def surface_topology(mask: np.ndarray) -> SurfaceTopology:
    """Holes and surface components of a 3-D voxel object from its surface vertices (thesis 4.3.4).

    The thesis's second method (Chen et al., ref. [88]): extract the surface vertices of the voxel
    surface, count for each how many surface vertices it is connected to (``k``), let ``M_k`` be
    the number of vertices with ``k`` such neighbours, and

        n_holes = 1 + (M5 + 2 M6 - M3) / 8.

    As printed, that formula is the genus of **one** closed quadrilateral surface (Gauss-Bonnet:
    each face has 4 edges and each edge 2 faces, so chi = sum_v (1 - k_v / 4) = (M3 - M5 - 2 M6) / 4,
    genus = 1 - chi / 2).  An object with several pieces or with voids is bounded by several closed
    surfaces (one outer surface per piece, one per void), so the correct total is

        holes = S + (M5 + 2 M6 + 3 M7 - M3) / 8 + P / 2       [= S + sum_k (k - 4) M_k / 8 + P / 2]

    with ``S`` the number of connected surface components (the thesis's surface connectivity) and
    ``P`` the pinch vertices below.  The surface is that of the 26/6 object (module docstring): a
    lattice vertex or edge of the surface is duplicated once per 6-connected background component
    around it (two voxels sharing only an edge give two surface edges there), which keeps the
    surface a closed 2-manifold except where two object voxels meet at a single vertex and nothing
    else of the 2x2x2 block is object.  There the object is joined through a neck, whose surface is
    an annulus and not a disc, so that vertex counts -3/2 in chi, not the -1/2 of its 6 neighbours:
    hence ``+ P / 2``.  Duplicated edges are also why a vertex can have 7 neighbours (at a corner
    shared by a face-adjacent pair of voxels and a third voxel that shares only an edge with one of
    them and only that corner with the other); the thesis lists at most 6, hence no ``M7`` in its formula.  With these
    corrections the result equals :func:`topology`'s tunnels for every mask (property-tested), and
    the thesis's formula is the case ``S = 1, P = 0, M7 = 0`` (one closed surface, i.e. a single
    piece without voids, and no single-vertex contact or 7-neighbour vertex).

    ``mask`` ``(nx, ny, nz)``: bool (or numeric, nonzero = object); outside it is background.
    """
    p = _pad(_check_mask(mask))
    code = np.zeros(tuple(s - 1 for s in p.shape), dtype=np.uint8)
    nx, ny, nz = code.shape
    for b in range(8):
        dx, dy, dz = b >> 2 & 1, b >> 1 & 1, b & 1
        code |= p[dx:dx + nx, dy:dy + ny, dz:dz + nz].astype(np.uint8) << np.uint8(b)
    hist = np.bincount(code.ravel(), minlength=256)
    m = hist @ _DEGREE_COUNTS
    pinches = int(hist @ _PINCH)
    copies = _COPIES[code]
    total = int(copies.sum())
    if total == 0:
        return SurfaceTopology(0, 0, tuple(int(v) for v in m), 0)
    offset = (np.cumsum(copies.ravel()) - copies.ravel()).reshape(code.shape)
    rows, cols = [], []
    for a in range(3):
        lo = tuple(slice(0, -1) if i == a else slice(None) for i in range(3))
        hi = tuple(slice(1, None) if i == a else slice(None) for i in range(3))
        c_lo, c_hi = code[lo].ravel(), code[hi].ravel()
        o_lo, o_hi = offset[lo].ravel(), offset[hi].ravel()
        for r in range(2):
            u = _OWNER[c_lo, 2 * a + 1, r]
            keep = u >= 0
            w = _OWNER[c_hi[keep], 2 * a, r]
            rows.append(o_lo[keep] + u[keep])
            cols.append(o_hi[keep] + w)
    rows_a, cols_a = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(rows_a), dtype=np.int8), (rows_a, cols_a)), shape=(total, total))
    surfaces, _ = connected_components(graph, directed=False)
    weighted = int(np.dot(np.arange(13) - 4, m))        # sum_k (k - 4) M_k = M5 + 2 M6 + 3 M7 - M3
    numerator = 8 * surfaces + weighted + 4 * pinches
    if numerator % 8:
        raise ArithmeticError(f"surface_topology: 8 S + sum (k - 4) M_k + 4 P = {numerator} is not a multiple "
                              "of 8 (the surface is not a closed 2-manifold; please report this mask)")
    return SurfaceTopology(numerator // 8, int(surfaces), tuple(int(v) for v in m), pinches)


# --- puncture and cut detection ------------------------------------------------------------------------


def arc_margin(scene, space) -> float:
    """The :class:`PunctureChecker` ``arc_margin`` for a robot: 0 for a rigid body that only translates (its
    points move on the chords the checker traverses), 1/8 voxel for one that rotates (SE(2), SE(3), jointed arms:
    between samples a voxel apart a point's arc leaves the chord by at most 1/8 voxel)."""
    translating = getattr(scene.robot, "kind", "") == "rigid" and space.kind == "rn"
    return 0.0 if translating else 0.125


@dataclass(frozen=True)
class PunctureState:
    """What a tree node stores for puncture checking (thesis 4.3.4).

    removed: one sorted ``int64`` array per watched object (in :attr:`PunctureChecker.names` order):
        the indices, flat in the object's cropped box, of the object's voxels swept by the robot on
        the path from the start to this node.
    """

    removed: tuple[np.ndarray, ...]

    @property
    def removed_count(self) -> int:
        """Total number of object voxels swept so far."""
        return int(sum(len(r) for r in self.removed))


class PunctureChecker:
    """Puncture and cut detection for sampling planners (thesis 4.3.4), incremental per edge.

    ``grid``: the scene's :class:`~pliant.geometry.voxelgrid.VoxelGrid`.  ``body_points``: maps configurations
    ``(n, d)`` to robot body points ``(n, m, 3)`` in metres (e.g. ``robot.body_points``); the voxels
    containing a body point are the voxels the robot occupies.  ``watch``: which objects to check —
    ``"enterable"`` (default: every object with a voxel of finite deformability > 0, i.e. one the
    robot may enter), ``"all"``, or a sequence of object names.

    A planner keeps :meth:`initial_state` at the root and, for an edge from a node to a new one,
    calls :meth:`extend` with the parent's state, the interpolated configurations of the edge after the
    parent and ``start=`` the parent's configuration (so the step out of the parent is swept too); it stores
    the returned state at the new node when ``ok``.  The state holds every voxel swept since the start, so
    each check covers the whole path (a rewired node is re-extended from its new parent's state), and the
    union of the edges' sweeps is exactly the sweep of the whole path: :meth:`check` on the path returned
    (the planners' final check, after any post-processing) gives the same verdict as the edges did.

    Each object is checked on its bounding box plus a one-voxel empty margin, against the object at
    the start: more tunnels than its initial :class:`Topology` is a puncture (a hole through the
    object); one of its own voids connected to the outside or to another of its voids is a puncture
    (a void opened); one of its own pieces falling apart is a cut.  Voids and pieces are followed one
    by one (a representative voxel per void, the initial piece of every voxel), not only counted, so
    a sweep that also carves a closed cavity into a thick wall, or sweeps a whole piece away, cannot
    hide a void it opened or a piece it split.  A piece entirely inside the swept volume and a void
    swept inside the object are not flagged.
    """

    def __init__(self, grid: VoxelGrid, body_points: Callable[[np.ndarray], np.ndarray],
                 watch: str | Sequence[str] = "enterable", arc_margin: float = 0.0) -> None:
        self.grid = grid
        self.body_points = body_points
        if not (np.isfinite(arc_margin) and 0.0 <= arc_margin < 0.5):
            raise ConfigError("must be in [0, 0.5) voxels", field="arc_margin", value=arc_margin)
        #: voxels added around each swept segment (in voxels): body points of a rotating robot move on arcs, which
        #: leave the chord between two samples a voxel apart by at most 1/8 voxel (for points a voxel or more
        #: from the rotation axis); 0 for a translating robot, whose points move on the chords exactly
        self.arc_margin = float(arc_margin)
        self._shape = np.array(grid.shape, dtype=np.int64)
        names = list(grid.object_names)
        if isinstance(watch, str):
            if watch not in ("enterable", "all"):
                raise ConfigError("must be 'enterable', 'all' or a list of object names", field="watch",
                                  value=watch)
            ids = list(range(len(names)))
        else:
            ids = []
            for name in watch:
                if name not in names:
                    raise ConfigError(f"unknown object (objects: {names})", field="watch", value=name)
                ids.append(names.index(name))
        self.ids: list[int] = []
        self._lower: list[np.ndarray] = []
        self._masks: list[np.ndarray] = []
        self.initial: list[Topology] = []
        self._voids: list[np.ndarray] = []
        self._pieces: list[np.ndarray] = []
        for k in ids:
            voxels = grid.object_id == k
            if not voxels.any():
                continue
            if watch == "enterable":
                d = grid.deformability[voxels]
                if not np.any(np.isfinite(d) & (d > 0)):
                    continue
            where = np.argwhere(voxels)
            lo, hi = where.min(axis=0), where.max(axis=0) + 1
            crop = np.zeros(tuple(hi - lo + 2), dtype=bool)
            crop[1:-1, 1:-1, 1:-1] = voxels[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
            self.ids.append(k)
            self._lower.append(lo - 1)                       # grid index of the crop's voxel (0, 0, 0)
            self._masks.append(crop)
            self.initial.append(_topology_padded(crop))
            # one voxel of each initial void, and the initial piece of every voxel: _judge follows them one by one
            background, _ = ndimage.label(~crop, structure=_BACKGROUND)
            labels = background.ravel()
            _, first = np.unique(labels, return_index=True)
            self._voids.append(np.sort(first[(labels[first] != 0) & (labels[first] != labels[0])]))
            self._pieces.append(ndimage.label(crop, structure=_FOREGROUND)[0].ravel())
        self.names = [names[k] for k in self.ids]
        #: the verdicts of :meth:`_judge` by object and removed set: a tree's sibling edges and a rewired subtree
        #: meet the same sets again (about half the calls in Table 4.2's RRT* plans); cleared when full
        self._verdicts: dict[tuple[int, bytes], tuple[str, ...]] = {}
        self._verdict_bytes = 0
        # slot of the watched object at each voxel of the grid padded by one voxel (-1: none), so that
        # a body point maps to its object with one clipped index computation and one lookup
        slots = np.full(tuple(self._shape + 2), -1, dtype=np.int16)
        for slot, k in enumerate(self.ids):
            slots[1:-1, 1:-1, 1:-1][grid.object_id == k] = slot
        self._slots = slots.ravel()

    def initial_state(self) -> PunctureState:
        """The state of the start node (thesis 4.3.4): no voxel removed from any watched object."""
        return PunctureState(tuple(np.zeros(0, dtype=np.int64) for _ in self.ids))

    def occupied(self, configurations: np.ndarray) -> list[np.ndarray]:
        """Per watched object, the sorted crop-flat indices of its voxels the robot occupies or sweeps (thesis
        4.3.4).

        ``configurations``: ``(n, d)`` or ``(d,)``.  One configuration occupies the voxels that contain a body
        point.  Consecutive configurations sweep, for each body point, every voxel its segment between them enters
        (a conservative traversal: the segment is cut into pieces at most one voxel long and each piece takes the
        voxels its bounding box, grown by :attr:`arc_margin`, overlaps), so a diagonal move through a voxel corner
        takes the voxels beside the corner too and no finer sampling of the motion reaches a voxel the check left
        out.
        """
        q = np.asarray(configurations, dtype=np.float64)
        if q.ndim == 1:
            q = q[None]
        if q.ndim != 2 or not np.all(np.isfinite(q)):
            raise DimensionError("must be finite configurations (n, d) or (d,)", field="configurations",
                                 value=list(q.shape) if q.ndim != 2 else "non-finite entries")
        out = [np.zeros(0, dtype=np.int64) for _ in self.ids]
        if not self.ids or len(q) == 0:
            return out
        pts = np.asarray(self.body_points(q), dtype=np.float64)
        if pts.ndim < 2 or pts.shape[-1] != 3:
            raise DimensionError("body_points must return points (n, m, 3)", field="body_points",
                                 value=list(pts.shape))
        flat = self._swept_cells(pts)
        slot_of = self._slots[flat]
        hit = slot_of >= 0
        if not hit.any():
            return out
        flat, slot_of = flat[hit], slot_of[hit]
        _, py, pz = self._shape + 2
        for slot in np.unique(slot_of):
            cells = np.unique(flat[slot_of == slot])
            # padded-grid (i + 1, j + 1, k + 1) -> crop-local (i - lo), with lo the crop's lower corner
            i, rest = np.divmod(cells, py * pz)
            j, k = np.divmod(rest, pz)
            lo = self._lower[slot] + 1
            _, cy, cz = self._masks[slot].shape
            out[slot] = ((i - lo[0]) * cy + (j - lo[1])) * cz + (k - lo[2])
        return out

    def _swept_cells(self, pts: np.ndarray) -> np.ndarray:
        """Flat padded-grid indices of the voxels the body points ``(n, m, 3)`` occupy (n = 1) or sweep between
        consecutive configurations (see :meth:`occupied`), with repetitions; one compiled pass
        (:func:`pliant.geometry.topology_kernels.swept_cells`).

        Each segment (one body point between two consecutive configurations) is cut into its own number of
        pieces, ``ceil`` of its largest per-axis displacement in voxels, so the cells of a path are the union of
        the cells of its segments: checking a path edge by edge (:meth:`extend` with ``start``) and checking it
        whole (:meth:`check`) sweep exactly the same voxels."""
        coords = (pts - self.grid.lower) / self.grid.resolution            # in voxels, (n, m, 3)
        return kernels.swept_cells(np.ascontiguousarray(coords, dtype=np.float64), self._shape,
                                   float(self.arc_margin))

    def extend(self, state: PunctureState, configurations: np.ndarray,
               start: np.ndarray | None = None) -> tuple[PunctureState, bool, str]:
        """Sweep the robot through ``configurations`` from ``state``; check for puncture and cut (thesis 4.3.4).

        ``configurations``: ``(n, d)`` (or one ``(d,)``), the interpolated configurations of the edge.
        ``start`` ``(d,)``: the configuration the edge leaves from (the parent node's).  Pass it: the motion from
        ``start`` to ``configurations[0]`` is then swept like every other step of the edge.  Without it only the
        voxels ``configurations[0]`` occupies are taken, so a step across a voxel corner at the start of the edge
        is not swept -- what a planner that gave the states after the parent alone used to miss.
        Returns ``(new_state, ok, reason)``: ``reason`` is ``""`` when ``ok``, else names each object
        at fault and what changed (``"puncture: ..."`` or ``"cut: ..."``).  Objects that
        gained no removed voxel are not recounted (they were valid at ``state``).
        """
        return self.extend_swept(state, self.sweep(configurations, start))

    def sweep(self, configurations: np.ndarray, start: np.ndarray | None = None) -> list[np.ndarray]:
        """Per watched object, the crop-flat voxels an edge sweeps (:meth:`occupied` of ``start`` followed by
        ``configurations``; see :meth:`extend`).  They depend on the edge alone, not on the state it extends, so a
        planner that re-derives the states below a rewired node may keep each edge's sweep and pass it to
        :meth:`extend_swept` instead of sweeping the edge again."""
        if start is not None:
            q = np.asarray(configurations, dtype=np.float64)
            q = q[None] if q.ndim == 1 else q
            s0 = np.asarray(start, dtype=np.float64)
            if s0.ndim != 1 or q.ndim != 2 or s0.shape[0] != q.shape[1]:
                raise DimensionError(f"must be one configuration of the {q.shape[-1]} coordinates of the edge",
                                     field="start", value=list(s0.shape))
            configurations = np.vstack([s0[None], q])
        return self.occupied(configurations)

    def extend_swept(self, state: PunctureState, new: list[np.ndarray]) -> tuple[PunctureState, bool, str]:
        """:meth:`extend` from an edge's :meth:`sweep`: ``(new_state, ok, reason)``."""
        if len(state.removed) != len(self.ids):
            raise DimensionError(f"state has {len(state.removed)} objects, the checker watches {len(self.ids)}",
                                 field="state", value=len(state.removed))
        if len(new) != len(self.ids):
            raise DimensionError(f"the sweep has {len(new)} objects, the checker watches {len(self.ids)}",
                                 field="swept", value=len(new))
        removed = list(state.removed)
        problems = []
        for slot, fresh in enumerate(new):
            if len(fresh) == 0:
                continue
            merged = np.union1d(removed[slot], fresh)
            if len(merged) == len(removed[slot]):
                continue
            removed[slot] = merged
            problems.extend(self._judge(slot, merged))
        return PunctureState(tuple(removed)), not problems, "; ".join(problems)

    def check(self, configurations: np.ndarray) -> tuple[bool, str]:
        """Check a whole path ``(n, d)`` from the start: ``(ok, reason)``.

        The path is swept exactly as :meth:`extend` sweeps its edges (each step between consecutive
        configurations conservatively), so the verdict here is that of the last edge when the path is extended
        edge by edge, each with its ``start``: a path whose edges all passed passes here too.  Consecutive
        configurations a check step apart (a voxel or less) keep the arcs of a rotating robot within
        :attr:`arc_margin` of the chords."""
        _, ok, reason = self.extend(self.initial_state(), configurations)
        return ok, reason

    def topologies(self, state: PunctureState) -> list[Topology]:
        """The :class:`Topology` of each watched object with ``state``'s voxels removed (thesis 4.3.4)."""
        return [self._count(slot, r) for slot, r in enumerate(state.removed)]

    def _count(self, slot: int, removed: np.ndarray) -> Topology:
        mask = self._masks[slot].copy()
        mask.ravel()[removed] = False
        return _topology_padded(mask)

    def _judge(self, slot: int, removed: np.ndarray) -> list[str]:
        """:meth:`_judge_anew`, remembered for up to :data:`VERDICTS_KEPT` sets whose keys take up to
        :data:`VERDICT_BYTES` (``removed``: sorted, as :meth:`extend_swept` builds it with ``union1d``)."""
        key = (slot, np.ascontiguousarray(removed, dtype=np.int64).tobytes())
        verdict = self._verdicts.get(key)
        if verdict is None:
            if len(self._verdicts) >= VERDICTS_KEPT or self._verdict_bytes + len(key[1]) > VERDICT_BYTES:
                self._verdicts.clear()
                self._verdict_bytes = 0
            verdict = self._verdicts[key] = tuple(self._judge_anew(slot, removed))
            self._verdict_bytes += len(key[1])
        return list(verdict)

    def _judge_anew(self, slot: int, removed: np.ndarray) -> list[str]:
        """What the removal of ``removed`` did wrong to object ``slot``: puncture (a hole gained, one of its own
        voids opened to the outside or joined to another) or cut (one of its own pieces split).

        Voids and pieces are followed one by one, not only counted: a count can hide a change when the same
        sweep also carves a new cavity inside a thick wall (cavities 1 -> 0 -> 1) or removes a whole piece while
        it splits another (components 2 -> 3 -> 2).  Opening a void is monotone in the swept voxels (removing more
        never closes it again), so a conservative sweep never passes a path that a finer sweep finds opening one.
        """
        start, name = self.initial[slot], self.names[slot]
        mask = self._masks[slot].copy()
        flat = mask.ravel()
        flat[removed] = False
        _, components = ndimage.label(mask, structure=_FOREGROUND)
        background, regions = ndimage.label(~mask, structure=_BACKGROUND)
        cavities = regions - 1 if components else 0       # the crop's empty margin is the outside, label 1
        euler = _euler_padded(mask)
        tunnels = components + cavities - euler if components else 0
        out = []
        if tunnels > start.tunnels:
            out.append(f"puncture: object {name!r} gained a hole (tunnels {start.tunnels} -> {tunnels})")
        seeds = self._voids[slot]
        if len(seeds):
            where = background.ravel()[seeds]
            outside = background.ravel()[0]
            opened = int(np.count_nonzero(where == outside))
            if opened:
                out.append(f"puncture: object {name!r} had a void opened to the outside ({opened} of {len(seeds)}; "
                           f"cavities {start.cavities} -> {cavities})")
            inner = where[where != outside]
            if len(np.unique(inner)) < len(inner):
                out.append(f"puncture: object {name!r} had two of its voids joined (cavities {start.cavities} -> "
                           f"{cavities})")
        left = np.unique(self._pieces[slot][flat])           # initial pieces with a voxel left
        if components > len(left):
            if components > start.components:
                out.append(f"cut: object {name!r} split into {components} pieces (was {start.components})")
            else:
                out.append(f"cut: object {name!r} had a piece split ({components} pieces from {len(left)} of its "
                           f"{start.components}; the others swept away)")
        return out
