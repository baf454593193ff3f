"""The joint-map file, the object dictionary (EDS) checks, the bundled example and the counts <-> radians scaling."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pliant.errors import ConfigError
from pliant.hardware.limits import load_limits
from pliant_canopen import cia402
from pliant_canopen.cia402 import Command, DriveState
from pliant_canopen.jointmap import (
    INT32_MAX,
    JointDrive,
    JointMap,
    data_file,
    load_joint_map,
    load_object_dictionary,
)

IIWA = tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8))


def test_the_bundled_example_is_the_iiwa_with_its_data_sheet_limits():
    jm = load_joint_map()
    assert jm.names == IIWA and jm.nodes == tuple(range(1, 8))
    limits = load_limits(jm.limits)
    assert limits.names == IIWA
    np.testing.assert_allclose(np.degrees(limits.upper), [170, 120, 170, 120, 170, 120, 175])
    np.testing.assert_allclose(np.degrees(limits.lower), [-170, -120, -170, -120, -170, -120, -175])
    np.testing.assert_allclose(np.degrees(limits.velocity), [98, 98, 100, 130, 140, 180, 180])
    assert any("KUKA" in s for s in limits.sources) and any("acceleration" in s for s in limits.sources)
    assert jm.joints[0].counts_per_radian == pytest.approx(131072 * 160 / (2 * math.pi))
    jm.check_range(limits.lower, limits.upper, limits.velocity)         # fits INTEGER32
    assert jm.joints[0].eds == data_file("cia402_joint.eds")


def test_three_scalings_and_direction(arm3):
    jm = load_joint_map(arm3)
    assert jm.names == ("shoulder", "elbow", "wrist") and jm.nodes == (11, 12, 13)
    assert jm.joints[1].counts_per_radian == pytest.approx(4096 * 100 / (2 * math.pi))
    assert jm.joints[0].velocity_factor == jm.joints[0].counts_per_radian       # counts/s by default
    q = np.array([0.1, 0.5 + 0.2, -0.3])
    counts = jm.to_counts(q)
    assert counts[0] == 1000 and counts[2] == -6000
    assert counts[1] == round(-0.2 * jm.joints[1].counts_per_radian)             # direction -1, offset 0.5
    np.testing.assert_allclose(jm.to_radians(counts), q, atol=1e-4)
    units = jm.to_velocity_units(np.array([0.0, 0.0, 2 * math.pi]))
    assert units[2] == 60                                                         # rpm


def _write(tmp_path, text, limits=True):
    if limits:
        (tmp_path / "limits.toml").write_text('robot = "x"\ncommand_rate = 100.0\nstate_timeout = 0.1\n'
                                              'sources = ["t"]\n[[joints]]\nname = "a"\nlower = -1.0\n'
                                              'upper = 1.0\nvelocity = 1.0\nacceleration = 1.0\njerk = 1.0\n')
    path = tmp_path / "map.toml"
    path.write_text(text)
    return path


GOOD_JOINT = 'name = "a"\nnode = 1\ncounts_per_radian = 1000.0\n'


@pytest.mark.parametrize(("joint", "field", "value"), [
    ('name = "a"\nnode = 0\ncounts_per_radian = 1.0\n', "joints[0].node", "0"),
    ('name = "a"\nnode = 128\ncounts_per_radian = 1.0\n', "joints[0].node", "128"),
    ('name = "a"\nnode = "one"\ncounts_per_radian = 1.0\n', "joints[0].node", "'one'"),
    ('name = "a"\nnode = 1\ncounts_per_radian = -5.0\n', "joints[0].counts_per_radian", "-5.0"),
    ('name = "a"\nnode = 1\n', "joints[0].counts_per_radian", None),
    ('name = "a"\nnode = 1\ncounts_per_radian = 1.0\nencoder_resolution = 4096\n',
     "joints[0].counts_per_radian", "1.0"),
    ('name = "a"\nnode = 1\nencoder_resolution = 0\n', "joints[0].encoder_resolution", "0"),
    ('name = "a"\nnode = 1\nencoder_resolution = 4096\ngear_ratio = 0.0\n', "joints[0].gear_ratio", "0.0"),
    ('name = "a"\nnode = 1\ncounts_per_radian = 1.0\ndirection = 2\n', "joints[0].direction", "2"),
    ('name = "a"\nnode = 1\ncounts_per_radian = 1.0\noffset = "zero"\n', "joints[0].offset", "'zero'"),
    ('name = "a"\nnode = 1\ncounts_per_radian = 1.0\nvelocity_factor = 0\n', "joints[0].velocity_factor", "0"),
    ('name = "a"\nnode = 1\ncounts_per_radian = 1.0\ncount_per_radian = 1.0\n', "joints[0].count_per_radian",
     "1.0"),
    ('name = "a"\nnode = 1\ncounts_per_radian = 1.0\neds = "nowhere.eds"\n', "joints[0].eds", "'nowhere.eds'"),
    ('node = 1\ncounts_per_radian = 1.0\n', "joints[0].name", None),
])
def test_a_bad_joint_field_is_named_with_its_value(tmp_path, joint, field, value):
    path = _write(tmp_path, f'limits = "limits.toml"\n[[joints]]\n{joint}')
    with pytest.raises(ConfigError) as info:
        load_joint_map(path)
    message = str(info.value)
    assert message.startswith(f"{path}:{field}:"), message
    if value is not None:
        assert f"(got {value})" in message


def test_repeated_nodes_and_names_and_file_level_errors(tmp_path):
    path = _write(tmp_path, f'limits = "limits.toml"\n[[joints]]\n{GOOD_JOINT}[[joints]]\n'
                            'name = "b"\nnode = 1\ncounts_per_radian = 1.0\n')
    with pytest.raises(ConfigError, match=r"joints\[1\]\.node: repeats joints\[0\]\.node"):
        load_joint_map(path)
    path = _write(tmp_path, f'limits = "limits.toml"\n[[joints]]\n{GOOD_JOINT}[[joints]]\n'
                            'name = "a"\nnode = 2\ncounts_per_radian = 1.0\n')
    with pytest.raises(ConfigError, match=r"joints\[1\]\.name: repeats"):
        load_joint_map(path)
    path = _write(tmp_path, f'limits = "missing.toml"\n[[joints]]\n{GOOD_JOINT}')
    with pytest.raises(ConfigError, match=r"map\.toml:limits: names a file that does not exist"):
        load_joint_map(path)
    path = _write(tmp_path, f'limits = "limits.toml"\nrobott = "x"\n[[joints]]\n{GOOD_JOINT}')
    with pytest.raises(ConfigError, match=r"map\.toml:robott: is not a known field"):
        load_joint_map(path)
    path = _write(tmp_path, 'limits = "limits.toml"\n')
    with pytest.raises(ConfigError, match=r"map\.toml:joints: is required"):
        load_joint_map(path)
    path = _write(tmp_path, 'limits = "limits.toml"\n[[joints]\n')
    with pytest.raises(ConfigError, match=r"<file>: not valid TOML"):
        load_joint_map(path)


def test_a_scaling_beyond_integer32_is_refused_naming_the_joint(tmp_path):
    path = _write(tmp_path, 'limits = "limits.toml"\n[[joints]]\nname = "a"\nnode = 1\ncounts_per_radian = 1e10\n')
    jm = load_joint_map(path)
    limits = load_limits(jm.limits)
    with pytest.raises(ConfigError, match=r"joints\[0\]\.counts_per_radian: joint a: .*beyond INTEGER32"):
        jm.check_range(limits.lower, limits.upper, limits.velocity)


# --- the object dictionary -------------------------------------------------------------------------------------

def test_the_shipped_eds_holds_every_object_the_driver_uses():
    import canopen

    od = load_object_dictionary(data_file("cia402_joint.eds"), 5)
    for index in (0x1000, 0x1001, 0x1016, 0x1017, 0x1018, 0x1400, 0x1600, 0x1800, 0x1801, 0x1A00, 0x1A01,
                  0x6040, 0x6041, 0x6060, 0x6061, 0x6064, 0x606C, 0x607A, 0x60B1):
        assert index in od, hex(index)
    assert od[0x1000].default & 0xFFFF == 402
    assert od[0x1400][1].default == 0x205 and od[0x1800][1].default == 0x185      # $NODEID resolved
    assert od[0x607A].data_type == cia402.INTEGER32 and od[0x607A].pdo_mappable
    assert isinstance(od[0x1016], canopen.objectdictionary.ODArray)
    # default mappings: RPDO1 = 0x607A + 0x60B1, TPDO1 = 0x6041 + 0x6064, TPDO2 = 0x606C + 0x6061
    assert [od[0x1600][i].default for i in (1, 2)] == [0x607A0020, 0x60B10020]
    assert [od[0x1A00][i].default for i in (1, 2)] == [0x60410010, 0x60640020]
    assert [od[0x1A01][i].default for i in (1, 2)] == [0x606C0020, 0x60610008]


def _eds(tmp_path, edit):
    text = data_file("cia402_joint.eds").read_text()
    path = tmp_path / "drive.eds"
    path.write_text(edit(text))
    return path


def _section(text, name):
    return re.search(rf"\[{name}\]\n(.*?)\n\n", text, re.S).group(0)


@pytest.mark.parametrize(("edit", "field"), [
    (lambda t: t.replace(_section(t, "6064"), ""), "0x6064"),
    (lambda t: t.replace(_section(t, "607A"), _section(t, "607A").replace("DataType=0x0004", "DataType=0x0003")),
     "0x607A.DataType"),
    (lambda t: t.replace(_section(t, "6041"), _section(t, "6041").replace("PDOMapping=1", "PDOMapping=0")),
     "0x6041.PDOMapping"),
    (lambda t: t.replace(_section(t, "6040"), _section(t, "6040").replace("AccessType=rw", "AccessType=ro")),
     "0x6040.AccessType"),
    (lambda t: t.replace(_section(t, "1000"), _section(t, "1000").replace("0x00020192", "0x00000191")),
     "0x1000.DefaultValue"),
    (lambda t: t.replace(_section(t, "6060"), _section(t, "6060").replace("DataType=0x0002\n", "")),
     "[6060].DataType"),
    (lambda t: t.replace("[FileInfo]", "[FileInfo]\n[FileInfo]"), "<file>"),
])
def test_a_bad_eds_is_refused_naming_the_object(tmp_path, edit, field):
    path = _eds(tmp_path, edit)
    with pytest.raises(ConfigError) as info:
        load_object_dictionary(path, 1)
    assert str(info.value).startswith(f"{path}:{field}:"), str(info.value)


def test_the_velocity_offset_is_needed_only_for_feed_forward(tmp_path):
    path = _eds(tmp_path, lambda t: t.replace(_section(t, "60B1"), ""))
    with pytest.raises(ConfigError, match=r"0x60B1: is missing"):
        load_object_dictionary(path, 1)
    assert 0x607A in load_object_dictionary(path, 1, velocity_offset=False)


def test_a_joint_may_name_its_own_eds_and_the_bundled_one_by_name(tmp_path):
    own = _eds(tmp_path, lambda t: t)
    path = _write(tmp_path, f'limits = "limits.toml"\n[[joints]]\n{GOOD_JOINT}eds = "{own.name}"\n'
                            '[[joints]]\nname = "b"\nnode = 2\ncounts_per_radian = 1.0\n')
    jm = load_joint_map(path)
    assert jm.joints[0].eds == own and jm.joints[1].eds == data_file("cia402_joint.eds")


# --- CiA 402 decoding --------------------------------------------------------------------------------------------

def test_statusword_and_controlword_decoding():
    assert cia402.drive_state(0x0250) == DriveState.SWITCH_ON_DISABLED
    assert cia402.drive_state(0x0231) == DriveState.READY
    assert cia402.drive_state(0x0233) == DriveState.SWITCHED_ON
    assert cia402.drive_state(0x1637) == DriveState.OPERATION_ENABLED
    assert cia402.drive_state(0x0217) == DriveState.QUICK_STOP
    assert cia402.drive_state(0x021F) == DriveState.FAULT_REACTION
    assert cia402.drive_state(0x0218) == DriveState.FAULT
    assert cia402.drive_state(0x0000) == DriveState.NOT_READY
    for state, word in cia402.STATUSWORD_OF.items():
        assert cia402.drive_state(word) == state
    assert cia402.controlword_command(0x06) == Command.SHUTDOWN
    assert cia402.controlword_command(0x07) == Command.SWITCH_ON
    assert cia402.controlword_command(0x0F) == Command.ENABLE_OPERATION
    assert cia402.controlword_command(0x00) == Command.DISABLE_VOLTAGE
    assert cia402.controlword_command(0x02) == Command.QUICK_STOP
    assert cia402.controlword_command(0x80, 0x00) == Command.FAULT_RESET
    assert cia402.controlword_command(0x80, 0x80) == Command.NONE          # an edge, not a level
    assert cia402.emcy_description(0x2310) == "continuous over-current"
    assert cia402.emcy_description(0x2399) == "current" and cia402.emcy_description(0x8130).startswith("life guard")


# --- the scaling, property-tested ------------------------------------------------------------------------------

def _one_joint(cpr: float, direction: int, offset: float, factor: float | None = None) -> JointMap:
    drive = JointDrive("j", 1, cpr, factor if factor is not None else cpr, direction, offset,
                       data_file("cia402_joint.eds"))
    return JointMap((drive,), data_file("iiwa7_limits.toml"))


scalings = st.tuples(st.floats(1.0, 1e8), st.sampled_from([1, -1]), st.floats(-math.pi, math.pi))


@given(scalings, st.integers(-(2 ** 31), INT32_MAX))
def test_counts_survive_the_round_trip_through_radians_exactly(scaling, counts):
    jm = _one_joint(*scaling)
    assert jm.to_counts(jm.to_radians(np.array([counts])))[0] == counts


@given(scalings, st.floats(-10.0, 10.0))
def test_radians_survive_the_round_trip_through_counts_within_half_a_count(scaling, q):
    cpr, direction, offset = scaling
    jm = _one_joint(cpr, direction, offset)
    counts = jm.to_counts(np.array([q]))
    if abs(counts[0]) > INT32_MAX:
        return
    assert abs(jm.to_radians(counts)[0] - q) <= 0.5 / cpr + 1e-12 * max(1.0, abs(q))


@given(st.floats(1.0, 1e7), st.sampled_from([1, -1]), st.floats(-20.0, 20.0))
def test_velocities_round_trip_within_half_a_unit_and_keep_their_sign(factor, direction, v):
    jm = _one_joint(1000.0, direction, 0.0, factor)
    units = jm.to_velocity_units(np.array([v]))
    assert abs(jm.to_radians_per_second(units)[0] - v) <= 0.5 / factor + 1e-12
    if abs(v) * factor >= 1:
        assert np.sign(units[0]) == np.sign(v) * direction
