"""The simulator kind and the checks in front of its entry points (starts inside obstacles are refused).
"""

from __future__ import annotations

import functools
import math
from abc import abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pliant.components.base import Component, check_batch
from pliant.components.checks import WRAPPED, _space_of, check_duration, check_rng, check_vector
from pliant.errors import (
    DimensionError,
    SimulationError,
)

if TYPE_CHECKING:
    from pliant.execution.actuation import ControlLaw


#: set on a simulator once its stepping state is known to be a free start (a checked ``reset``, or a checked first
#: ``step`` from the state ``bind`` left)
START_CHECKED = "_pliant_start_checked"


#: at most this many offending indices are listed in the error of a batch
LISTED_STARTS = 8


def refused_starts(simulator, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The configurations ``starts`` ``(n, d)`` that put the robot deeper inside a rigid obstacle than the simulator
    tolerates -- the starts :func:`check_starts` refuses: their indices, and every start's depth (m, from
    :meth:`~pliant.interfaces.Simulator.start_penetration`; NaN counts as inside; compared with
    :attr:`~pliant.interfaces.Simulator.start_tolerance`).  None refused when the simulator cannot tell."""
    depth = simulator.start_penetration(starts) if len(starts) else None
    if depth is None:
        return np.zeros(0, dtype=np.intp), np.zeros(len(starts))
    depth = np.asarray(depth, dtype=np.float64).reshape(-1)
    return np.nonzero(~(depth <= float(simulator.start_tolerance)))[0], depth


def check_starts(simulator, starts: np.ndarray, *, field: str, single: bool = False) -> None:
    """Refuse configurations ``starts`` ``(n, d)`` that put the robot inside a rigid obstacle.

    The simulator measures (:meth:`~pliant.interfaces.Simulator.start_penetration`, m per configuration; ``None``:
    it cannot tell, nothing is refused) and tolerates :attr:`~pliant.interfaces.Simulator.start_tolerance` (m, the
    contact slop of its own states).  Deeper (or NaN) is a :class:`~pliant.errors.SimulationError` naming the field
    (``field`` for one configuration, ``field[k]`` for the first offending one of a batch, with the others' indices
    listed), the configuration and, where the simulator can say, the obstacle.  Nothing is simulated then.
    """
    bad, depth = refused_starts(simulator, starts)
    if len(bad) == 0:
        return
    tolerance = float(simulator.start_tolerance)
    k = int(bad[0])
    name = field if single else f"{field}[{k}]"
    what = simulator.describe_obstacle(starts[k]) or "an obstacle"
    amount = "at an unknown depth" if not math.isfinite(depth[k]) else f"{depth[k]:.4g} m"
    message = (f"places the robot {amount} inside {what} (this simulator tolerates {tolerance:.4g} m of contact); "
               "start it in free space")
    if len(bad) > 1:
        listed = ", ".join(str(int(i)) for i in bad[:LISTED_STARTS]) + (", ..." if len(bad) > LISTED_STARTS else "")
        message += f"; {len(bad)} of the {len(starts)} {field} are inside: indices {listed}"
    raise SimulationError(message, field=name, value=np.asarray(starts[k]).tolist())


def checked_reset(method):
    """Wrap a simulator's ``reset(q)``: ``q`` must be a finite configuration inside the space's bounds (a robot placed
    outside the workspace would jump back in one step) that does not put the robot inside an obstacle
    (:func:`check_starts`).  A refused reset changes nothing."""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def reset(self, q, *args, **kwargs):
        space = _space_of(self)
        if space is not None:
            q = space.check(q, field="reset")
            if q.ndim != 1:
                raise DimensionError("must be one configuration", field="reset", value=list(q.shape))
            check_starts(self, q[None], field="reset", single=True)
        out = method(self, q, *args, **kwargs)
        if space is not None:
            self.__dict__[START_CHECKED] = True
        return out

    setattr(reset, WRAPPED, True)
    return reset


def checked_simulate(method):
    """Wrap a simulator's ``simulate(starts, targets, rng, duration, record=False)``: ``starts`` must be finite
    configurations of the space (``(n, d)`` or ``(d,)``), none of them inside an obstacle (:func:`check_starts`,
    naming ``starts[k]``); a refused batch simulates no particle."""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def simulate(self, starts, *args, **kwargs):
        space = _space_of(self)
        if space is not None:

            checked, single = check_batch(starts, space, "starts")
            check_starts(self, checked, field="starts", single=single)
        return method(self, starts, *args, **kwargs)

    setattr(simulate, WRAPPED, True)
    return simulate


def checked_step(method):
    """Wrap a simulator's ``step(velocity, dt, rng)``: a finite velocity per tangent direction, a finite positive
    ``dt`` (s).  The first step from a state no checked ``reset`` placed (the one ``bind`` left) checks that state
    as a start (:func:`check_starts`, field ``step``)."""
    if getattr(method, WRAPPED, False):
        return method

    @functools.wraps(method)
    def step(self, velocity, dt, *args, **kwargs):
        dt = check_duration(dt)
        rng = args[0] if args else kwargs.get("rng")
        if rng is not None:
            check_rng(rng)
        space = _space_of(self)
        if space is not None:
            velocity = check_vector(velocity, space.tangent_dim, field="velocity")
            if not self.__dict__.get(START_CHECKED, False):
                current = np.asarray(self.configuration(), dtype=np.float64).reshape(1, -1)
                check_starts(self, current, field="step", single=True)
                self.__dict__[START_CHECKED] = True
        return method(self, velocity, dt, *args, **kwargs)

    setattr(step, WRAPPED, True)
    return step


@dataclass
class SimulationBatch:
    """Outcome of forward-simulating ``n`` particles.

    final: ``(n, d)`` configurations at the end.
    in_contact / stuck / reached: bool ``(n,)``.
    trajectories: optional ``(n, k, d)`` recorded states.
    steps: microsteps taken (total over the batch).
    """

    final: np.ndarray
    in_contact: np.ndarray
    stuck: np.ndarray
    reached: np.ndarray
    trajectories: np.ndarray | None = None
    steps: int = 0


class Simulator(Component):
    """Moves the robot among the scene's objects under commands, with contact.

    Two ways in: :meth:`simulate` (a batch of particles toward targets; the belief planner's
    workhorse) and the stepping API :meth:`reset` / :meth:`step` used by
    :func:`pliant.execution.loop.execute` to run a controller in closed loop.
    """

    kind = "simulator"

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # the core checks reset's configuration, simulate's starts and step's velocity, dt and rng (and the state a
        # first step starts from) before the plugin's code runs; starts inside an obstacle are refused
        super().__init_subclass__(**kwargs)
        if "reset" in cls.__dict__:
            cls.reset = checked_reset(cls.__dict__["reset"])
        if "simulate" in cls.__dict__:
            cls.simulate = checked_simulate(cls.__dict__["simulate"])
        if "step" in cls.__dict__:
            cls.step = checked_step(cls.__dict__["step"])

    #: penetration (m) of a start that still counts as contact, not as inside (:meth:`start_penetration`)
    start_tolerance: float = 0.0

    def start_penetration(self, configurations: np.ndarray) -> np.ndarray | None:
        """How deep (m) the robot would start inside a rigid obstacle at each configuration ``(n, d)``: ``(n,)``,
        0 where it is free.  The core refuses every start deeper than :attr:`start_tolerance` -- in ``reset``,
        in ``simulate`` (naming ``starts[k]``) and in a first ``step`` from the state ``bind`` left -- before the
        plugin's code runs (:func:`pliant.contracts.check_starts`), so that no entry point lets a robot placed
        inside a wall pass through it.  Each simulator measures with its own geometry; it must not change its
        state doing so.

        The default ``None`` means the simulator cannot tell (nothing is refused).
        """
        return None

    def describe_obstacle(self, q: np.ndarray) -> str:
        """Words naming what the robot at configuration ``(d,)`` is inside (e.g. ``"object 'wall-3'"``), for the
        error of a refused start; ``""`` (the default) says "an obstacle"."""
        return ""

    @abstractmethod
    def simulate(self, starts: np.ndarray, targets: np.ndarray, rng: np.random.Generator,
                 duration: float, record: bool = False) -> SimulationBatch:
        """Drive each start ``(n, d)`` toward its target (``(n, d)`` or ``(d,)``) for ``duration`` s.

        With ``record``, the result's ``trajectories`` hold the state after every control step.
        """

    @abstractmethod
    def reset(self, q: np.ndarray) -> None:
        """Place the robot at configuration ``(d,)``, at rest."""

    @abstractmethod
    def step(self, velocity: np.ndarray, dt: float, rng: np.random.Generator) -> np.ndarray:
        """Apply a tangent velocity command ``(t,)`` (m/s, rad/s) for ``dt`` seconds; return the new ``(d,)``."""

    def contact_points(self) -> np.ndarray:
        """The robot's contacts after the last step, ``(k, 7)``: world point (m), unit normal from the other
        body toward the robot, normal force (N; NaN where the simulator has no forces).

        The default ``(0, 7)`` is for simulators that report only :meth:`in_contact`.
        """
        return np.zeros((0, 7))

    def object_poses(self) -> dict[str, np.ndarray]:
        """Current poses of the scene's movable objects by name: ``(x, y, theta)`` in planar scenes, else
        ``(x, y, z, qx, qy, qz, qw)``.

        The default ``{}`` is for simulators that hold every object fixed (the kinematic simulator).
        """
        return {}

    #: whether :meth:`set_object_poses` is implemented (planners that push objects check it when they bind)
    can_place_objects: ClassVar[bool] = False

    def set_object_poses(self, poses: dict[str, np.ndarray]) -> None:
        """Place the named movable objects at ``poses`` (the layout of :meth:`object_poses`), at rest; the robot and
        the objects not named stay where they are.  Object-space planners (TS-RRT, poster ICHR 2010) use it to start
        an execution from a chosen arrangement and to reposition the pusher between pushes (``reset``, which puts
        every object back at its scene pose, then this).

        The default raises :class:`~pliant.errors.SimulationError`: the simulator cannot place objects.
        """
        raise SimulationError(f"{type(self).__name__} cannot place movable objects", field="simulator",
                              value=type(self).__name__)

    @abstractmethod
    def configuration(self) -> np.ndarray:
        """The robot's current configuration ``(d,)``."""

    def in_contact(self) -> bool:
        """Whether the robot touched anything during the last step."""
        return False

    def settle(self) -> np.ndarray:
        """End of an execution: a simulated robot stops with its last command; returns its configuration."""
        return self.configuration()

    def control_law(self) -> ControlLaw | None:
        """The control law :meth:`simulate` applies each step (gains, period, limits, noise), or ``None``.

        Components that predict the simulator's motion without simulating it (the reachable volumes of the
        path metric, thesis 6.4.1) need it; simulators whose motion has no such law return ``None``.
        """
        return None
