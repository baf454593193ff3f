"""Compiled (numba) kernels of the hot paths of TS-RRT's search: IN_COLLISION for a batch of arrangements, the
validity of a batch of single-object steps (IN_COLLISION at the end and halfway, the paddle's sweep, the scene's
bounds), and the task cost.  They compute what the batched numpy code of :mod:`pliant_tsrrt.geometry`,
:meth:`pliant_tsrrt.search.ObjectSpace.valid_steps` and :mod:`pliant_tsrrt.cost` computes (the same tests and
formulas, one arrangement at a time in a compiled loop instead of many small numpy operations); the tests compare
them on random batches.  Profiled (cProfile, 3000 tree iterations and the improvement phase to its end, seed 0):
the numpy versions spent most of their time in the overhead of small array operations.

Footprints: ``kind`` ``(k,)`` (0 box, 1 circle), ``half`` ``(k, 2)``; a circle's radius is ``half[0]``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

BOX, CIRCLE = 0, 1


@numba.njit(cache=True, nogil=True)
def _box_box(xa, ya, ta, hax, hay, xb, yb, tb, hbx, hby, margin):
    ca, sa = math.cos(ta), math.sin(ta)
    cb, sb = math.cos(tb), math.sin(tb)
    dx, dy = xb - xa, yb - ya
    cross_c = abs(ca * cb + sa * sb)
    cross_s = abs(sa * cb - ca * sb)
    m2 = 2.0 * margin
    if abs(dx * ca + dy * sa) - hax - (hbx * cross_c + hby * cross_s) >= m2:
        return False
    if abs(-dx * sa + dy * ca) - hay - (hbx * cross_s + hby * cross_c) >= m2:
        return False
    if abs(dx * cb + dy * sb) - hbx - (hax * cross_c + hay * cross_s) >= m2:
        return False
    if abs(-dx * sb + dy * cb) - hby - (hax * cross_s + hay * cross_c) >= m2:
        return False
    return True


@numba.njit(cache=True, nogil=True)
def _box_circle(xb, yb, tb, hbx, hby, xc, yc, r, margin):
    dx, dy = xc - xb, yc - yb
    c, s = math.cos(tb), math.sin(tb)
    lx = c * dx + s * dy
    ly = -s * dx + c * dy
    nx = min(max(lx, -hbx), hbx)
    ny = min(max(ly, -hby), hby)
    return math.sqrt((lx - nx) ** 2 + (ly - ny) ** 2) < r + 2.0 * margin


@numba.njit(cache=True, nogil=True)
def _overlap(ka, xa, ya, ta, hax, hay, kb, xb, yb, tb, hbx, hby, margin):
    if ka == BOX and kb == BOX:
        return _box_box(xa, ya, ta, hax, hay, xb, yb, tb, hbx, hby, margin)
    if ka == CIRCLE and kb == CIRCLE:
        return math.sqrt((xa - xb) ** 2 + (ya - yb) ** 2) < hax + hbx + 2.0 * margin
    if ka == BOX:
        return _box_circle(xa, ya, ta, hax, hay, xb, yb, hbx, margin)
    return _box_circle(xb, yb, tb, hbx, hby, xa, ya, hax, margin)


@numba.njit(cache=True, nogil=True)
def _off_table(kind, hx, hy, x, y, t, table, margin):
    if kind == CIRCLE:
        ex, ey = hx, hx
    else:
        c, s = abs(math.cos(t)), abs(math.sin(t))
        ex, ey = c * hx + s * hy, s * hx + c * hy
    return (x - ex < table[0] + margin or y - ey < table[1] + margin or x + ex > table[2] - margin
            or y + ey > table[3] - margin)


@numba.njit(cache=True, nogil=True)
def _object_bad(s, o, kind, half, obs_kind, obs_half, obs_poses, table, margin):
    """Whether object ``o`` of arrangement ``s`` ``(k, 3)`` leaves the table or overlaps an obstacle or an object of
    a higher index than ``o`` (or any other object when ``o`` is negative: then ``-o - 1`` is checked against all)."""
    every = o < 0
    if every:
        o = -o - 1
    x, y, t = s[o, 0], s[o, 1], s[o, 2]
    if _off_table(kind[o], half[o, 0], half[o, 1], x, y, t, table, margin):
        return True
    for j in range(s.shape[0]):
        if j == o or (not every and j < o):
            continue
        if _overlap(kind[o], x, y, t, half[o, 0], half[o, 1], kind[j], s[j, 0], s[j, 1], s[j, 2], half[j, 0],
                    half[j, 1], margin):
            return True
    for j in range(obs_poses.shape[0]):
        if _overlap(kind[o], x, y, t, half[o, 0], half[o, 1], obs_kind[j], obs_poses[j, 0], obs_poses[j, 1],
                    obs_poses[j, 2], obs_half[j, 0], obs_half[j, 1], margin):
            return True
    return False


@numba.njit(cache=True, nogil=True)
def in_collision(states, kind, half, obs_kind, obs_half, obs_poses, table, margin):
    """Bool ``(n,)``: IN_COLLISION of arrangements ``(n, k, 3)`` (:meth:`CollisionChecker.in_collision`)."""
    n, k = states.shape[0], states.shape[1]
    out = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        s = states[i]
        for o in range(k):
            if _object_bad(s, o, kind, half, obs_kind, obs_half, obs_poses, table, margin):
                out[i] = True
                break
    return out


@numba.njit(cache=True, nogil=True)
def valid_steps(before, after, objs, prims, means, kind, half, obs_kind, obs_half, obs_poses, table, margin,
                sweep_local, sweep_phi, sweep_half, bounds, moved_only):
    """Bool ``(m,)``: :meth:`ObjectSpace.valid_steps` -- the arrangement after each step and the one with the moved
    object halfway are free of collisions (margin), and the paddle's swept box (``sweep_local`` ``(k, 6, 2)``: its
    centre in the pushed object's frame, ``sweep_phi`` its heading there, ``sweep_half`` its half extents) touches
    no other object nor obstacle (no margin) and stays inside ``bounds``.  ``moved_only``: the arrangements before
    the steps are known to be free of collisions, so only the moved object's pairs are checked after the step."""
    m, k = before.shape[0], before.shape[1]
    out = np.zeros(m, dtype=np.bool_)
    mid = np.empty((k, 3))
    for i in range(m):
        a = after[i]
        o, p = objs[i], prims[i]
        bad = False
        if moved_only:
            bad = _object_bad(a, -o - 1, kind, half, obs_kind, obs_half, obs_poses, table, margin)
        else:
            for q in range(k):
                if _object_bad(a, q, kind, half, obs_kind, obs_half, obs_poses, table, margin):
                    bad = True
                    break
        if bad:
            continue
        b = before[i]
        for q in range(k):
            mid[q, 0], mid[q, 1], mid[q, 2] = a[q, 0], a[q, 1], a[q, 2]
        x, y, t = b[o, 0], b[o, 1], b[o, 2]
        c, s = math.cos(t), math.sin(t)
        dx, dy = 0.5 * means[o, p, 0], 0.5 * means[o, p, 1]
        mid[o, 0] = x + c * dx - s * dy
        mid[o, 1] = y + s * dx + c * dy
        mid[o, 2] = t + 0.5 * means[o, p, 2]
        if _object_bad(mid, -o - 1, kind, half, obs_kind, obs_half, obs_poses, table, margin):
            continue
        lx, ly = sweep_local[o, p, 0], sweep_local[o, p, 1]
        bx = x + c * lx - s * ly
        by = y + s * lx + c * ly
        bt = t + sweep_phi[o, p]
        hx, hy = sweep_half[o, p, 0], sweep_half[o, p, 1]
        cb, sb = math.cos(bt), math.sin(bt)
        inside = True
        for sx, sy in ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)):
            cx = cb * sx * hx - sb * sy * hy + bx
            cy = sb * sx * hx + cb * sy * hy + by
            if cx < bounds[0] or cx > bounds[2] or cy < bounds[1] or cy > bounds[3]:
                inside = False
                break
        if not inside:
            continue
        for j in range(k):
            if j != o and _overlap(BOX, bx, by, bt, hx, hy, kind[j], b[j, 0], b[j, 1], b[j, 2], half[j, 0],
                                   half[j, 1], 0.0):
                bad = True
                break
        if bad:
            continue
        for j in range(obs_poses.shape[0]):
            if _overlap(BOX, bx, by, bt, hx, hy, obs_kind[j], obs_poses[j, 0], obs_poses[j, 1], obs_poses[j, 2],
                        obs_half[j, 0], obs_half[j, 1], 0.0):
                bad = True
                break
        out[i] = not bad
    return out


@numba.njit(cache=True, nogil=True)
def task_cost(states, kind, half, table, weights, rel_a, rel_b, rel_dx, rel_dy, setting_scale):
    """``(n,)``: the weighted task cost of arrangements ``(n, k, 3)`` (:meth:`TaskCost.cost`)."""
    n, k = states.shape[0], states.shape[1]
    x0, y0, x1, y1 = table[0], table[1], table[2], table[3]
    area_ref = (x1 - x0) * (y1 - y0)
    d_ref = 0.5 * min(x1 - x0, y1 - y0)
    out = np.empty(n)
    for i in range(n):
        s = states[i]
        orth = 0.0
        edge = 0.0
        lox, loy, hix, hiy = np.inf, np.inf, -np.inf, -np.inf
        for o in range(k):
            t = s[o, 2]
            if kind[o] == CIRCLE:
                ex, ey = half[o, 0], half[o, 0]
            else:
                orth += math.sin(2.0 * t) ** 2
                c, sn = abs(math.cos(t)), abs(math.sin(t))
                ex, ey = c * half[o, 0] + sn * half[o, 1], sn * half[o, 0] + c * half[o, 1]
            lx, ly, hx, hy = s[o, 0] - ex, s[o, 1] - ey, s[o, 0] + ex, s[o, 1] + ey
            lox, loy, hix, hiy = min(lox, lx), min(loy, ly), max(hix, hx), max(hiy, hy)
            d = min(min(lx - x0, x1 - hx), min(ly - y0, y1 - hy))
            edge += 1.0 - max(d, 0.0) / d_ref
        area = (hix - lox) * (hiy - loy) / area_ref
        setting = 0.0
        for r in range(rel_a.shape[0]):
            a, b = rel_a[r], rel_b[r]
            px, py = (s[b, 0], s[b, 1]) if b >= 0 else (x0, y0)
            ex = s[a, 0] - px - rel_dx[r]
            ey = s[a, 1] - py - rel_dy[r]
            setting += ex * ex + ey * ey
        setting /= setting_scale ** 2
        out[i] = weights[0] * orth + weights[1] * area + weights[2] * edge + weights[3] * setting
    return out


@numba.njit(cache=True, nogil=True)
def rollout(s0, objs, prims, means):
    """The states ``(m + 1, k, 3)`` of the actions ``(objs[j], prims[j])`` from ``s0`` ``(k, 3)``: MODEL applied in
    turn (:meth:`ObjectSpace.rollout`; angles wrapped to ``[-pi, pi)``)."""
    m, k = objs.shape[0], s0.shape[0]
    out = np.empty((m + 1, k, 3))
    out[0] = s0
    for j in range(m):
        out[j + 1] = out[j]
        o, p = objs[j], prims[j]
        x, y, t = out[j, o, 0], out[j, o, 1], out[j, o, 2]
        dx, dy, dt = means[o, p, 0], means[o, p, 1], means[o, p, 2]
        c, s = math.cos(t), math.sin(t)
        out[j + 1, o, 0] = x + c * dx - s * dy
        out[j + 1, o, 1] = y + s * dx + c * dy
        out[j + 1, o, 2] = (t + dt + math.pi) % (2 * math.pi) - math.pi
    return out


@numba.njit(cache=True, nogil=True)
def beam_expand(poses, means, target, scale, period, bin_width):
    """One object's beam step (:func:`pliant_tsrrt.refine.push_toward`): every pose ``(b, 3)`` moved by each of the
    ``P`` mean displacements ``means`` ``(P, 3)`` (MODEL; the six primitives, or more: fractions of a stroke);
    returns the new poses ``(P b, 3)``, their pose error to
    ``target`` (position and ``scale`` times the yaw error modulo ``period``), the duplicate keys (0.5 mm, 2 mrad)
    and the yaw bins (``bin_width`` rad, modulo ``period``)."""
    b = poses.shape[0]
    P = means.shape[0]
    n = P * b
    to = np.empty((n, 3))
    err = np.empty(n)
    key = np.empty(n, dtype=np.int64)
    bins = np.empty(n, dtype=np.int64)
    for i in range(b):
        x, y, t = poses[i, 0], poses[i, 1], poses[i, 2]
        c, s = math.cos(t), math.sin(t)
        for p in range(P):
            j = P * i + p
            dx, dy, dt = means[p, 0], means[p, 1], means[p, 2]
            nx = x + c * dx - s * dy
            ny = y + s * dx + c * dy
            nt = (t + dt + math.pi) % (2 * math.pi) - math.pi
            to[j, 0], to[j, 1], to[j, 2] = nx, ny, nt
            d = nt - target[2]
            dth = (d + period / 2) % period - period / 2
            ex, ey = nx - target[0], ny - target[1]
            err[j] = math.sqrt(ex * ex + ey * ey + (scale * dth) ** 2)
            ix = np.int64(np.rint(nx / 5e-4))
            iy = np.int64(np.rint(ny / 5e-4))
            it = np.int64(np.rint(((nt + math.pi) % (2 * math.pi)) / 2e-3))
            key[j] = (ix * 1_000_003 + iy) * 4099 + it
            bins[j] = np.int64(np.rint((nt % period) / bin_width))
    return to, err, key, bins
