"""The six action primitives and APPLY_ACTION in any simulator that can push and place objects (poster ICHR 2010:
"Six action primitives defined for interacting with objects in the robot's workspace"; LEARN_MODEL line 4).

The poster's figure of the primitives is missing from the text; the six chosen here are the four pushes on the
middle of each side of the object (each toward the opposite side, along the object's own axes) and two turning
pushes, which press near one end of a long side, at right angles to the line from the object's centre to the
contact, so that the object turns counter-clockwise (``turn+``) or clockwise (``turn-``) about z (a circle is
pushed off its centre line instead: sideways and forward).  Every primitive is defined in the object's frame, so
its displacement model ``P(delta s | a, o)`` (:mod:`pliant_tsrrt.models`) holds wherever the object stands.

A push is executed by the robot (a flat paddle, the scene's SE(2) rigid robot) through the core's
:class:`~pliant.interfaces.Simulator` interface only: the paddle is placed ``gap`` behind the contact point, facing
the push direction (``reset`` then :meth:`~pliant.interfaces.Simulator.set_object_poses` to keep the objects where
they are: the real robot lifts its paddle between pushes), driven ``gap + depth`` along the push direction
(``turn_depth`` for turning pushes, which meet the object with the paddle's narrow end) at ``speed`` (velocity
commands through ``step``; contact and friction are the simulator's), backed off ``retreat`` and held still for
``settle`` s while the objects come to rest.
"""

from __future__ import annotations

from collections.abc import Generator
from types import SimpleNamespace

import numpy as np
from pliant.api import Move, Observation, Place

from pliant_tsrrt.geometry import CIRCLE, Footprints, wrap
from pliant_tsrrt.options import PushSettings

PRIMITIVES = ("push+x", "push-x", "push+y", "push-y", "turn+", "turn-")

#: the primitives of one stroke: pushes along +x, -x, +y, -y of the object's frame and turns +, - (the models' order)
N_PRIMITIVES = len(PRIMITIVES)


def decode_action(action: int, strokes: tuple[float, ...]) -> tuple[int, int, float]:
    """Action ``a = P o + p`` of a plan pushing with ``strokes`` (``P = 6 len(strokes)``; ``planning.strokes``) as
    ``(object o, primitive p % 6 of PRIMITIVES, stroke strokes[p // 6]: a fraction of the primitive's depth)``."""
    o, p = divmod(int(action), N_PRIMITIVES * len(strokes))
    return o, p % N_PRIMITIVES, strokes[p // N_PRIMITIVES]


def contact_frames(fp: Footprints, turn_offset: float) -> tuple[np.ndarray, np.ndarray]:
    """Contact points ``c`` ``(k, 6, 2)`` and unit push directions ``u`` ``(k, 6, 2)`` of the six primitives in each
    object's frame (m).  Turning pushes press on the long sides (boxes) at ``turn_offset`` of the half length."""
    k = len(fp)
    hx, hy = fp.half[:, 0], fp.half[:, 1]
    c = np.zeros((k, 6, 2))
    u = np.zeros((k, 6, 2))
    c[:, 0] = np.stack([-hx, 0 * hx], -1)
    u[:, 0] = (1.0, 0.0)
    c[:, 1] = np.stack([hx, 0 * hx], -1)
    u[:, 1] = (-1.0, 0.0)
    c[:, 2] = np.stack([0 * hy, -hy], -1)
    u[:, 2] = (0.0, 1.0)
    c[:, 3] = np.stack([0 * hy, hy], -1)
    u[:, 3] = (0.0, -1.0)
    long_x = hx >= hy
    f = turn_offset
    # turn+ (counter-clockwise): at f of the long side's half length from the middle, on the -y side (long x) or the
    # +x side (long y), pushing at right angles to the contact's radius (the largest torque for the force); turn-
    # (clockwise): the same corner seen from the other long side (+y side, or -x side), so the two turns need room on
    # different sides of the object
    c[:, 4] = np.where(long_x[:, None], np.stack([f * hx, -hy], -1), np.stack([hx, f * hy], -1))
    c[:, 5] = np.where(long_x[:, None], np.stack([f * hx, hy], -1), np.stack([-hx, f * hy], -1))
    for col, sign in ((4, 1.0), (5, -1.0)):
        r = c[:, col]
        perp = sign * np.stack([-r[:, 1], r[:, 0]], -1)
        u[:, col] = perp / np.linalg.norm(perp, axis=-1, keepdims=True)
    circle = fp.kind == CIRCLE
    if circle.any():   # a circle: pushed along +y off its centre line (a glancing push, sideways and forward)
        c[circle, 4] = np.stack([f * hx[circle], -hy[circle]], -1)
        c[circle, 5] = np.stack([-f * hx[circle], -hy[circle]], -1)
        u[circle, 4:6] = (0.0, 1.0)
    return c, u


def paddle_sweeps(poses: np.ndarray, fp: Footprints, settings: PushSettings) -> tuple[np.ndarray, np.ndarray,
                                                                                         np.ndarray]:
    """For objects at ``poses`` ``(n, k, 3)``: the paddle's start pose ``(n, k, 6, 3)`` for every primitive, and the
    area it sweeps until the end of the push as boxes: centre poses ``(n, k, 6, 3)`` and half extents
    ``(k, 6, 2)`` (m, rad; the boxes' x axis is the push direction).

    Side pushes meet the object with the paddle's face (the paddle across the push direction); turning pushes with
    its narrow end (the paddle turned along the push direction), a near point contact, so the object can turn
    about it -- a face flush with the object's side would hold the side parallel to it and barely turn it."""
    c, u = contact_frames(fp, settings.turn_offset)
    s = settings
    turning = np.array([False, False, False, False, True, True])
    along = np.where(turning, s.width, s.thickness)                          # paddle extent along the push (6,)
    across = np.where(turning, s.thickness, s.width)
    back = s.push_gap + 0.5 * along
    theta = poses[..., 2][..., None]                                          # (n, k, 1)
    cos, sin = np.cos(theta), np.sin(theta)

    def world(p):                                                            # object frame -> world, (n, k, 6, 2)
        return np.stack([cos * p[..., 0] - sin * p[..., 1], sin * p[..., 0] + cos * p[..., 1]], -1) \
            + poses[..., None, :2]

    uw = np.stack([cos * u[..., 0] - sin * u[..., 1], sin * u[..., 0] + cos * u[..., 1]], -1)
    heading = np.arctan2(uw[..., 1], uw[..., 0])
    start = world(c - back[:, None] * u)
    travel = s.push_gap + np.where(turning, s.turn_depth, s.push_depth)      # (6,)
    centre = start + 0.5 * travel[:, None] * uw
    yaw = heading + np.where(turning, 0.5 * np.pi, 0.0)
    start_pose = np.concatenate([start, yaw[..., None]], -1)
    sweep_pose = np.concatenate([centre, heading[..., None]], -1)
    half = np.stack(np.broadcast_arrays(0.5 * (travel + along), 0.5 * across), -1)   # (6, 2)
    half = np.broadcast_to(half, c.shape).copy()
    return start_pose, sweep_pose, half


def paddle_sweep_rows(poses: np.ndarray, objs: np.ndarray, prims: np.ndarray, fp: Footprints,
                      settings: PushSettings, frames: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[
                          np.ndarray, np.ndarray]:
    """The swept boxes of :func:`paddle_sweeps` for one (object, primitive) per row: object ``objs[j]`` at
    ``poses[j]`` ``(m, 3)`` pushed with ``prims[j]``; returns the boxes' centre poses ``(m, 3)`` and half extents
    ``(m, 2)``.  ``frames``: :func:`contact_frames` of ``fp`` (computed when not given)."""
    c, u = frames if frames is not None else contact_frames(fp, settings.turn_offset)
    s = settings
    turning = prims >= 4
    along = np.where(turning, s.width, s.thickness)
    across = np.where(turning, s.thickness, s.width)
    travel = s.push_gap + np.where(turning, s.turn_depth, s.push_depth)
    cj, uj = c[objs, prims], u[objs, prims]                                  # (m, 2)
    cos, sin = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    uw = np.stack([cos * uj[:, 0] - sin * uj[:, 1], sin * uj[:, 0] + cos * uj[:, 1]], -1)
    local = cj + (0.5 * travel - s.push_gap - 0.5 * along)[:, None] * uj     # the box's centre in the object frame
    centre = np.stack([cos * local[:, 0] - sin * local[:, 1], sin * local[:, 0] + cos * local[:, 1]], -1) \
        + poses[:, :2]
    pose = np.concatenate([centre, np.arctan2(uw[:, 1], uw[:, 0])[:, None]], -1)
    return pose, np.stack([0.5 * (travel + along), 0.5 * across], -1)


#: how far (m) the guarded approach goes beyond the nominal gap, in placement-noise standard deviations, before it
#: gives up waiting for contact and pushes the depth from there
GUARD_REACH = 4.0


#: a turn (rad) of the pushed object that also counts as the contact of a guarded approach
GUARD_TURN = 0.005


def push_steps(names: list[str], fp: Footprints, index: int, primitive: int, settings: PushSettings,
               rng: np.random.Generator, seen) -> Generator[Place | Move, Observation, dict[str, np.ndarray]]:
    """APPLY_ACTION (poster, LEARN_MODEL line 4) as the directives of the core's execution loop
    (:func:`pliant.api.follow`): push object ``names[index]`` with primitive ``primitive`` (an index into
    :data:`PRIMITIVES`) from where ``seen`` (the last :class:`~pliant.api.Observation`, or anything with the
    ``objects``' poses by name) shows the objects, and return
    every movable object's pose afterwards, by name.  The paddle's placement error is drawn from ``rng``
    (``settings.placement_noise``).  The directives may fail (``recover``): a placement or a step the simulator refuses
    is raised at the ``yield`` (the plan's strategy skips the push and replans).  The one definition of a push: an
    execution follows it through the loop, the learner through :func:`apply_action`."""
    s = settings
    poses = dict(seen.objects)
    pose = np.asarray(poses[names[index]], dtype=np.float64)
    start, sweep, _ = paddle_sweeps(pose[None, None], fp.subset([index]), s)
    q = start[0, 0, primitive].copy()
    direction = sweep[0, 0, primitive, 2]
    heading = np.array([np.cos(direction), np.sin(direction)])
    if s.placement_noise > 0:
        along, across = rng.normal(0.0, s.placement_noise, 2)
        q[:2] += along * heading + across * np.array([-heading[1], heading[0]])
    seen = yield Place(q, poses, recover=True)
    depth = s.turn_depth if PRIMITIVES[primitive].startswith("turn") else s.push_depth
    if s.guard_step > 0:
        # a guarded move (approach until contact, then push): advance in steps of guard_step until the object has
        # moved by half a step or turned by GUARD_TURN (the contact; at most push_gap plus GUARD_REACH placement-noise
        # deviations), then depth further.  The object's motion stands in for a force sensor's contact signal.
        name = names[index]
        first = np.asarray(seen.objects[name], dtype=np.float64)
        reach = s.push_gap + GUARD_REACH * s.placement_noise + s.guard_step
        travelled = 0.0
        while travelled < reach:
            seen = yield _move(heading * s.push_speed, s.guard_step / s.push_speed, s.control_period)
            travelled += s.guard_step
            now = np.asarray(seen.objects[name], dtype=np.float64)
            if np.hypot(*(now[:2] - first[:2])) > 0.5 * s.guard_step or abs(wrap(now[2] - first[2])) > GUARD_TURN:
                break
        seen = yield _move(heading * s.push_speed, depth / s.push_speed, s.control_period)
    else:
        seen = yield _move(heading * s.push_speed, (s.push_gap + depth) / s.push_speed, s.control_period)
    if s.retreat > 0:
        seen = yield _move(-heading * s.push_speed, s.retreat / s.push_speed, s.control_period)
    seen = yield _move(np.zeros(2), s.settle, s.control_period)
    return {n: np.asarray(p, dtype=np.float64).copy() for n, p in seen.objects.items()}


def _move(velocity: np.ndarray, duration: float, period: float) -> Move:
    """The planar ``velocity`` (m/s, no turning) for ``duration`` s in steps of at most ``period``."""
    return Move(np.array([velocity[0], velocity[1], 0.0]), duration, period, recover=True)


def apply_action(world, names: list[str], fp: Footprints, index: int, primitive: int, settings: PushSettings,
                 rng: np.random.Generator, poses: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """APPLY_ACTION while the models are learned (LEARN_MODEL, before any plan exists): the push of
    :func:`push_steps` applied to ``world`` (a :class:`~pliant.interfaces.Simulator` that can place objects)
    directly, without the execution loop's recording; returns every movable object's pose afterwards, by name.
    ``poses``: where the objects are now (default: asked from the world).  A refused placement or step raises its
    :class:`~pliant.api.SimulationError`."""
    now = SimpleNamespace(objects=dict(world.object_poses()) if poses is None else
                          {n: np.asarray(p, float) for n, p in poses.items()})
    steps = push_steps(names, fp, index, primitive, settings, rng, now)
    directive = next(steps)
    while True:
        if isinstance(directive, Place):
            world.reset(np.asarray(directive.configuration, dtype=np.float64))
            world.set_object_poses(directive.objects)
            result = "placed"
        else:
            n = max(1, int(np.ceil(directive.duration / directive.period - 1e-9)))
            h = directive.duration / n
            for _ in range(n):
                world.step(directive.velocity, h, rng)
            result = "moved"
        try:
            directive = steps.send(Observation(result, 0.0, np.inf, world))
        except StopIteration as stop:
            return stop.value
