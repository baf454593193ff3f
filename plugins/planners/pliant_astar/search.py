"""The A* search kernel (numba) over a 26-connected voxel lattice.

Objective of a path ``s_0 .. s_k`` (thesis Algorithm 1, section 3.2.3)::

    f = (1 - p) * length + p * deformation,   deformation = sum_{j=0..k} c(s_j)

with ``length`` in voxels (steps of 1, sqrt 2, sqrt 3) and ``c`` the state cost (the start's cost
included).  As an edge weight, moving ``s -> s'`` costs ``(1 - p) |s' - s| + p c(s')``; the
heuristic ``(1 - p) * |goal - s|`` is consistent (Euclidean distance obeys the triangle inequality
and ``c >= 0``), so the first time the goal is popped its ``g`` is optimal: the search is exact.
NaN state costs are impassable.
"""

from __future__ import annotations

import numba
import numpy as np
from pliant.api import checkpoint

_OFFSETS = np.array([(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                     if (dx, dy, dz) != (0, 0, 0)], dtype=np.int64)
_STEPS = np.sqrt(np.sum(_OFFSETS * _OFFSETS, axis=1)).astype(np.float64)


@numba.njit(cache=True, nogil=True)
def _push(heap_f, heap_h, heap_i, size, f, h, i):
    k = size
    heap_f[k], heap_h[k], heap_i[k] = f, h, i
    while k > 0:
        parent = (k - 1) >> 1
        pf, ph, pi = heap_f[parent], heap_h[parent], heap_i[parent]
        if f < pf or (f == pf and (h < ph or (h == ph and i < pi))):
            heap_f[k], heap_h[k], heap_i[k] = pf, ph, pi
            k = parent
        else:
            break
    heap_f[k], heap_h[k], heap_i[k] = f, h, i
    return size + 1


@numba.njit(cache=True, nogil=True)
def _pop(heap_f, heap_h, heap_i, size):
    top = heap_i[0]
    size -= 1
    f, h, i = heap_f[size], heap_h[size], heap_i[size]
    k = 0
    while True:
        child = 2 * k + 1
        if child >= size:
            break
        right = child + 1
        if right < size:
            cf, ch, ci = heap_f[child], heap_h[child], heap_i[child]
            rf, rh, ri = heap_f[right], heap_h[right], heap_i[right]
            if rf < cf or (rf == cf and (rh < ch or (rh == ch and ri < ci))):
                child = right
        cf, ch, ci = heap_f[child], heap_h[child], heap_i[child]
        if cf < f or (cf == f and (ch < h or (ch == h and ci < i))):
            heap_f[k], heap_h[k], heap_i[k] = cf, ch, ci
            k = child
        else:
            break
    if size > 0:
        heap_f[k], heap_h[k], heap_i[k] = f, h, i
    return top, size


@numba.njit(cache=True, nogil=True)
def astar_start(costs, nx, ny, nz, start, goal, p, parent, g, closed, heap_f, heap_h, heap_i, meta):
    """Initialise a search's state (``g``, ``closed``, the heap arrays, ``parent``; ``meta = [heap size, expanded]``)
    with the start on the open list."""
    n = nx * ny * nz
    for k in range(n):
        parent[k] = -1
        g[k] = np.inf
        closed[k] = False
    gx, gy, gz = goal // (ny * nz), (goal // nz) % ny, goal % nz
    w_len = 1.0 - p
    g[start] = p * costs[start]
    sx, sy, sz = start // (ny * nz), (start // nz) % ny, start % nz
    h0 = w_len * np.sqrt((sx - gx) ** 2 + (sy - gy) ** 2 + (sz - gz) ** 2)
    meta[0] = _push(heap_f, heap_h, heap_i, 0, g[start] + h0, h0, start)
    meta[1] = 0


@numba.njit(cache=True, nogil=True)
def astar_expand(costs, nx, ny, nz, goal, p, offsets, steps, parent, g, closed, heap_f, heap_h, heap_i, meta,
                 limit):
    """Expand at most ``limit`` cells of a search started by :func:`astar_start`; returns ``(state, objective)``:
    1 the goal was reached (``objective`` optimal), 0 the open list is exhausted, -1 the limit was reached (call
    again to go on: the search continues exactly where it stopped)."""
    gx, gy, gz = goal // (ny * nz), (goal // nz) % ny, goal % nz
    w_len = 1.0 - p
    size = meta[0]
    expanded = meta[1]
    done = 0
    while size > 0:
        if done >= limit:
            meta[0], meta[1] = size, expanded
            return -1, np.inf
        s, size = _pop(heap_f, heap_h, heap_i, size)
        if closed[s]:
            continue
        closed[s] = True
        expanded += 1
        done += 1
        if s == goal:
            meta[0], meta[1] = size, expanded
            return 1, g[s]
        x, y, z = s // (ny * nz), (s // nz) % ny, s % nz
        for k in range(offsets.shape[0]):
            u, v, w = x + offsets[k, 0], y + offsets[k, 1], z + offsets[k, 2]
            if u < 0 or u >= nx or v < 0 or v >= ny or w < 0 or w >= nz:
                continue
            t = (u * ny + v) * nz + w
            c = costs[t]
            if closed[t] or np.isnan(c):
                continue
            cand = g[s] + w_len * steps[k] + p * c
            if cand < g[t]:
                g[t] = cand
                parent[t] = s
                h = w_len * np.sqrt((u - gx) ** 2 + (v - gy) ** 2 + (w - gz) ** 2)
                size = _push(heap_f, heap_h, heap_i, size, cand + h, h, t)
    meta[0], meta[1] = size, expanded
    return 0, np.inf


#: cells expanded between two budget checks (a few milliseconds of search)
CHUNK = 50_000


def astar_kernel(costs, nx, ny, nz, start, goal, p, offsets, steps, parent, chunk: int = CHUNK):
    """Search ``costs`` (flat C-order ``nx*ny*nz``, NaN impassable) from flat ``start`` to ``goal``.

    Fills ``parent`` (-1 = none) and returns ``(found, expanded, objective)``.  The search runs in chunks of
    ``chunk`` expansions with :func:`pliant.termination.checkpoint` between them, so that a planner's time budget
    can stop a long search (:class:`~pliant.termination.BudgetExpired`); the result does not depend on ``chunk``.
    """
    n = nx * ny * nz
    g = np.empty(n)
    closed = np.empty(n, dtype=np.bool_)
    cap = 27 * n + 1
    heap_f = np.empty(cap)
    heap_h = np.empty(cap)
    heap_i = np.empty(cap, dtype=np.int64)
    meta = np.zeros(2, dtype=np.int64)
    astar_start(costs, nx, ny, nz, start, goal, p, parent, g, closed, heap_f, heap_h, heap_i, meta)
    while True:
        state, objective = astar_expand(costs, nx, ny, nz, goal, p, offsets, steps, parent, g, closed, heap_f,
                                        heap_h, heap_i, meta, chunk)
        if state >= 0:
            return state == 1, int(meta[1]), objective
        checkpoint()


def search(costs: np.ndarray, start: tuple[int, int, int], goal: tuple[int, int, int], p: float,
           chunk: int | None = None):
    """A* on a cost field ``(nx, ny, nz)``; returns ``(cells (k, 3) or None, expanded, objective)``.  Inside a
    :meth:`pliant.termination.Condition.interruptible` block it raises
    :class:`~pliant.termination.BudgetExpired` when the budget ends mid-search (checked every ``chunk`` expansions,
    default :data:`CHUNK`)."""
    nx, ny, nz = costs.shape
    flat = np.ascontiguousarray(costs, dtype=np.float64).reshape(-1)
    s = (start[0] * ny + start[1]) * nz + start[2]
    t = (goal[0] * ny + goal[1]) * nz + goal[2]
    parent = np.empty(flat.size, dtype=np.int64)
    found, expanded, objective = astar_kernel(flat, nx, ny, nz, s, t, float(p), _OFFSETS, _STEPS, parent,
                                              chunk or CHUNK)
    if not found:
        return None, int(expanded), float("inf")
    chain = [t]
    while chain[-1] != s:
        chain.append(int(parent[chain[-1]]))
    idx = np.array(chain[::-1], dtype=np.int64)
    cells = np.column_stack([idx // (ny * nz), (idx // nz) % ny, idx % nz])
    return cells, int(expanded), float(objective)


def path_length(cells: np.ndarray) -> float:
    """Length of a cell path in voxels."""
    return float(np.sum(np.linalg.norm(np.diff(cells, axis=0), axis=1))) if len(cells) > 1 else 0.0


def path_deformation(costs: np.ndarray, cells: np.ndarray) -> float:
    """Accumulated state cost along a cell path, the start's included (thesis DEFORM)."""
    return float(np.sum(costs[cells[:, 0], cells[:, 1], cells[:, 2]]))
