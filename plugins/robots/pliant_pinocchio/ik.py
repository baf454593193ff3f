"""Inverse kinematics of a URDF robot's planned joints: several diverse configurations that put a frame at a pose.

Damped least squares on pinocchio's frame Jacobian (the same differential IK that ``pink`` builds its QP from, here
solved in closed form): from a start configuration, each step moves the joints by
``dq = J^T (J J^T + lambda I)^-1 e`` -- ``e`` the position error (m) and, when an orientation is asked, the rotation
error ``log3(R_target R^T)`` (rad, world frame), ``J`` the matching rows of the frame Jacobian in the world-aligned
frame -- with the step's norm capped and the joints clamped to their limits after each step, until the errors are
within the tolerances.  Starts: the given seeds first, then uniform samples of the joint space from the caller's
generator.  A converged configuration is kept when the caller's validity check accepts it (collisions) and it is at
least ``diversity`` (joint-space metric) from every one kept so far, so the solutions are distinct goal states.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import ConfigError


@dataclass
class IKResult:
    """``solutions`` ``(k, d)`` (k may be 0), with per-solution ``position_errors`` (m) and ``orientation_errors``
    (rad; 0 without an orientation), ``attempts`` made and ``converged`` (before the validity and diversity checks)."""

    solutions: np.ndarray
    position_errors: np.ndarray
    orientation_errors: np.ndarray
    attempts: int
    converged: int


def _rotation(orientation) -> np.ndarray:
    import pinocchio as pin

    q = np.asarray(orientation, dtype=np.float64)
    if q.shape != (4,) or not np.all(np.isfinite(q)) or np.linalg.norm(q) < 1e-9:
        raise ConfigError("must be a quaternion (qx, qy, qz, qw)", field="orientation", value=q.tolist())
    q = q / np.linalg.norm(q)
    return pin.Quaternion(q[3], q[0], q[1], q[2]).toRotationMatrix()


def solve_ik(robot, frame: str, position, orientation=None, *, rng: np.random.Generator, solutions: int = 4,
             position_tolerance: float = 1e-3, orientation_tolerance: float = 1e-2, attempts: int = 50,
             iterations: int = 150, damping: float = 1e-4, max_step: float = 0.3, diversity: float = 0.1,
             valid=None, seeds=None) -> IKResult:
    """Up to ``solutions`` configurations of ``robot`` (a :class:`~pliant_pinocchio.robot.PinocchioRobot`) placing
    ``frame`` at ``position`` (m, world) and, when given, ``orientation`` (quaternion ``(qx, qy, qz, qw)``), within the
    tolerances (m, rad) and the joint limits; ``valid``: ``(n, d) -> bool (n,)`` (default: no self-collision and
    no contact with the scene); ``seeds``: start configurations tried first (module docstring)."""
    import pinocchio as pin

    target = np.asarray(position, dtype=np.float64)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise ConfigError("must be 3 finite numbers (m)", field="position", value=np.asarray(position).tolist())
    rotation = None if orientation is None else _rotation(orientation)
    fid = robot._frame(frame)
    model, data, space = robot.model, robot.data, robot.space
    lower, upper = space.lower, space.upper
    valid = valid or (lambda q: ~robot.in_collision(q))
    starts = [np.asarray(s, dtype=np.float64) for s in (seeds if seeds is not None else [])]
    kept, p_err, o_err = [], [], []
    converged = tried = 0
    rows = 3 if rotation is None else 6
    for tried in range(1, attempts + 1):
        q = np.clip(starts[tried - 1], lower, upper) if tried <= len(starts) else space.sample(rng, 1)[0]
        done = False
        for _ in range(iterations):
            full = robot.full_configurations(q)[0]
            pin.forwardKinematics(model, data, full)
            placement = pin.updateFramePlacement(model, data, fid)
            e_pos = target - placement.translation
            e = e_pos if rotation is None else np.concatenate([e_pos, pin.log3(rotation @ placement.rotation.T)])
            if np.linalg.norm(e_pos) <= position_tolerance and (
                    rotation is None or np.linalg.norm(e[3:]) <= orientation_tolerance):
                done = True
                break
            jac = pin.computeFrameJacobian(model, data, full, fid, pin.LOCAL_WORLD_ALIGNED)[:rows, robot.idx_v]
            dq = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(rows), e)
            norm = float(np.linalg.norm(dq))
            if norm > max_step:
                dq *= max_step / norm
            q = np.clip(q + dq, lower, upper)
        if not done:
            continue
        converged += 1
        if not bool(np.asarray(valid(q[None]))[0]):
            continue
        if kept and float(np.min(space.distance(np.array(kept), q))) < diversity:
            continue
        kept.append(q)
        p_err.append(float(np.linalg.norm(e_pos)))
        o_err.append(0.0 if rotation is None else float(np.linalg.norm(e[3:])))
        if len(kept) >= solutions:
            break
    d = space.dim
    return IKResult(np.array(kept).reshape(-1, d), np.array(p_err), np.array(o_err), tried, converged)
