"""Executing a path with a controller through any simulator, step by step (thesis 5.4, app. C).

:func:`execute` resets the simulator at the path's first configuration, then for each waypoint asks
the controller for velocity commands at the control period until the controller reports the
waypoint reached, gives up (stuck), or the time limit passes.  Everything is recorded, so the
outcome can be drawn and replayed.  :func:`drive` is one such motion toward one target without a reset,
the primitive that policy execution (thesis 5.3.5) builds on.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pliant.errors import DimensionError
from pliant.interfaces import Controller, Simulator
from pliant.results import Path


@dataclass
class ExecutionRecord:
    """What happened during an execution.

    configurations: ``(k, d)`` states after every control step (the first is the start).
    times: ``(k,)`` seconds.  contacts: ``(k,)`` whether the robot touched anything in that step.
    waypoints_reached: how many waypoints (after the start) were reached.
    outcome: ``reached`` (the last waypoint), ``stuck`` (the controller gave up) or ``timeout``.
    objects: the movable objects' poses ``(k, p)`` by name (:meth:`Simulator.object_poses`: ``(x, y, theta)``
    in planar scenes, else position and quaternion); empty for simulators that hold objects fixed.
    """

    configurations: np.ndarray
    times: np.ndarray
    contacts: np.ndarray
    waypoints_reached: int
    outcome: str
    events: list[str] = field(default_factory=list)
    objects: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.outcome == "reached"

    def to_dict(self) -> dict:
        return {"configurations": self.configurations.tolist(), "times": self.times.tolist(),
                "contacts": self.contacts.tolist(), "waypoints_reached": self.waypoints_reached,
                "outcome": self.outcome, "events": list(self.events),
                "objects": {name: poses.tolist() for name, poses in self.objects.items()}}


def drive(simulator: Simulator, controller: Controller, target: np.ndarray, rng: np.random.Generator, *,
          period: float = 0.1, time_limit: float = 60.0, start_time: float = 0.0,
          poses: list[dict[str, np.ndarray]] | None = None
          ) -> tuple[list[np.ndarray], list[float], list[bool], str]:
    """Drive the robot from wherever the simulator holds it toward ``target`` ``(d,)`` (no reset).

    The controller is reset, then commands velocities every ``period`` s until it reports the target
    reached, gives up (``gave_up``: stuck, thesis app. C) or ``time_limit`` s have passed.  Returns the
    states ``(d,)`` after every control step, their times (s, counted from ``start_time``), whether each step
    touched anything, and the outcome ``reached`` / ``stuck`` / ``timeout``.  With ``poses``, the movable
    objects' poses after every step are appended to it.
    """
    if not (period > 0 and time_limit >= 0):
        raise DimensionError("period must be positive and time_limit non-negative (s)", field="period/time_limit",
                             value=(period, time_limit))
    target = np.asarray(target, dtype=np.float64)
    controller.reset()
    q = simulator.configuration()
    deadline = start_time + time_limit
    t = start_time
    states: list[np.ndarray] = []
    times: list[float] = []
    contacts: list[bool] = []
    while True:
        if controller.reached(q, target):
            return states, times, contacts, "reached"
        if getattr(controller, "gave_up", False):
            return states, times, contacts, "stuck"
        if t >= deadline - 1e-12:
            return states, times, contacts, "timeout"
        velocity = controller.command(q, target, period)
        q = simulator.step(velocity, period, rng)
        t += period
        states.append(q.copy())
        times.append(t)
        contacts.append(simulator.in_contact())
        if poses is not None:
            poses.append(simulator.object_poses())


def execute(simulator: Simulator, controller: Controller, path: Path, rng: np.random.Generator, *,
            period: float = 0.1, time_limit: float = 60.0) -> ExecutionRecord:
    """Follow ``path`` waypoint by waypoint with ``controller`` in ``simulator`` (reset at the first waypoint).

    ``period`` is the control period (s); ``time_limit`` the total budget (s).  Each waypoint is one
    :func:`drive`.
    """
    if not (period > 0 and time_limit > 0):
        raise DimensionError("period and time_limit must be positive seconds", field="period/time_limit",
                             value=(period, time_limit))
    waypoints = np.atleast_2d(path.configurations)
    simulator.reset(waypoints[0])
    q = simulator.configuration()
    states, times, contacts, events = [q.copy()], [0.0], [False], []
    objects = [simulator.object_poses()]
    t = 0.0
    reached = 0
    outcome = "timeout"
    for index, target in enumerate(waypoints[1:], start=1):
        s, ts, cs, result = drive(simulator, controller, target, rng, period=period,
                                  time_limit=max(0.0, time_limit - t), start_time=t, poses=objects)
        states += s
        times += ts
        contacts += cs
        if ts:
            t = ts[-1]
        if result == "reached":
            reached = index
            continue
        if result == "stuck":
            outcome = "stuck"
            events.append(f"t={t:.2f}s: stuck before waypoint {index}")
        break
    else:
        outcome = "reached"
    if outcome == "timeout" and reached != len(waypoints) - 1:
        events.append(f"t={t:.2f}s: time limit before waypoint {reached + 1}")
    names = objects[0]
    poses = {name: np.array([step[name] for step in objects], dtype=np.float64) for name in names}
    return ExecutionRecord(np.array(states), np.array(times), np.array(contacts), reached, outcome, events, poses)
