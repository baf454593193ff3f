"""The contact motion controller (thesis app. C).

It commands the target without modification and watches the recent trajectory.  When the total
motion over a sliding window falls below ``stuck_distance``, the robot is stuck against a surface:

* ``mode = "plane"`` (SE(2)/SE(3) bodies): fit a plane (point ``P``, normal ``N``) to the window's
  configurations (in tangent coordinates: ``P`` their centroid, the plane spanned by the directions
  they moved along, ``N`` the target error's component orthogonal to those) and move the target
  toward it, eq. 8.6:
  ``q'_target = q_target + ((P - q_target) . N / (N . N)) N * (i eps_adjust)`` on the i-th
  consecutive stuck iteration;
* ``mode = "predict"`` (multi-link robots): forward-simulate from the stuck configuration toward the
  target with the context's simulator for one period and interpolate from the target toward the
  simulated configuration by ``i eps_adjust``.

* ``mode = "track"`` (model-predictive, thesis 5.4.4): every control step the commanded target is the
  pipeline's simulator's configuration ``horizon`` s (default one period) after ``q`` toward the target, so a
  dynamic robot follows the compliant motion the planner simulated instead of pressing into a face; stuck
  detection and giving up are unchanged, and no further adjustment is made.

When the robot moves again the original target is commanded; ``i`` resets to 0 only once the robot has
come closer to the original target than it ever was during this drive, by at least ``stuck_distance``
(app. C resets ``i`` whenever the robot moves; an adjustment that frees the robot sideways would then reset
it each time and a robot pressed against a face forever would never give up — seen on Baxter in pybullet,
every drive into a wall ran to its time limit).  When ``i eps_adjust >= eps_adjust_max`` the controller
gives up (``gave_up``): "completely stuck".
The command is ``gain * difference(target', q)`` (tangent units per second); the simulator applies
its velocity limits.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from pliant.api import Controller, PlanningError, SimulationError, option, stream


@dataclass(frozen=True)
class ContactControllerOptions:
    """Options of :class:`ContactMotionController` (thesis app. C: eps_adjust 0.01, eps_adjust_max 1.0)."""

    gain: float = option(5.0, "proportional gain (1/s): commanded velocity = gain * error", minimum=0.0)
    tolerance: float = option(0.05, "distance (space metric) at which a target counts as reached", minimum=0.0)
    window: int = option(5, "control steps in the stuck-detection window", minimum=2)
    stuck_distance: float = option(0.01, "stuck when the window's total motion (space metric) is below this",
                                   minimum=0.0)
    eps_adjust: float = option(0.01, "fraction of the way to the plane added per stuck iteration", minimum=0.0)
    eps_adjust_max: float = option(1.0, "give up when i * eps_adjust reaches this", minimum=0.0)
    horizon: float | None = option(None, "predict and track modes: seconds simulated ahead toward the target; "
                                   "default one control period (thesis app. C)", minimum=1e-6)
    mode: str = option("plane", "target adjustment: plane (fit, eq. 8.6), predict (kinematic simulator, app. C) "
                       "or track (follow the kinematic simulator's prediction every step, see the module doc)",
                       choices=("plane", "predict", "track"))


class ContactMotionController(Controller):
    """P control toward a target with stuck detection and target adjustment (thesis app. C)."""

    Options = ContactControllerOptions
    example_scene = "se2-maze"

    def bind(self, context) -> None:
        super().bind(context)
        self.space = self.require("robot").space
        if self.options.mode in ("predict", "track") and context.simulator is None:
            raise PlanningError(f"mode '{self.options.mode}' needs a simulator in the pipeline",
                                field="controller.mode", value=self.options.mode)
        self.reset()

    def reset(self) -> None:
        self.history: deque[np.ndarray] = deque(maxlen=self.options.window + 1)
        self.stuck_iterations = 0
        self.gave_up = False
        self.adjusted_target: np.ndarray | None = None
        self.closest: float = np.inf            # closest distance to the commanded target in this drive
        self._target: np.ndarray | None = None
        # the predictions' actuation noise: one reproducible stream per drive, from the run's seed (pliant.seeds: the
        # execution stage's sub-stream "contact-prediction", drive k) -- a generator re-seeded every call would
        # repeat the same draws, a fixed bias of up to the noise bound on every joint, every step
        self._drives = getattr(self, "_drives", -1) + 1
        seed = getattr(getattr(self, "context", None), "seed", 0) or 0
        self._prediction_rng = stream(int(seed), "execution", "contact-prediction", self._drives)
        #: control steps of this drive whose measured configuration the prediction simulator refused as a start
        self.refused_predictions = 0

    def reached(self, q, target) -> bool:
        return bool(self.space.distance(q, target) <= self.options.tolerance)

    def is_stuck(self) -> bool:
        """Whether the window is full and its total motion is below ``stuck_distance``."""
        if len(self.history) <= self.options.window:
            return False
        states = np.array(self.history)
        return float(np.sum(self.space.distance(states[:-1], states[1:]))) < self.options.stuck_distance

    def command(self, q, target, dt):
        q = np.asarray(q, dtype=np.float64)
        target = np.asarray(target, dtype=np.float64)
        if self._target is None or not np.array_equal(target, self._target):
            self._target, self.closest, self.stuck_iterations = target.copy(), np.inf, 0
        self.history.append(q.copy())
        distance = float(self.space.distance(q, target))
        progressed = distance <= self.closest - self.options.stuck_distance
        if progressed:
            self.closest = distance
        stuck = self.is_stuck()
        if stuck:
            self.stuck_iterations += 1
            if self.stuck_iterations * self.options.eps_adjust >= self.options.eps_adjust_max:
                self.gave_up = True
                return np.zeros(self.space.tangent_dim)
        elif progressed:
            self.stuck_iterations = 0
        if self.options.mode == "track":
            goal = self._predict(q, target, dt)
        elif stuck:
            goal = self._adjust(q, target, self.stuck_iterations * self.options.eps_adjust, dt)
        else:
            goal = target
        self.adjusted_target = goal
        return self.options.gain * self.space.difference(goal, q)

    def _predict(self, q, target, dt):
        """The pipeline's simulator's configuration ``horizon`` s (default one period) after ``q``, driven toward
        ``target`` (its noise from one reproducible stream per drive)."""
        horizon = dt if self.options.horizon is None else self.options.horizon
        try:
            return self.context.simulator.simulate(q[None], target, self._prediction_rng, horizon).final[0]
        except SimulationError:
            # the simulator refuses a start inside one of its obstacles: the measured configuration lies deeper in
            # the model's geometry than the world let it (a dynamic world's or a robot's contact, a model that
            # differs), so there is nothing to predict from; aim at the target this period, as without a prediction
            self.refused_predictions += 1
            return target

    def _adjust(self, q, target, fraction, dt):
        if self.options.mode == "predict":
            return self.space.interpolate(target, self._predict(q, target, dt), min(fraction, 1.0))
        states = np.array(self.history)
        offsets = self.space.difference(states, states[0])        # tangent coordinates of the window
        centre = offsets.mean(axis=0)
        error = self.space.difference(target, states[0]) - centre
        _, singular, vt = np.linalg.svd(offsets - centre)
        # The fitted plane contains the directions the window actually moved along; its normal is the
        # part of the target error orthogonal to them (in more than two dimensions a window of sliding
        # motion spans too few directions to fix a plane by itself).  A window that did not move at
        # all leaves the whole error as the normal.
        significant = vt[: self.space.tangent_dim - 1][singular[: self.space.tangent_dim - 1]
                                                       > 1e-6 * max(1.0, singular[0])]
        normal = error - significant.T @ (significant @ error)
        if normal @ normal < 1e-18:
            return target
        adjustment = ((-error) @ normal) / (normal @ normal) * normal
        return self.space.retract(target, adjustment * fraction)
