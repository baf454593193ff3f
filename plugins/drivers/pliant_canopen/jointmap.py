"""The joint-map file (which CANopen node drives which URDF joint, and how counts become radians) and the checks
of a drive's object dictionary (EDS).

A joint map is TOML; paths are relative to the file (an ``eds`` not found there is looked up among the bundled
data files, so ``eds = "cia402_joint.eds"`` names the shipped one)::

    robot = "kuka-lbr-iiwa-7-r800"      # free text
    description = "..."                 # optional
    limits = "iiwa7_limits.toml"        # the limits file (pliant.hardware.limits) of these joints
    eds = "cia402_joint.eds"            # optional: every drive's object dictionary (default the bundled one)

    [[joints]]                          # one per drive, in command order (the URDF's joint order)
    name = "lbr_iiwa_joint_1"           # the URDF joint
    node = 1                            # CANopen node id, 1..127
    encoder_resolution = 131072         # counts per motor revolution ...
    gear_ratio = 160.0                  # ... and motor revolutions per joint revolution,
    # counts_per_radian = 3337719.4     # ... or the position scaling directly (give one or the other)
    direction = 1                       # +1, or -1 when the drive counts against the URDF axis
    offset = 0.0                        # rad: the joint angle at position 0 counts
    # velocity_factor = 3337719.4       # drive velocity units per rad/s (0x606C, 0x60B1); default
    #                                   #   counts_per_radian, i.e. the drive reports counts/s
    # eds = "my_drive.eds"              # this drive's own object dictionary

A joint angle ``q`` (rad) is ``offset + direction * counts / counts_per_radian``; a command is rounded to the
nearest count.  Every field is checked; errors name the file, the field and the value.
"""

from __future__ import annotations

import configparser
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
from pliant.api import ConfigError, Fields, read_toml

from pliant_canopen import cia402

INT32_MIN, INT32_MAX = -(2 ** 31), 2 ** 31 - 1


def data_file(name: str) -> Path:
    """A file shipped in ``pliant_canopen/data`` (the EDS, the example joint map and limits)."""
    return Path(str(resources.files("pliant_canopen") / "data" / name))


#: the bundled 7-joint example (KUKA LBR iiwa 7 R800 joint names and data-sheet limits)
DEFAULT_JOINT_MAP = "iiwa7_joint_map.toml"
#: the bundled object dictionary of a CiA 402 joint drive
DEFAULT_EDS = "cia402_joint.eds"


@dataclass(frozen=True)
class JointDrive:
    """One joint and its drive: URDF joint ``name``, CANopen ``node`` id (1..127), ``counts_per_radian``
    (position units of 0x6064 / 0x607A per rad), ``velocity_factor`` (velocity units of 0x606C / 0x60B1 per
    rad/s), ``direction`` (+1 or -1), ``offset`` (rad at 0 counts) and the drive's object dictionary ``eds``."""

    name: str
    node: int
    counts_per_radian: float
    velocity_factor: float
    direction: int
    offset: float
    eds: Path


@dataclass(frozen=True)
class JointMap:
    """The joints of a CANopen arm in command order, with their scaling; see the module docstring.

    The conversions work on ``(d,)`` arrays in this order: :meth:`to_counts` / :meth:`to_radians` for positions
    (rad <-> counts), :meth:`to_velocity_units` / :meth:`to_radians_per_second` for velocities.
    """

    joints: tuple[JointDrive, ...]
    limits: Path
    robot: str = ""
    description: str = ""
    source: str = "<joint map>"

    def __post_init__(self) -> None:
        j = self.joints
        object.__setattr__(self, "_cpr", np.array([d.counts_per_radian for d in j], dtype=np.float64))
        object.__setattr__(self, "_vf", np.array([d.velocity_factor for d in j], dtype=np.float64))
        object.__setattr__(self, "_sign", np.array([d.direction for d in j], dtype=np.float64))
        object.__setattr__(self, "_offset", np.array([d.offset for d in j], dtype=np.float64))

    @property
    def names(self) -> tuple[str, ...]:
        """The URDF joint names in command order."""
        return tuple(d.name for d in self.joints)

    @property
    def nodes(self) -> tuple[int, ...]:
        """The CANopen node ids in command order."""
        return tuple(d.node for d in self.joints)

    def to_counts(self, positions) -> np.ndarray:
        """Joint angles ``(d,)`` rad -> position counts ``(d,)`` int64 (rounded to the nearest count)."""
        q = np.asarray(positions, dtype=np.float64)
        return np.rint(self._sign * (q - self._offset) * self._cpr).astype(np.int64)

    def to_radians(self, counts) -> np.ndarray:
        """Position counts ``(d,)`` -> joint angles ``(d,)`` rad."""
        return self._offset + self._sign * np.asarray(counts, dtype=np.float64) / self._cpr

    def to_velocity_units(self, velocities) -> np.ndarray:
        """Joint velocities ``(d,)`` rad/s -> drive velocity units ``(d,)`` int64 (rounded)."""
        return np.rint(self._sign * np.asarray(velocities, dtype=np.float64) * self._vf).astype(np.int64)

    def to_radians_per_second(self, units) -> np.ndarray:
        """Drive velocity units ``(d,)`` -> joint velocities ``(d,)`` rad/s."""
        return self._sign * np.asarray(units, dtype=np.float64) / self._vf

    def check_range(self, lower, upper, velocity, source: str | None = None) -> None:
        """Raise :class:`ConfigError` when a position in ``[lower, upper]`` (rad) or a velocity up to ``velocity``
        (rad/s), all ``(d,)``, does not fit the drives' INTEGER32 objects (0x607A, 0x6064, 0x60B1, 0x606C)."""
        ends = np.stack([self.to_counts(lower), self.to_counts(upper)])
        speed = self.to_velocity_units(velocity)
        for i, joint in enumerate(self.joints):
            if np.any(ends[:, i] < INT32_MIN) or np.any(ends[:, i] > INT32_MAX):
                raise ConfigError(f"joint {joint.name}: its position range [{lower[i]:.4g}, {upper[i]:.4g}] rad is "
                                  f"{ends[:, i].tolist()} counts, beyond INTEGER32 (0x607A)", source=source or
                                  self.source, field=f"joints[{i}].counts_per_radian", value=joint.counts_per_radian)
            if abs(int(speed[i])) > INT32_MAX:
                raise ConfigError(f"joint {joint.name}: its velocity limit {velocity[i]:.4g} rad/s is beyond "
                                  "INTEGER32 velocity units (0x60B1)", source=source or self.source,
                                  field=f"joints[{i}].velocity_factor", value=joint.velocity_factor)


def _resolve(base: Path, value: str, fields: Fields, key: str, bundled: bool) -> Path:
    path = Path(value).expanduser()
    if not path.is_absolute():
        path = base / path
    if not path.is_file() and bundled and not Path(value).is_absolute() and data_file(value).is_file():
        path = data_file(value)
    if not path.is_file():
        fields.fail(key, f"names a file that does not exist ({path})", value)
    return path


def load_joint_map(path: str | Path | None = None) -> JointMap:
    """Read a joint-map file (format in the module docstring; ``None``: the bundled iiwa example)."""
    path = Path(path) if path is not None else data_file(DEFAULT_JOINT_MAP)
    source = str(path)
    fields = Fields(read_toml(path), source)
    base = path.parent
    robot = fields.string("robot", "")
    description = fields.string("description", "")
    limits = _resolve(base, fields.string("limits"), fields, "limits", bundled=True)
    default_eds = fields.string("eds", DEFAULT_EDS)
    default_eds_path = _resolve(base, default_eds, fields, "eds", bundled=True)
    tables = fields.tables("joints", required=True)
    if not tables:
        fields.fail("joints", "must list at least one joint", [])
    joints: list[JointDrive] = []
    for table in tables:
        name = table.string("name")
        node = table.integer("node")
        if not 1 <= node <= 127:
            table.fail("node", "must be a CANopen node id in 1..127", node)
        has_cpr = table.has("counts_per_radian")
        has_encoder = table.has("encoder_resolution") or table.has("gear_ratio")
        if has_cpr and has_encoder:
            table.fail("counts_per_radian", "give either counts_per_radian or encoder_resolution (with gear_ratio), "
                       "not both", table.raw("counts_per_radian"))
        if has_cpr:
            cpr = table.number("counts_per_radian", positive=True)
        elif has_encoder:
            resolution = table.integer("encoder_resolution", minimum=1)
            ratio = table.number("gear_ratio", 1.0, positive=True)
            cpr = resolution * ratio / (2 * math.pi)
        else:
            table.fail("counts_per_radian", "is required (or encoder_resolution with gear_ratio): the position "
                       "counts per radian of the joint")
        direction = table.integer("direction", 1)
        if direction not in (1, -1):
            table.fail("direction", "must be 1 or -1", direction)
        offset = table.number("offset", 0.0)
        velocity_factor = table.number("velocity_factor", cpr, positive=True)
        eds = (_resolve(base, table.string("eds"), table, "eds", bundled=True) if table.has("eds")
               else default_eds_path)
        table.finish()
        for i, other in enumerate(joints):
            if other.name == name:
                table.fail("name", f"repeats joints[{i}].name", name)
            if other.node == node:
                table.fail("node", f"repeats joints[{i}].node ({other.name})", node)
        joints.append(JointDrive(name, node, float(cpr), float(velocity_factor), direction, float(offset), eds))
    fields.finish()
    return JointMap(tuple(joints), limits, robot=robot, description=description, source=source)


# --- the object dictionary ------------------------------------------------------------------------------------

_TYPE_NAMES = {cia402.UNSIGNED8: "UNSIGNED8", cia402.UNSIGNED16: "UNSIGNED16", cia402.UNSIGNED32: "UNSIGNED32",
               cia402.INTEGER8: "INTEGER8", cia402.INTEGER16: "INTEGER16", cia402.INTEGER32: "INTEGER32"}

#: index -> (data type, needs read, needs write, needs PDO mapping) of every object the driver uses
REQUIRED_OBJECTS = {
    cia402.DEVICE_TYPE: (cia402.UNSIGNED32, True, False, False),
    cia402.PRODUCER_HEARTBEAT_TIME: (cia402.UNSIGNED16, True, True, False),
    cia402.CONTROLWORD: (cia402.UNSIGNED16, False, True, False),
    cia402.STATUSWORD: (cia402.UNSIGNED16, True, False, True),
    cia402.MODES_OF_OPERATION: (cia402.INTEGER8, False, True, False),
    cia402.MODES_OF_OPERATION_DISPLAY: (cia402.INTEGER8, True, False, True),
    cia402.POSITION_ACTUAL: (cia402.INTEGER32, True, False, True),
    cia402.VELOCITY_ACTUAL: (cia402.INTEGER32, True, False, True),
    cia402.TARGET_POSITION: (cia402.INTEGER32, False, True, True),
}
#: the PDO parameter records the driver configures (RPDO1, TPDO1, TPDO2)
REQUIRED_PDO_RECORDS = (cia402.RPDO_COMMUNICATION, cia402.RPDO_MAPPING, cia402.TPDO_COMMUNICATION,
                        cia402.TPDO_COMMUNICATION + 1, cia402.TPDO_MAPPING, cia402.TPDO_MAPPING + 1)


def load_object_dictionary(path: str | Path, node: int, *, velocity_offset: bool = True):
    """Import the EDS at ``path`` for node id ``node`` and check that it holds every object the driver uses.

    Checked: the CiA 402 objects 0x6040, 0x6041, 0x6060, 0x6061, 0x6064, 0x606C, 0x607A (and 0x60B1 when
    ``velocity_offset``) with their data types, access and PDO mapping, the heartbeat producer 0x1017, the device
    type 0x1000 and the PDO records 0x1400, 0x1600, 0x1800, 0x1801, 0x1A00, 0x1A01.  Returns the
    ``canopen.ObjectDictionary``; a problem raises :class:`ConfigError` naming the file, the object and the value.
    """
    import canopen

    source = str(path)
    try:
        od = canopen.import_od(source, node)
    except configparser.NoOptionError as exc:
        raise ConfigError(f"not a valid EDS: section [{exc.section}] lacks {exc.option}", source=source,
                          field=f"[{exc.section}].{exc.option}") from None
    except (configparser.Error, ValueError, KeyError, IndexError, OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"not a valid EDS: {type(exc).__name__}: {exc}".replace("\n", " "), source=source,
                          field="<file>") from None
    required = dict(REQUIRED_OBJECTS)
    if velocity_offset:
        required[cia402.VELOCITY_OFFSET] = (cia402.INTEGER32, False, True, True)
    for index, (data_type, read, write, mapped) in required.items():
        field = f"0x{index:04X}"
        if index not in od:
            raise ConfigError("is missing: the canopen driver needs it", source=source, field=field)
        obj = od[index]
        if not isinstance(obj, canopen.objectdictionary.ODVariable):
            raise ConfigError("must be a VAR object", source=source, field=field, value=type(obj).__name__)
        if obj.data_type != data_type:
            raise ConfigError(f"must be {_TYPE_NAMES[data_type]} (DataType 0x{data_type:04X})", source=source,
                              field=f"{field}.DataType", value=f"0x{obj.data_type:04X}")
        if (read and not obj.readable) or (write and not obj.writable):
            want = "readable and writable" if read and write else "readable" if read else "writable"
            raise ConfigError(f"must be {want}", source=source, field=f"{field}.AccessType", value=obj.access_type)
        if mapped and not obj.pdo_mappable:
            raise ConfigError("must be PDO-mappable", source=source, field=f"{field}.PDOMapping", value=0)
    for index in REQUIRED_PDO_RECORDS:
        if index not in od:
            raise ConfigError("is missing: the driver maps its PDOs there", source=source, field=f"0x{index:04X}")
    device_type = od[cia402.DEVICE_TYPE].default
    if device_type is not None and device_type & 0xFFFF != cia402.DEVICE_PROFILE_DRIVE:
        raise ConfigError("is not a CiA 402 drive (device profile 402 in the low 16 bits)", source=source,
                          field="0x1000.DefaultValue", value=f"0x{device_type:08X}")
    return od
