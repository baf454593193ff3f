"""The exception hierarchy of pliant.

Every error pliant raises on purpose derives from :class:`PliantError`.  An error about input names
where the bad value came from (``source``, usually a file path), which field held it (``field``,
a dotted path such as ``objects[2].material.deformability``) and the value itself, so that the
message alone is enough to find and fix the mistake.
"""

from __future__ import annotations

from typing import Any

_MISSING = object()


class PliantError(Exception):
    """Base class of every error raised by pliant.

    Parameters
    ----------
    message:
        What is wrong, in words.
    source:
        Where the input came from (a file path, ``"<dict>"`` or a component name), or ``None``.
    field:
        The dotted path of the offending field inside ``source``, or ``None``.
    value:
        The offending value; omitted from the message when not given.
    """

    def __init__(self, message: str, *, source: str | None = None, field: str | None = None,
                 value: Any = _MISSING) -> None:
        self.message = message
        self.source = source
        self.field = field
        self.value = None if value is _MISSING else value
        self.has_value = value is not _MISSING
        super().__init__(self._format())

    def _format(self) -> str:
        where = ":".join(str(p) for p in (self.source, self.field) if p)
        text = f"{where}: {self.message}" if where else self.message
        if self.has_value:
            shown = repr(self.value)
            if len(shown) > 200:
                shown = shown[:197] + "..."
            text += f" (got {shown})"
        return text


class ConfigError(PliantError):
    """A configuration value (scene, pipeline, options) is missing, mistyped or out of range."""


class SceneError(ConfigError):
    """A scene file or scene description is invalid."""


class PipelineError(ConfigError):
    """A pipeline file or pipeline description is invalid."""


class PluginError(PliantError):
    """A plugin is unknown, disabled, failed to load, or does not honour its contract."""


class DimensionError(PliantError):
    """An array has the wrong shape, dtype or non-finite entries where finite ones are required."""


class PlanningError(PliantError):
    """A planner was given a problem it cannot accept (as opposed to failing to find a path)."""


class SimulationError(PliantError):
    """A simulator was given a scene, robot or command it cannot represent."""


class DriverError(PliantError):
    """A robot driver refused a command, lost its robot, or the robot reported a fault.

    ``joint``, ``value`` and ``limit`` name what was refused where that applies (a joint name, the offending
    value and the limit it broke).  Every refusal of the safety layer (:mod:`pliant.hardware.safety`) is a
    subclass, so ``except DriverError`` catches them all.
    """

    def __init__(self, message: str, *, joint: str | None = None, limit: Any = _MISSING, source: str | None = None,
                 field: str | None = None, value: Any = _MISSING) -> None:
        self.joint = joint
        self.limit = None if limit is _MISSING else limit
        if joint is not None:
            message = f"joint {joint}: {message}"
        if limit is not _MISSING:
            message = f"{message} (limit {limit!r})"
        super().__init__(message, source=source, field=field, value=value)


class CommandRejected(DriverError):
    """A command broke the safety contract (non-finite, past a limit, too large a step); it was not sent."""


class NonFiniteCommand(CommandRejected):
    """A command or target holds NaN or infinity."""


class LimitViolation(CommandRejected):
    """A command or target lies past a position, velocity or acceleration limit."""


class StepTooLarge(CommandRejected):
    """A command moves a joint further in one cycle than the largest step allowed."""


class StateError(DriverError):
    """The robot's state is unusable: stale, out of order, inconsistent, flooding or non-finite."""


class StaleState(StateError):
    """No fresh state arrived within the watchdog deadline."""


class JointMismatch(StateError):
    """The robot's joint names or order differ from the driver's."""


class RobotNotReady(DriverError):
    """The robot is disabled, e-stopped or faulted."""


class RobotDisabled(RobotNotReady):
    """The robot is not enabled (motors off)."""


class EmergencyStop(RobotNotReady):
    """The robot's emergency stop is engaged."""


class DriveFault(RobotNotReady):
    """A joint drive reports a fault."""


class ConnectionLost(DriverError):
    """The robot, its middleware (a ROS master) or its bus cannot be reached."""


class SmoothingError(DriverError):
    """The trajectory generator (ruckig) rejected its input or failed to plan."""
