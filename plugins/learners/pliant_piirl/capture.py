"""Capturing a person's demonstration (thesis 4.3.1): a probe driven by keys, its path recorded.

:class:`CaptureSession` is the tool's model, independent of any window: it holds the task, the probe's current
configuration and the path so far.  Each key moves the probe one step; a step that would take any probe point
outside the task's collision planes, or into an infeasible state (outside the scene, a rigid collision), is
refused, as the thesis's planes constrained its users.  The state it reports after every key is what a person
needs to decide the next one: the tip's distance to the target, what the probe deforms now, and the deformation
of the path so far.  :meth:`CaptureSession.demonstration` returns the recorded path as a demonstration.

Keys (one step each; lengths in ``step`` m, angles in ``turn`` rad; rotations turn the probe about its tip):

====================  =====================================================
``i`` / ``k``          insert along the probe's axis / retract
``a`` / ``d``          move along -x / +x
``s`` / ``w``          move along -y / +y
``f`` / ``r``          move along -z / +z
``t`` / ``g``          turn about the world x axis, + / -
``y`` / ``h``          turn about the world y axis, + / -
``u`` / ``j``          turn about the world z axis, + / -
``z``                  undo the last step
====================  =====================================================

A planar robot (SE(2)) moves in the plane: ``i`` / ``k`` along its body x axis, ``u`` / ``j`` turn it about the
world z axis, and turns out of the plane do nothing.  For a task with a goal configuration, "reached" means
within ``tolerance`` of it in the space's metric (the thesis's planar environment, captured in the kinematic
model the planners use).

Front ends: the browser page of :mod:`pliant_piirl.capture_server` (``pliant learn capture``), and a scripted key
sequence (``pliant learn capture --keys``), which is also how the tool is tested headless.
"""

from __future__ import annotations

import numpy as np
from pliant.api import ConfigError

from pliant_piirl.demonstration import Demonstration, DemonstrationTask

KEYS = {"i": ("insert", 1), "k": ("insert", -1), "a": ("move", (-1, 0, 0)), "d": ("move", (1, 0, 0)),
        "s": ("move", (0, -1, 0)), "w": ("move", (0, 1, 0)), "f": ("move", (0, 0, -1)), "r": ("move", (0, 0, 1)),
        "t": ("turn", (1, 0, 0)), "g": ("turn", (-1, 0, 0)), "y": ("turn", (0, 1, 0)), "h": ("turn", (0, -1, 0)),
        "u": ("turn", (0, 0, 1)), "j": ("turn", (0, 0, -1)), "z": ("undo", None)}


class CaptureSession:
    """A demonstration being recorded for ``task`` with ``features`` (a ``DeformationFeatures`` of the scene) and a
    rigid probe whose ``tip`` (body frame, m) must reach the target within ``tolerance`` m."""

    def __init__(self, features, task: DemonstrationTask, tip, *, step: float = 0.002, turn: float = 0.02,
                 tolerance: float = 0.004) -> None:
        for name, value in (("step", step), ("turn", turn), ("tolerance", tolerance)):
            if not (np.isfinite(value) and value > 0):
                raise ConfigError("must be a positive number", field=name, value=value)
        self.features, self.task = features, task
        self.robot = features.robot
        self.tip = np.asarray(tip, dtype=np.float64)
        self.step, self.turn, self.tolerance = float(step), float(turn), float(tolerance)
        if self.robot.rigid_placement(task.start[None]) is None:
            raise ConfigError("the capture tool drives a rigid probe", field="robot", value=features.scene.robot.kind)
        if not self._allowed(task.start):
            raise ConfigError("the task's start leaves the workspace or its collision planes, or is infeasible",
                              field="task.start",
                              value=task.start.tolist())
        self.path = [task.start.copy()]
        self.refused = 0
        self.planar = getattr(features.space, "kind", "") == "se2"

    @property
    def configuration(self) -> np.ndarray:
        return self.path[-1]

    def tip_position(self, q: np.ndarray | None = None) -> np.ndarray:
        rot, pos, _ = self.robot.rigid_placement((self.configuration if q is None else q)[None])
        return rot[0] @ self.tip + pos[0]

    def press(self, key: str) -> dict:
        """Apply one key (see the module docstring); returns :meth:`state` with ``accepted``."""
        if key not in KEYS:
            raise ConfigError(f"unknown key (keys: {''.join(KEYS)})", field="key", value=key)
        action, arg = KEYS[key]
        if action == "undo":
            accepted = len(self.path) > 1
            if accepted:
                self.path.pop()
            return {**self.state(), "accepted": accepted}
        q = self._moved(action, np.asarray(arg, dtype=np.float64))
        moved = not np.array_equal(q, self.configuration)
        accepted = moved and self._allowed(q) and self._allowed_motion(self.configuration, q)
        if accepted:
            self.path.append(q)
        else:
            self.refused += 1
        return {**self.state(), "accepted": accepted}

    def _moved(self, action: str, arg) -> np.ndarray:
        from scipy.spatial.transform import Rotation

        q = self.configuration.copy()
        if self.planar:
            return self._moved_planar(q, action, arg)
        rot = Rotation.from_quat(q[3:])
        if action == "insert":
            axis = rot.apply([0.0, 0.0, 1.0])                 # body z points from the tip backwards
            q[:3] -= arg * self.step * axis
        elif action == "move":
            q[:3] += self.step * arg
        else:                                                 # turn about the tip
            tip = self.tip_position()
            turned = Rotation.from_rotvec(self.turn * arg) * rot
            q[3:] = turned.as_quat()
            q[:3] = tip - turned.apply(self.tip)
        return q

    def _moved_planar(self, q: np.ndarray, action: str, arg) -> np.ndarray:
        """SE(2): ``i`` / ``k`` along the body's x axis, moves in the plane, turns about the world z axis only."""
        if action == "insert":
            q[:2] += arg * self.step * np.array([np.cos(q[2]), np.sin(q[2])])
        elif action == "move":
            q[:2] += self.step * arg[:2]
        elif arg[2] != 0:
            q[2] = (q[2] + self.turn * arg[2] + np.pi) % (2 * np.pi) - np.pi
        else:
            return q                                          # a turn out of the plane: no motion
        return q

    def _allowed(self, q: np.ndarray) -> bool:
        if not bool(np.asarray(self.features.space.is_valid(q[None])).reshape(-1)[0]):
            return False                                      # out of the workspace: no step leaves it
        points = self.robot.body_points(q[None])[0]
        return bool(self.task.allows(points).all()) and bool(np.all(np.isfinite(self.features.cost.breakdown(q[None]))))

    def _allowed_motion(self, a: np.ndarray, b: np.ndarray) -> bool:
        states = self.features.states(np.array([a, b]))
        return bool(self.task.allows(self.robot.body_points(states)).all())

    def state(self) -> dict:
        """What the person sees: configuration, tip, distance to the target (m), ``reached``, the deformation now
        and along the path so far (robot points per object), steps recorded and refused."""
        tip = self.tip_position()
        now = self.features.cost.breakdown(self.configuration[None])[0]
        path = self.features.of_path(np.array(self.path)) if len(self.path) > 1 else np.zeros(len(now))
        if self.task.goal is not None:                       # a goal configuration: its distance in the space
            distance = float(self.features.space.distance(self.configuration, self.task.goal))
        else:
            distance = float(np.linalg.norm(tip - self.task.target))
        return {"configuration": self.configuration.tolist(), "tip": tip.tolist(), "target": self.task.target.tolist(),
                "distance": distance, "reached": distance <= self.tolerance,
                "deformation": dict(zip(self.features.names, now.tolist())),
                "path_deformation": dict(zip(self.features.names, path.tolist())), "steps": len(self.path) - 1,
                "refused": self.refused}

    def demonstration(self) -> Demonstration:
        """The recorded path as a demonstration; an error until the tip has reached the target."""
        if not self.state()["reached"]:
            what = "the goal" if self.task.goal is not None else "the target"
            raise ConfigError(f"the {'robot' if self.task.goal is not None else 'tip'} is "
                              f"{self.state()['distance'] * 1000:.1f} mm from {what} (within "
                              f"{self.tolerance * 1000:.1f} mm needed)", field="capture", value=len(self.path) - 1)
        return Demonstration(self.task, np.array(self.path), "capture")

    def play(self, keys: str) -> dict:
        """Press every key of ``keys`` in turn (whitespace ignored); returns the last state."""
        state = self.state()
        for key in keys:
            if not key.isspace():
                state = self.press(key)
        return state
