"""A fused numba kernel of RESOLVECOLLISIONS for rigid bodies (the hot path of the simulator).

For a rigid body the Jacobian of a point at ``r = p - c`` from the reference ``c`` is known in closed
form for the core's tangent conventions (world-frame twists): R^3 ``J = I``; SE(2) ``(x, y, theta)``
``J = [e_x, e_y, (-r_y, r_x, 0)]``; SE(3) ``(v, w)`` ``J = [I | -[r]x]``.  The kernel transforms the
body's surface points, finds the colliding ones, their entry-face normals and depths exactly as
:mod:`.contact` does, and accumulates the normal equations ``J^T J`` and ``J^T dp`` of eq. 8.5 per
particle, without any per-point temporaries.  With the effort-limited solver (the default,
below) it collects the constraint rows ``a_i = J_i^T n_i`` and push-outs instead, and calls the
same compiled :func:`effort_correction` as the generic path (it lives in this file because numba's
cache is invalidated per source file: a solver in another module would leave a stale kernel).

The effort-limited contact correction: minimum dissipation against the controller's effort limits
---------------------------------------------------------------------------------------------------

RESOLVECOLLISIONS (thesis eq. 8.5) maps the point push-outs to the configuration by least squares,
``dq = J^+ [dp_1; dp_2; ...]``.  That fit asks every colliding point to move by exactly its push-out
*vector* (tangential slip included), so contacts with different normals near each other (a convex
corner) or several points of one face at different depths are "explained" by a rotation, however
far the contact is from the body's reference point: the L-block of se2-maze turned by 1 rad against
its command at a corner, 60 times its speed limit.  Rescaling the rotation by a length does not
help: with two or more contact points ``J`` has full column rank and the least-squares solution does
not depend on the metric of ``dq``.

A compliant robot is driven by a controller whose *effort* is limited: a force limit ``F`` on the
translation and a torque limit ``T`` on the rotation (independent limits, as in the pymunk execution
simulator and in real actuators).  Quasi-statically, an obstacle displaces the robot from its command
in the directions where the controller saturates, and by the maximum-dissipation principle (the
controller's effort limits form a box *limit surface*, as the support friction does for quasi-static
pushing) the displacement ``dq`` minimises the work done against the controller,

    D(dq) = F ||dq_v|| + T ||dq_w||  =  F (||dq_v|| + l ||dq_w||),    l = T / F (m),

subject to no penetration of the colliding points, ``n_i . J_i dq >= depth_i + clearance``.  So a
contact whose lever arm about the reference point is shorter than ``l`` pushes the body away without
turning it, and only a longer lever turns it — as in the dynamic simulator.  Only the normal of each
contact is constrained (frictionless, like eq. 8.5's normal push-outs), and shallower points are not
forced to the surface (inequalities, not equalities), so the body does not snap flush to a wall.

Generally, tangent coordinates are split into *groups* with weights ``w_g`` (rigid bodies: the
translation with 1 and the rotation with ``l``; joint-space robots: each joint with 1), and

    minimise  sum_g w_g ||dq_g||   subject to  a_i . dq >= b_i,   a_i = J_i^T n_i.

It is solved by iteratively reweighted least squares (each iterate a quadratic program in the metric
``diag(w_g / ||dq_g||)``, the first one in ``diag(w_g^2)``, the ellipsoidal limit surface), each
quadratic program exactly by an active-set method on the contact multipliers (Lawson-Hanson:
``dq = M^-1 sum_i a_i lambda_i``, ``lambda_i >= 0``, at most about ``t`` of them nonzero).  Both the
generic numpy path and the fused rigid-body kernel call this one compiled function, so they agree to
rounding.
"""

from __future__ import annotations

import numba
import numpy as np

KIND_R3, KIND_SE2, KIND_SE3 = 0, 1, 2
SOLVE_LEAST_SQUARES, SOLVE_EFFORT = 0, 1
#: a robot face "faces" an entered obstacle face when their normals are within 60 degrees of anti-parallel
ROBOT_FACE_COS = 0.5

#: iteration cap of the reweighting (each round one quadratic program)
OUTER_ITERATIONS = 12


#: voxels: the largest radius of a broad-phase segment of surface points (``pliant.api.spatial_runs``)
SEGMENT_RADIUS = 4.0
#: most points in one broad-phase segment
SEGMENT_POINTS = 64
#: at most this many contacts of one pass are put in the body's order by an insertion sort (more: numpy's sort)
SORT_IN_PLACE = 64
#: voxels: the broad phase's bounds are reduced by this much, far more than any rounding of a point's position
BOUND_MARGIN = 1e-6


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _quadratic_program(a, b, count, minv, tol, lam, active, out, warm):
    """``out = argmin 1/2 dq^T M dq`` s.t. ``a[i] . dq >= b[i]``, ``M = diag(1 / minv)``; returns the active count.

    Lawson-Hanson active set on the dual, ``min_{lambda >= 0} 1/2 lambda^T A M^-1 A^T lambda - b^T lambda``
    with ``dq = M^-1 A^T lambda``: the most violated constraint joins the active set, the equality
    problem on the active set is solved exactly, and constraints whose multiplier would turn negative
    leave it.  At most ``t`` constraints are independent, so the systems are tiny and the solution is
    exact (a flat face pushed evenly gives a pure translation).  ``lam`` (count,) and ``active``
    (count,) carry the multipliers and the active set: with ``warm`` the previous ones are the start
    (the reweighting changes only the metric, so the active set mostly stays).
    """
    t = a.shape[1]
    if not warm:
        for j in range(count):
            lam[j] = 0.0
            active[j] = False
        for c in range(t):
            out[c] = 0.0
    members = np.empty(count, dtype=np.int64)
    pending = warm                                    # re-solve the carried active set in the new metric first
    for _ in range(3 * count + 3 * t):
        worst = -1
        if not pending:
            # the most violated inactive constraint
            worst_v = tol
            for j in range(count):
                if active[j]:
                    continue
                v = b[j]
                for c in range(t):
                    v -= a[j, c] * out[c]
                if v > worst_v:
                    worst, worst_v = j, v
            if worst < 0:
                break
            active[worst] = True
        pending = False
        for _inner in range(count + 1):
            m = 0
            for j in range(count):
                if active[j]:
                    members[m] = j
                    m += 1
            if m == 0:
                break
            w = np.empty((m, m))
            z = np.empty(m)
            trace = 0.0
            for u in range(m):
                for v in range(m):
                    s = 0.0
                    for c in range(t):
                        s += a[members[u], c] * minv[c] * a[members[v], c]
                    w[u, v] = s
                z[u] = b[members[u]]
                trace += w[u, u]
            for u in range(m):                       # dependent contacts (more than t) stay solvable
                w[u, u] += 1e-12 * max(trace / m, 1e-300)
            if m == 1 and np.isfinite(w[0, 0]) and np.isfinite(z[0]):
                # one active contact (nearly every solve of a sliding body): LAPACK's LU solve of a 1 x 1 system is
                # this one division (measured bit for bit), without its call and copies
                z[0] = z[0] / w[0, 0]
            else:
                z = np.linalg.solve(w, z)
            if np.all(z > 0.0):
                for u in range(m):
                    lam[members[u]] = z[u]
                break
            # step toward z until a multiplier reaches zero; that constraint leaves the active set
            alpha = 1.0
            for u in range(m):
                if z[u] <= 0.0:
                    denominator = lam[members[u]] - z[u]
                    ratio = lam[members[u]] / denominator if denominator > 0.0 else 0.0
                    alpha = min(alpha, ratio)
            for u in range(m):
                j = members[u]
                lam[j] += alpha * (z[u] - lam[j])
                if lam[j] <= 1e-300 or (z[u] <= 0.0 and lam[j] <= 1e-15 * max(abs(z[u]), 1e-300)):
                    lam[j] = 0.0
                    active[j] = False
        for c in range(t):
            out[c] = 0.0
        for j in range(count):
            if lam[j] != 0.0:
                for c in range(t):
                    out[c] += minv[c] * a[j, c] * lam[j]
        if worst >= 0 and not active[worst]:
            break                                    # it could not take load: no progress is possible
    return 0


@numba.njit(cache=True, nogil=True, error_model="numpy")
def effort_correction(a, b, count, group, weight, tol, out):
    """Write to ``out`` (t,) the ``dq`` minimising ``sum_g weight[g] ||dq_g||`` s.t. ``a[i] . dq >= b[i]``.

    ``a`` (>= count, t) holds the constraint rows ``J_i^T n_i`` and ``b`` (>= count,) the push-outs
    (m) of the first ``count`` colliding points; ``group`` (t,) the group of each tangent coordinate
    and ``weight`` (G,) the groups' weights (1 for translation, the effort length ``l`` in metres for
    rotation).  ``tol`` (m): constraints violated by less are left, and the reweighting stops once
    the weighted change of ``dq`` is below it.  With two groups (a rigid body) the pure translation is
    tried first and kept when its contact torque is within the limit (exactly optimal then); otherwise
    the first iterate is the quadratic program in ``diag(weight^2)`` and the others reweight it toward
    the sum of norms.  When the constraints cannot
    all hold (the body is squeezed), the caller's collision check reverts the microstep.
    """
    t = a.shape[1]
    ngroups = weight.shape[0]
    minv = np.empty(t)
    lam = np.empty(count)
    active = np.empty(count, dtype=np.bool_)
    norms = np.empty(ngroups)
    previous = np.zeros(t)
    floor = 1e-6 * tol
    if ngroups == 2:
        # A rigid body: try the pure translation first.  It is optimal (KKT of the sum of norms) iff the
        # contact forces that stop it, scaled to the force limit, exert at most the torque limit:
        # ||(A^T lambda)_w|| <= w_1 w_0 ||dq_v||, lambda the translation-only multipliers.
        for c in range(t):
            minv[c] = 1.0 / (weight[0] * weight[0]) if group[c] == 0 else 0.0
        _quadratic_program(a, b, count, minv, tol, lam, active, out, False)
        feasible = True
        for j in range(count):
            v = b[j]
            for c in range(t):
                v -= a[j, c] * out[c]
            if v > tol:
                feasible = False
                break
        if feasible:
            force = 0.0
            torque = 0.0
            for c in range(t):
                s = 0.0
                for j in range(count):
                    s += a[j, c] * lam[j]
                if group[c] == 0:
                    force += out[c] * out[c]
                else:
                    torque += s * s
            if np.sqrt(torque) <= weight[1] * weight[0] * np.sqrt(force):
                return
    for c in range(t):
        minv[c] = 1.0 / (weight[group[c]] * weight[group[c]])
    for outer in range(OUTER_ITERATIONS):
        _quadratic_program(a, b, count, minv, tol, lam, active, out, outer > 0)
        # reweight: the metric w_g / ||dq_g|| majorises w_g ||dq_g|| at the current iterate
        for g in range(ngroups):
            norms[g] = 0.0
        for c in range(t):
            norms[group[c]] += out[c] * out[c]
        moved = 0.0
        for g in range(ngroups):
            norms[g] = np.sqrt(norms[g])
            s = 0.0
            for c in range(t):
                if group[c] == g:
                    s += (out[c] - previous[c]) ** 2
            moved += weight[g] * np.sqrt(s)
        nonzero = 0
        for g in range(ngroups):
            if norms[g] > 0.0:
                nonzero += 1
        if nonzero <= 1 or (outer > 0 and moved < tol):
            break           # (one group moving, e.g. a pure translation: reweighting keeps the solution)
        for c in range(t):
            g = group[c]
            minv[c] = max(weight[g] * norms[g], floor) / (weight[g] * weight[g])
            previous[c] = out[c]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _face_contact(p, motion, lower, res, ix, iy, iz, flat, exposed, deep_normal, deep_depth, faces, r_, out_n):
    """Normal (written to ``out_n``) and depth of a point inside occupied voxel ``flat``.

    ``faces``: bit ``e`` set when body-frame axis direction ``e`` (-x, +x, -y, +y, -z, +z) leaves the robot
    at this point (the robot's own face normals, :meth:`pliant.interfaces.RobotModel.surface_faces`); ``r_``
    (3, 3) rotates them to the world.  See :mod:`.contact` for the rule: a point in an edge voxel of the
    obstacle (exposed faces on two or more axes) that lies on exactly one robot face facing them is pushed
    out along that face's normal; any other point through the face it entered last.
    """
    lo0, lo1, lo2 = lower[0] + ix * res, lower[1] + iy * res, lower[2] + iz * res
    d = (p[0] - lo0, lo0 + res - p[0], p[1] - lo1, lo1 + res - p[1], p[2] - lo2, lo2 + res - p[2])
    ndotd = (-motion[0], motion[0], -motion[1], motion[1], -motion[2], motion[2])
    best, best_t, entered = -1, np.inf, 0
    for f in range(6):
        if exposed[flat, f] and ndotd[f] < -1e-15:
            entered += 1
            t = d[f] / -ndotd[f]
            if t < best_t:
                best_t, best = t, f
    if faces != 0 and entered >= 1:
        axes = 0
        for c in range(3):
            if exposed[flat, 2 * c] or exposed[flat, 2 * c + 1]:
                axes += 1
        if axes >= 2:
            chosen, count = -1, 0
            for e in range(6):
                if not (faces >> e) & 1:
                    continue
                se = 1.0 if e % 2 == 1 else -1.0
                score = -np.inf
                for f in range(6):
                    if exposed[flat, f]:
                        sf = 1.0 if f % 2 == 1 else -1.0
                        score = max(score, -sf * se * r_[f // 2, e // 2])
                if score > ROBOT_FACE_COS:
                    chosen, count = e, count + 1
            if count == 1:
                se = 1.0 if chosen % 2 == 1 else -1.0
                n0, n1, n2 = -se * r_[0, chosen // 2], -se * r_[1, chosen // 2], -se * r_[2, chosen // 2]
                n = (n0, n1, n2)
                depth = np.inf
                for f in range(6):
                    sf = 1.0 if f % 2 == 1 else -1.0
                    along = sf * n[f // 2]
                    if along > 1e-9:
                        depth = min(depth, d[f] / along)
                out_n[0], out_n[1], out_n[2] = n0, n1, n2
                return depth
    if best < 0:
        best_d = np.inf
        for f in range(6):
            if exposed[flat, f] and d[f] < best_d:
                best_d, best = d[f], f
    if best < 0:
        out_n[0], out_n[1], out_n[2] = deep_normal[flat, 0], deep_normal[flat, 1], deep_normal[flat, 2]
        return deep_depth[flat]
    out_n[0] = out_n[1] = out_n[2] = 0.0
    out_n[best // 2] = 1.0 if best % 2 == 1 else -1.0
    return d[best]


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _segment_clearance(r_, pos, centre, radius, lower, inv, nx, ny, nz, free_clearance):
    """The broad phase's test of one segment of points: the ``free_clearance`` of the voxel holding its ``centre``
    (body frame, placed by ``r_`` / ``pos``) less its ``radius``; -1 when the centre is off the grid.  Positive: no
    point of the segment can be in an occupied voxel (see :func:`_accumulate`)."""
    c0, c1, c2 = centre[0], centre[1], centre[2]
    ix = int(np.floor((r_[0, 0] * c0 + r_[0, 1] * c1 + r_[0, 2] * c2 + pos[0] - lower[0]) * inv))
    iy = int(np.floor((r_[1, 0] * c0 + r_[1, 1] * c1 + r_[1, 2] * c2 + pos[1] - lower[1]) * inv))
    iz = int(np.floor((r_[2, 0] * c0 + r_[2, 1] * c1 + r_[2, 2] * c2 + pos[2] - lower[2]) * inv))
    if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
        return free_clearance[(ix * ny + iy) * nz + iz] - radius
    return -1.0


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _accumulate(kind, r_, pos, local, faces, index, r0, pos0, lower, res, shape, exposed, deep_normal,
                deep_depth, clearance, lhs, rhs, p, motion, nrm, free_clearance, planar, segments, centres, radii,
                readings, distance, reach, rows, pushes, hit_index, hit_p, hit_nrm, hit_push, hit_order):
    """Normal equations of one body placed by ``r_`` (3, 3) / ``pos`` (3,); returns the colliding count.

    The colliding points' constraint rows ``J_i^T n_i`` and push-outs are written to ``rows`` (k, t)
    and ``pushes`` (k,) too, in the order of the body's points.

    ``local`` / ``faces`` are the body's points in the order the kernel walks them (``pliant.api.spatial_order``,
    which makes the segments below long) and ``index`` (k,) each one's place in the body's own order.  The
    colliding points are gathered first (``hit_index`` / ``hit_p`` / ``hit_nrm`` / ``hit_push``, k each;
    ``hit_order`` (k,) scratch for their order) and added in the body's order, so every sum is taken in the same
    order, bit for bit, whatever order the points are walked.

    ``r0`` / ``pos0`` place the body before the microstep: a colliding point's motion is measured
    from there (computed only for colliding points).

    Broad phase (it only skips points that cannot collide, so the result is the same without it).  The points are
    cut into *segments*, runs of consecutive points (``segments`` (s + 1,): the first point of each, then ``k``)
    within ``radii`` (s,) (m) of their ``centres`` (s, 3) in the body frame.  ``free_clearance`` (per voxel, m) is a
    lower bound on the distance from any point of a free voxel to an obstacle or the grid's boundary, and negative
    for an occupied voxel (:class:`.contact.ContactModel`).  A segment whose centre lies in a voxel whose bound
    exceeds its radius holds no colliding point and is skipped whole.  Then, point by point,
    points with ``distance[i] > reach`` are skipped: they were that far from every obstacle and have moved less
    since.  ``distance``, ``readings`` (s,) and ``reach`` are "odometer" readings: a point (segment) measured with
    clearance ``c`` when the body had moved ``m`` in total stores ``c + m``; it is safe while the body's total
    motion stays below that.  Zeros check everything.
    """
    nx, ny, nz = shape[0], shape[1], shape[2]
    inv = 1.0 / res
    lo0, lo1, lo2 = lower[0], lower[1], lower[2]
    upper0, upper1, upper2 = lo0 + nx * res, lo1 + ny * res, lo2 + nz * res
    # the placement in scalars (the same products and sums, in the same order, as with the arrays)
    a00, a01, a02, a10, a11, a12, a20, a21, a22 = (r_[0, 0], r_[0, 1], r_[0, 2], r_[1, 0], r_[1, 1], r_[1, 2],
                                                   r_[2, 0], r_[2, 1], r_[2, 2])
    b0, b1, b2 = pos[0], pos[1], pos[2]
    lhs[:] = 0.0
    rhs[:] = 0.0
    found = 0
    for s in range(segments.shape[0] - 1):
        reading = readings[s]
        if reading > reach:
            continue
        if reading >= 0.0 or -reading <= reach:
            free = _segment_clearance(r_, pos, centres[s], radii[s], lower, inv, nx, ny, nz, free_clearance)
            if free > 0.0:
                readings[s] = free + reach
                continue
            readings[s] = -(reach + res)           # near an obstacle: its points one by one until it moved a voxel
        for i in range(segments[s], segments[s + 1]):
            if distance[i] > reach:
                continue
            l0, l1, l2 = local[i, 0], local[i, 1], local[i, 2]
            x = a00 * l0 + a01 * l1 + a02 * l2 + b0
            y = a10 * l0 + a11 * l1 + a12 * l2 + b1
            z = a20 * l0 + a21 * l1 + a22 * l2 + b2
            ix = int(np.floor((x - lo0) * inv))
            iy = int(np.floor((y - lo1) * inv))
            iz = int(np.floor((z - lo2) * inv))
            if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
                flat = (ix * ny + iy) * nz + iz
                free = free_clearance[flat]
                if free >= 0.0:
                    # the point must first leave its voxel's box (not across z in the plane), less a margin for rounding
                    fx, fy = x - (lo0 + ix * res), y - (lo1 + iy * res)
                    inside = min(fx, res - fx, fy, res - fy)
                    if not planar:
                        fz = z - (lo2 + iz * res)
                        inside = min(inside, fz, res - fz)
                    distance[i] = free + inside - BOUND_MARGIN * res + reach
                    continue
                p[0], p[1], p[2] = x, y, z
                for c in range(3):
                    motion[c] = p[c] - (r0[c, 0] * l0 + r0[c, 1] * l1 + r0[c, 2] * l2 + pos0[c])
                depth = _face_contact(p, motion, lower, res, ix, iy, iz, flat, exposed, deep_normal, deep_depth,
                                      faces[i], r_, nrm)
            else:
                p[0], p[1], p[2] = x, y, z
                nrm[0] = max(lo0 - x, 0.0) - max(x - upper0, 0.0)
                nrm[1] = max(lo1 - y, 0.0) - max(y - upper1, 0.0)
                nrm[2] = max(lo2 - z, 0.0) - max(z - upper2, 0.0)
                depth = np.sqrt(nrm[0] ** 2 + nrm[1] ** 2 + nrm[2] ** 2)
                for c in range(3):
                    nrm[c] /= max(depth, 1e-300)
            distance[i] = reach
            hit_index[found] = index[i]
            for c in range(3):
                hit_p[found, c] = p[c]
                hit_nrm[found, c] = nrm[c]
            hit_push[found] = depth + clearance * res
            found += 1
    if found > SORT_IN_PLACE:
        order = np.argsort(hit_index[:found])
    else:                       # few contacts: an insertion sort of their slots, without allocating
        order = hit_order[:found]
        for j in range(found):
            key = hit_index[j]
            m = j
            while m > 0 and hit_index[order[m - 1]] > key:
                order[m] = order[m - 1]
                m -= 1
            order[m] = j
    hits = 0
    for j in order:
        hits = _add_contact(kind, hits, hit_p[j], pos, hit_nrm[j], hit_push[j], lhs, rhs, rows, pushes)
    return hits


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _add_contact(kind, hits, p, pos, nrm, push, lhs, rhs, rows, pushes):
    """Add one colliding point at ``p`` (normal ``nrm``, push-out ``push`` m) to the constraint rows and the normal
    equations of eq. 8.5; returns the new count."""
    dp0, dp1, dp2 = nrm[0] * push, nrm[1] * push, nrm[2] * push
    rx, ry, rz = p[0] - pos[0], p[1] - pos[1], p[2] - pos[2]
    pushes[hits] = push
    if kind == KIND_R3:
        rows[hits, 0], rows[hits, 1], rows[hits, 2] = nrm[0], nrm[1], nrm[2]
    elif kind == KIND_SE2:
        rows[hits, 0], rows[hits, 1], rows[hits, 2] = nrm[0], nrm[1], -ry * nrm[0] + rx * nrm[1]
    else:
        rows[hits, 0], rows[hits, 1], rows[hits, 2] = nrm[0], nrm[1], nrm[2]
        rows[hits, 3] = ry * nrm[2] - rz * nrm[1]
        rows[hits, 4] = rz * nrm[0] - rx * nrm[2]
        rows[hits, 5] = rx * nrm[1] - ry * nrm[0]
    hits += 1
    if kind == KIND_R3:
        for c in range(3):
            lhs[c, c] += 1.0
        rhs[0] += dp0
        rhs[1] += dp1
        rhs[2] += dp2
    elif kind == KIND_SE2:
        # columns: e_x, e_y, (-ry, rx, 0)
        lhs[0, 0] += 1.0
        lhs[1, 1] += 1.0
        lhs[0, 2] += -ry
        lhs[2, 0] += -ry
        lhs[1, 2] += rx
        lhs[2, 1] += rx
        lhs[2, 2] += rx * rx + ry * ry
        rhs[0] += dp0
        rhs[1] += dp1
        rhs[2] += -ry * dp0 + rx * dp1
    else:
        # J = [I | -[r]x]; J^T J = [[I, -[r]x], [[r]x, |r|^2 I - r r^T]]; J^T dp = [dp; r x dp]
        for c in range(3):
            lhs[c, c] += 1.0
        lhs[0, 4] += rz
        lhs[0, 5] += -ry
        lhs[1, 3] += -rz
        lhs[1, 5] += rx
        lhs[2, 3] += ry
        lhs[2, 4] += -rx
        lhs[4, 0] += rz
        lhs[5, 0] += -ry
        lhs[3, 1] += -rz
        lhs[5, 1] += rx
        lhs[3, 2] += ry
        lhs[4, 2] += -rx
        rr = rx * rx + ry * ry + rz * rz
        lhs[3, 3] += rr - rx * rx
        lhs[4, 4] += rr - ry * ry
        lhs[5, 5] += rr - rz * rz
        lhs[3, 4] += -rx * ry
        lhs[4, 3] += -rx * ry
        lhs[3, 5] += -rx * rz
        lhs[5, 3] += -rx * rz
        lhs[4, 5] += -ry * rz
        lhs[5, 4] += -ry * rz
        rhs[0] += dp0
        rhs[1] += dp1
        rhs[2] += dp2
        rhs[3] += ry * dp2 - rz * dp1
        rhs[4] += rz * dp0 - rx * dp2
        rhs[5] += rx * dp1 - ry * dp0
    return hits


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _placement(kind, q, r_, pos):
    """Rotation ``r_`` and reference position ``pos`` of configuration ``q`` (core conventions)."""
    if kind == KIND_R3:
        r_[:] = 0.0
        r_[0, 0] = r_[1, 1] = r_[2, 2] = 1.0
        pos[0], pos[1], pos[2] = q[0], q[1], q[2]
    elif kind == KIND_SE2:
        c, s = np.cos(q[2]), np.sin(q[2])
        r_[:] = 0.0
        r_[0, 0], r_[0, 1], r_[1, 0], r_[1, 1], r_[2, 2] = c, -s, s, c, 1.0
        pos[0], pos[1], pos[2] = q[0], q[1], 0.0
    else:
        x, y, z, w = q[3], q[4], q[5], q[6]
        r_[0, 0] = 1 - 2 * (y * y + z * z)
        r_[0, 1] = 2 * (x * y - w * z)
        r_[0, 2] = 2 * (x * z + w * y)
        r_[1, 0] = 2 * (x * y + w * z)
        r_[1, 1] = 1 - 2 * (x * x + z * z)
        r_[1, 2] = 2 * (y * z - w * x)
        r_[2, 0] = 2 * (x * z - w * y)
        r_[2, 1] = 2 * (y * z + w * x)
        r_[2, 2] = 1 - 2 * (x * x + y * y)
        pos[0], pos[1], pos[2] = q[0], q[1], q[2]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def placed_points_hit(kind, q, local, segments, centres, radii, free_clearance, lower, inv_res, shape,
                      occupied_flat, out):
    """Whether any body point lies inside an occupied voxel or outside the grid, per configuration: ``out[a]`` (n,)
    for ``q[a]`` (n, d), the points ``local`` (k, 3) in the body frame placed as :func:`_placement` places them
    (the rigid body's ``body_points``).  ``occupied_flat``: the occupancy, C order.  The compiled first pass of
    the simulator's start check (``start_penetration``): most starts are free, and this answers them without the
    ``(n, k, 3)`` array of placed points.  The broad phase of :func:`_accumulate` skips a segment of points
    (``segments`` / ``centres`` / ``radii``) whose centre lies in a voxel whose ``free_clearance`` exceeds its
    radius: none of its points can be inside."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    r_ = np.empty((3, 3))
    pos = np.empty(3)
    for a in range(q.shape[0]):
        _placement(kind, q[a], r_, pos)
        hit = False
        for s in range(segments.shape[0] - 1):
            if _segment_clearance(r_, pos, centres[s], radii[s], lower, inv_res, nx, ny, nz, free_clearance) > 0.0:
                continue
            hit = _segment_hit(local, segments[s], segments[s + 1], r_, pos, lower, inv_res, nx, ny, nz,
                               occupied_flat)
            if hit:
                break
        out[a] = hit


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _segment_hit(local, first, end, r_, pos, lower, inv_res, nx, ny, nz, occupied_flat):
    """Whether any of the points ``local[first:end]`` placed by ``r_`` / ``pos`` is occupied or off the grid."""
    for i in range(first, end):
        x, y, z = local[i, 0], local[i, 1], local[i, 2]
        ix = int(np.floor((r_[0, 0] * x + r_[0, 1] * y + r_[0, 2] * z + pos[0] - lower[0]) * inv_res))
        iy = int(np.floor((r_[1, 0] * x + r_[1, 1] * y + r_[1, 2] * z + pos[1] - lower[1]) * inv_res))
        iz = int(np.floor((r_[2, 0] * x + r_[2, 1] * y + r_[2, 2] * z + pos[2] - lower[2]) * inv_res))
        if not (0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz) or occupied_flat[(ix * ny + iy) * nz + iz]:
            return True
    return False


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _retract(kind, q, delta, out):
    """``Space.retract`` of the core for R^3, SE(2) and SE(3) (world-frame rotation vectors)."""
    if kind == KIND_R3:
        for c in range(3):
            out[c] = q[c] + delta[c]
    elif kind == KIND_SE2:
        out[0], out[1] = q[0] + delta[0], q[1] + delta[1]
        out[2] = (q[2] + delta[2] + np.pi) % (2 * np.pi) - np.pi
    else:
        for c in range(3):
            out[c] = q[c] + delta[c]
        wx, wy, wz = delta[3], delta[4], delta[5]
        angle = np.sqrt(wx * wx + wy * wy + wz * wz)
        if angle > 0:
            s = np.sin(0.5 * angle) / angle
            ax, ay, az, aw = wx * s, wy * s, wz * s, np.cos(0.5 * angle)
        else:
            ax, ay, az, aw = 0.0, 0.0, 0.0, 1.0
        bx, by, bz, bw = q[3], q[4], q[5], q[6]
        x = aw * bx + ax * bw + ay * bz - az * by
        y = aw * by - ax * bz + ay * bw + az * bx
        z = aw * bz + ax * by - ay * bx + az * bw
        w = aw * bw - ax * bx - ay * by - az * bz
        norm = np.sqrt(x * x + y * y + z * z + w * w)
        out[3], out[4], out[5], out[6] = x / norm, y / norm, z / norm, w / norm


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _motion_bound(kind, delta, radius):
    """No body point moves farther than |translation| + |rotation| * radius under tangent motion ``delta``."""
    if kind == KIND_R3:
        return np.sqrt(delta[0] ** 2 + delta[1] ** 2 + delta[2] ** 2)
    if kind == KIND_SE2:
        return np.sqrt(delta[0] ** 2 + delta[1] ** 2) + abs(delta[2]) * radius
    return (np.sqrt(delta[0] ** 2 + delta[1] ** 2 + delta[2] ** 2)
            + np.sqrt(delta[3] ** 2 + delta[4] ** 2 + delta[5] ** 2) * radius)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def fused_advance(kind, q, velocity, noise, sub_dt, max_halvings, local, faces, index, segments, centres, radii, lower,
                  res, shape, exposed, deep_normal, deep_depth, free_clearance, planar, radius, clearance,
                  max_corrections, damping, solver, group, weight, tol, out, touched):
    """One control step of every particle, microstep by microstep with RESOLVECOLLISIONS (thesis eq. 8.3-8.5), fully
    compiled.

    Particle ``a`` at ``q[a]`` (n, d) is commanded ``velocity[a]`` (n, t; m/s, rad/s) for ``micro`` microsteps of
    ``sub_dt`` s, with the actuation error ``noise[m, a]`` (micro, n, t; drawn by the caller, microstep by microstep,
    in the order the per-microstep loop it replaces drew them).  Each microstep moves by ``(velocity + noise) *
    sub_dt * scale``; corrections repeat up to ``max_corrections`` times, each ``dq = (J^T J)^-1 J^T dp``
    (``solver`` SOLVE_LEAST_SQUARES, eq. 8.5 with relative ``damping``) or the effort-limited correction
    :func:`effort_correction` (SOLVE_EFFORT: tangent ``group``/``weight``, tolerance ``tol`` in m).  A microstep
    that still collides is reverted and the particle's ``scale`` halved (adaptive step scaling), to zero after
    ``max_halvings``.  Writes the final configurations to ``out`` (n, d) and to ``touched`` (n,) whether any
    correction was needed.  ``segments`` / ``centres`` / ``radii`` (the broad phase, :func:`_accumulate`) and
    ``radius`` (m, the farthest point from the reference) only skip points that cannot collide.  ``local`` /
    ``faces`` are walked in a spatial order, ``index`` (k,) each point's place in the body's own order
    (:func:`_accumulate`).

    Particles are independent, so they are advanced one after the other through all their microsteps: the broad
    phase's readings are per particle (length ``k``, not ``n x k``) and stay in cache.
    """
    n, d = q.shape
    t = velocity.shape[1]
    micro = noise.shape[0]
    r_ = np.empty((3, 3))
    pos = np.empty(3)
    r0 = np.empty((3, 3))
    pos0 = np.empty(3)
    lhs = np.empty((t, t))
    rhs = np.empty(t)
    p = np.empty(3)
    motion = np.empty(3)
    nrm = np.empty(3)
    current = np.empty(d)
    trial = np.empty(d)
    moved = np.empty(d)
    step = np.empty(t)
    rows = np.empty((local.shape[0], t))
    pushes = np.empty(local.shape[0])
    distance = np.empty(local.shape[0])
    readings = np.empty(segments.shape[0] - 1)
    hit_index = np.empty(local.shape[0], dtype=np.int64)
    hit_p = np.empty((local.shape[0], 3))
    hit_nrm = np.empty((local.shape[0], 3))
    hit_push = np.empty(local.shape[0])
    hit_order = np.empty(local.shape[0], dtype=np.int64)
    dq = np.empty(t)
    for a in range(n):
        for c in range(d):
            current[c] = q[a, c]
        distance[:] = 0.0
        readings[:] = 0.0
        odometer = 0.0
        scale = 1.0
        halvings = 0
        touched[a] = False
        for m in range(micro):
            for c in range(t):
                step[c] = (velocity[a, c] + noise[m, a, c]) * sub_dt * scale
            _placement(kind, current, r0, pos0)
            _retract(kind, current, step, trial)
            converged = False
            start_reading = odometer
            reach = odometer + _motion_bound(kind, step, radius)
            for _ in range(max_corrections + 1):
                _placement(kind, trial, r_, pos)
                hits = _accumulate(kind, r_, pos, local, faces, index, r0, pos0, lower, res, shape, exposed,
                                   deep_normal, deep_depth, clearance, lhs, rhs, p, motion, nrm, free_clearance,
                                   planar, segments, centres, radii, readings, distance, reach, rows, pushes,
                                   hit_index, hit_p, hit_nrm, hit_push, hit_order)
                if hits == 0:
                    converged = True
                    break
                touched[a] = True
                if solver == SOLVE_EFFORT:
                    effort_correction(rows, pushes, hits, group, weight, tol, dq)
                else:
                    trace = 0.0
                    for c in range(t):
                        trace += lhs[c, c]
                    for c in range(t):
                        lhs[c, c] += damping * max(trace / t, 1e-12)
                    dq[:] = np.linalg.solve(lhs, rhs)
                _retract(kind, trial, dq, moved)
                trial[:] = moved
                reach += _motion_bound(kind, dq, radius)
            if converged:
                current[:] = trial
                odometer = reach
            else:
                odometer = reach + (reach - start_reading)   # jumping back is a motion too
                halvings += 1
                scale = 0.0 if halvings > max_halvings else scale * 0.5
        out[a] = current
