"""Per-robot joint limits for streaming commands, read from a limits file.

A limits file is TOML; every number is a published value, and ``sources`` cites where each came from::

    robot = "baxter"
    group = "right_arm"
    command_rate = 100.0        # Hz: how often the driver sends a command
    command_timeout = 0.2       # s: the robot's own timeout (it holds position when commands arrive slower)
    state_timeout = 0.1         # s: no fresh joint state for this long is a fault (the watchdog)
    max_state_rate = 1000.0     # Hz: more state messages per second than this is a flood
    position_margin = 0.02      # rad: commands stay this far inside [lower, upper]
    step_factor = 1.2           # the largest step per cycle is step_factor * velocity / command_rate
    sources = ["Rethink Robotics, Baxter URDF (baxter_description), joint limits", "..."]

    [[joints]]
    name = "right_s0"
    lower = -1.70168            # rad
    upper = 1.70168             # rad
    velocity = 1.5              # rad/s
    acceleration = 4.0          # rad/s^2
    jerk = 40.0                 # rad/s^3

Every field is checked; an error names the file, the field and the value.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from pliant.errors import ConfigError, JointMismatch
from pliant.validation import Fields, read_toml


@dataclass(frozen=True)
class JointLimits:
    """The limits every streamed command must respect, for joints ``names`` in command order.

    lower / upper: ``(d,)`` position limits (rad or m); velocity / acceleration / jerk: ``(d,)`` positive limits
    (per second, squared, cubed).  position_margin: commands stay this far inside the position limits.
    command_rate: commands per second (Hz).  command_timeout: the robot's own command timeout (s), ``None`` when
    it has none.  state_timeout: the stale-state watchdog's deadline (s).  max_state_rate: state messages per
    second above which the stream is a flood (Hz).  step_factor: the largest step per cycle is
    ``step_factor * velocity / command_rate``.  sources: where the numbers come from.
    """

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    position_margin: float = 0.02
    command_rate: float = 100.0
    command_timeout: float | None = None
    state_timeout: float = 0.1
    max_state_rate: float = 2000.0
    step_factor: float = 1.2
    sources: tuple[str, ...] = ()
    robot: str = ""
    source: str = "<limits>"

    def __post_init__(self) -> None:
        d = len(self.names)
        for name in ("lower", "upper", "velocity", "acceleration", "jerk"):
            value = np.asarray(getattr(self, name), dtype=np.float64)
            if value.shape != (d,) or not np.all(np.isfinite(value)):
                raise ConfigError(f"must be {d} finite numbers, one per joint", source=self.source, field=name,
                                  value=np.asarray(getattr(self, name)).tolist())
            object.__setattr__(self, name, value)
        for name in ("velocity", "acceleration", "jerk"):
            bad = np.flatnonzero(getattr(self, name) <= 0)
            if bad.size:
                raise ConfigError("must be positive", source=self.source, field=f"{self.names[bad[0]]}.{name}",
                                  value=float(getattr(self, name)[bad[0]]))
        bad = np.flatnonzero(self.upper - self.lower <= 2 * self.position_margin)
        if bad.size:
            raise ConfigError("upper must exceed lower by more than twice the position margin", source=self.source,
                              field=f"{self.names[bad[0]]}.upper",
                              value=[float(self.lower[bad[0]]), float(self.upper[bad[0]])])
        if len(set(self.names)) != d:
            raise ConfigError("joint names must be unique", source=self.source, field="joints", value=self.names)

    @property
    def dof(self) -> int:
        return len(self.names)

    @property
    def period(self) -> float:
        """The command period (s)."""
        return 1.0 / self.command_rate

    @property
    def command_lower(self) -> np.ndarray:
        """The lowest position a command may hold: ``lower + position_margin``."""
        return self.lower + self.position_margin

    @property
    def command_upper(self) -> np.ndarray:
        """The highest position a command may hold: ``upper - position_margin``."""
        return self.upper - self.position_margin

    @property
    def max_step(self) -> np.ndarray:
        """The largest change of a command in one cycle, ``(d,)`` (rad)."""
        return self.step_factor * self.velocity / self.command_rate

    def scaled(self, speed: float) -> JointLimits:
        """These limits with velocity scaled by ``speed``, acceleration by ``speed**2`` and jerk by ``speed**3``
        (the same motion, slowed down), ``0 < speed <= 1``."""
        if not 0 < speed <= 1:
            raise ConfigError("must be in (0, 1]", source=self.source, field="speed_scale", value=speed)
        return replace(self, velocity=self.velocity * speed, acceleration=self.acceleration * speed ** 2,
                       jerk=self.jerk * speed ** 3)

    def with_rate(self, command_rate: float) -> JointLimits:
        """These limits at another command rate (Hz)."""
        if not command_rate > 0:
            raise ConfigError("must be positive", source=self.source, field="command_rate", value=command_rate)
        return replace(self, command_rate=float(command_rate))

    def select(self, names: tuple[str, ...] | list[str]) -> JointLimits:
        """The limits of ``names``, in that order; a joint the file does not list raises :class:`JointMismatch`."""
        missing = [n for n in names if n not in self.names]
        if missing:
            raise JointMismatch(f"has no limits in {self.source} (it lists {', '.join(self.names)})",
                                joint=missing[0])
        index = [self.names.index(n) for n in names]
        return replace(self, names=tuple(names), lower=self.lower[index], upper=self.upper[index],
                       velocity=self.velocity[index], acceleration=self.acceleration[index], jerk=self.jerk[index])

    def describe(self) -> list[tuple[str, str, str, str, str, str]]:
        """One row per joint: name, lower, upper, velocity, acceleration, jerk (for ``pliant robot check``)."""
        return [(n, f"{lo:.4f}", f"{hi:.4f}", f"{v:.3f}", f"{a:.3f}", f"{j:.1f}") for n, lo, hi, v, a, j in
                zip(self.names, self.lower, self.upper, self.velocity, self.acceleration, self.jerk)]


def load_limits(path: str | Path) -> JointLimits:
    """Read a limits file (format in the module docstring); errors name the file, field and value."""
    path = Path(path)
    source = str(path)
    fields = Fields(read_toml(path), source)
    robot = fields.string("robot")
    fields.string("group", "")
    fields.string("description", "")
    command_rate = fields.number("command_rate", minimum=1.0, maximum=10000.0)
    command_timeout = fields.number("command_timeout", None, positive=True)
    state_timeout = fields.number("state_timeout", positive=True)
    max_state_rate = fields.number("max_state_rate", 2000.0, positive=True)
    margin = fields.number("position_margin", 0.02, minimum=0.0)
    step_factor = fields.number("step_factor", 1.2, minimum=1.0)
    sources = fields.raw("sources")
    if not isinstance(sources, list) or not sources or not all(isinstance(s, str) and s for s in sources):
        fields.fail("sources", "must be a non-empty list of citations (where each number comes from)", sources)
    joints = fields.tables("joints", required=True)
    if not joints:
        fields.fail("joints", "must list at least one joint", [])
    names, columns = [], {k: [] for k in ("lower", "upper", "velocity", "acceleration", "jerk")}
    for joint in joints:
        names.append(joint.string("name"))
        columns["lower"].append(joint.number("lower"))
        columns["upper"].append(joint.number("upper"))
        for key in ("velocity", "acceleration", "jerk"):
            columns[key].append(joint.number(key, positive=True))
        joint.finish()
    fields.finish()
    return JointLimits(tuple(names), *(np.array(columns[k]) for k in columns), position_margin=margin,
                       command_rate=command_rate, command_timeout=command_timeout, state_timeout=state_timeout,
                       max_state_rate=max_state_rate, step_factor=step_factor, sources=tuple(sources), robot=robot,
                       source=source)
