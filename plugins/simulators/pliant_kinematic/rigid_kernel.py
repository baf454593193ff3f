"""A fused numba kernel of RESOLVECOLLISIONS for rigid bodies (the hot path of the simulator).

For a rigid body the Jacobian of a point at ``r = p - c`` from the reference ``c`` is known in closed
form for the core's tangent conventions (world-frame twists): R^3 ``J = I``; SE(2) ``(x, y, theta)``
``J = [e_x, e_y, (-r_y, r_x, 0)]``; SE(3) ``(v, w)`` ``J = [I | -[r]x]``.  The kernel transforms the
body's surface points, finds the colliding ones, their entry-face normals and depths exactly as
:mod:`.contact` does, and accumulates the normal equations ``J^T J`` and ``J^T dp`` of eq. 8.5 per
particle, without any per-point temporaries.
"""

from __future__ import annotations

import numba
import numpy as np

KIND_R3, KIND_SE2, KIND_SE3 = 0, 1, 2


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _face_contact(p, motion, lower, res, ix, iy, iz, flat, exposed, deep_normal, deep_depth, out_n):
    """Normal (written to ``out_n``) and depth of a point inside occupied voxel ``flat``."""
    lo0, lo1, lo2 = lower[0] + ix * res, lower[1] + iy * res, lower[2] + iz * res
    d = (p[0] - lo0, lo0 + res - p[0], p[1] - lo1, lo1 + res - p[1], p[2] - lo2, lo2 + res - p[2])
    ndotd = (-motion[0], motion[0], -motion[1], motion[1], -motion[2], motion[2])
    best, best_t = -1, np.inf
    for f in range(6):
        if exposed[flat, f] and ndotd[f] < -1e-15:
            t = d[f] / -ndotd[f]
            if t < best_t:
                best_t, best = t, f
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


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _accumulate(kind, r_, pos, local, r0, pos0, lower, res, shape, occupied_flat, exposed, deep_normal, deep_depth,
                clearance, lhs, rhs, p, motion, nrm, free_clearance, distance, reach):
    """Normal equations of one body placed by ``r_`` (3, 3) / ``pos`` (3,); returns the colliding count.

    ``r0`` / ``pos0`` place the body before the microstep: a colliding point's motion is measured
    from there (computed only for colliding points).  Points with ``distance[i] > reach`` are skipped:
    they were that far from every obstacle and have moved less since (``distance`` and ``reach`` are
    "odometer" readings: a point measured with clearance ``c`` when the body had moved ``m`` in total
    stores ``c + m``; it is safe while the body's total motion stays below that).
    """
    k = local.shape[0]
    nx, ny, nz = shape[0], shape[1], shape[2]
    inv = 1.0 / res
    upper0, upper1, upper2 = lower[0] + nx * res, lower[1] + ny * res, lower[2] + nz * res
    lhs[:] = 0.0
    rhs[:] = 0.0
    hits = 0
    for i in range(k):
        if distance[i] > reach:
            continue
        for c in range(3):
            p[c] = r_[c, 0] * local[i, 0] + r_[c, 1] * local[i, 1] + r_[c, 2] * local[i, 2] + pos[c]
        ix = int(np.floor((p[0] - lower[0]) * inv))
        iy = int(np.floor((p[1] - lower[1]) * inv))
        iz = int(np.floor((p[2] - lower[2]) * inv))
        if 0 <= ix < nx and 0 <= iy < ny and 0 <= iz < nz:
            flat = (ix * ny + iy) * nz + iz
            if not occupied_flat[flat]:
                distance[i] = free_clearance[flat] + reach
                continue
            for c in range(3):
                motion[c] = p[c] - (r0[c, 0] * local[i, 0] + r0[c, 1] * local[i, 1] + r0[c, 2] * local[i, 2]
                                    + pos0[c])
            depth = _face_contact(p, motion, lower, res, ix, iy, iz, flat, exposed, deep_normal, deep_depth, nrm)
        else:
            nrm[0] = max(lower[0] - p[0], 0.0) - max(p[0] - upper0, 0.0)
            nrm[1] = max(lower[1] - p[1], 0.0) - max(p[1] - upper1, 0.0)
            nrm[2] = max(lower[2] - p[2], 0.0) - max(p[2] - upper2, 0.0)
            depth = np.sqrt(nrm[0] ** 2 + nrm[1] ** 2 + nrm[2] ** 2)
            for c in range(3):
                nrm[c] /= max(depth, 1e-300)
        distance[i] = reach
        hits += 1
        push = depth + clearance * res
        dp0, dp1, dp2 = nrm[0] * push, nrm[1] * push, nrm[2] * push
        rx, ry, rz = p[0] - pos[0], p[1] - pos[1], p[2] - pos[2]
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
def fused_microstep(kind, q, step, local, lower, res, shape, occupied_flat, exposed, deep_normal, deep_depth,
                    free_clearance, radius, clearance, max_corrections, damping, odometer, distances, out,
                    converged, touched):
    """One microstep with RESOLVECOLLISIONS for every particle (thesis eq. 8.3-8.5), fully compiled.

    ``q`` (n, d) moves by ``step`` (n, t); corrections ``dq = (J^T J)^-1 J^T dp`` repeat up to
    ``max_corrections`` times; a particle that still collides is put back at ``q`` (``converged``
    False).  ``touched`` reports whether any correction was needed.  ``odometer`` (n,) and
    ``distances`` (n, k) carry the broad phase between microsteps: zeros check every point.
    """
    n, d = q.shape
    t = step.shape[1]
    r_ = np.empty((3, 3))
    pos = np.empty(3)
    r0 = np.empty((3, 3))
    pos0 = np.empty(3)
    lhs = np.empty((t, t))
    rhs = np.empty(t)
    p = np.empty(3)
    motion = np.empty(3)
    nrm = np.empty(3)
    trial = np.empty(d)
    moved = np.empty(d)
    for a in range(n):
        _placement(kind, q[a], r0, pos0)
        _retract(kind, q[a], step[a], trial)
        converged[a] = False
        touched[a] = False
        distance = distances[a]
        start_reading = odometer[a]
        reach = odometer[a] + _motion_bound(kind, step[a], radius)
        for _ in range(max_corrections + 1):
            _placement(kind, trial, r_, pos)
            hits = _accumulate(kind, r_, pos, local, r0, pos0, lower, res, shape, occupied_flat, exposed,
                               deep_normal, deep_depth, clearance, lhs, rhs, p, motion, nrm, free_clearance,
                               distance, reach)
            if hits == 0:
                converged[a] = True
                break
            touched[a] = True
            trace = 0.0
            for c in range(t):
                trace += lhs[c, c]
            for c in range(t):
                lhs[c, c] += damping * max(trace / t, 1e-12)
            dq = np.linalg.solve(lhs, rhs)
            _retract(kind, trial, dq, moved)
            trial[:] = moved
            reach += _motion_bound(kind, dq, radius)
        if converged[a]:
            out[a] = trial
            odometer[a] = reach
        else:
            out[a] = q[a]
            odometer[a] = reach + (reach - start_reading)   # jumping back is a motion too
