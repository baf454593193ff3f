"""Constants of CANopen (CiA 301) and of the drive profile CiA 402 that the driver and the peer share.

Object indices, the statusword's states (CiA 402 state machine), the controlword's commands, the mode of
operation used (8, cyclic synchronous position), the NMT commands and states, and the descriptions of the
emergency (EMCY) error codes a CiA 402 drive sends.  No I/O here.
"""

from __future__ import annotations

from enum import StrEnum

# --- CiA 301 communication objects ----------------------------------------------------------------------------

DEVICE_TYPE = 0x1000                 #: UNSIGNED32; low 16 bits = device profile number (402 for drives)
ERROR_REGISTER = 0x1001              #: UNSIGNED8
COMMUNICATION_CYCLE_PERIOD = 0x1006  #: UNSIGNED32, microseconds between two SYNC messages
CONSUMER_HEARTBEAT_TIME = 0x1016     #: ARRAY of UNSIGNED32: (node id << 16) | timeout in ms
PRODUCER_HEARTBEAT_TIME = 0x1017     #: UNSIGNED16, ms between two heartbeats (0: none)
RPDO_COMMUNICATION = 0x1400          #: 0x1400 + n: RPDO n+1 COB-ID (sub 1) and transmission type (sub 2)
RPDO_MAPPING = 0x1600                #: 0x1600 + n: RPDO n+1 mapped objects (index << 16 | sub << 8 | bits)
TPDO_COMMUNICATION = 0x1800          #: 0x1800 + n: TPDO n+1 COB-ID and transmission type
TPDO_MAPPING = 0x1A00                #: 0x1A00 + n: TPDO n+1 mapped objects

DEVICE_PROFILE_DRIVE = 402

# --- CiA 402 drive objects --------------------------------------------------------------------------------------

CONTROLWORD = 0x6040                 #: UNSIGNED16, written by the master
STATUSWORD = 0x6041                  #: UNSIGNED16, the drive's state
MODES_OF_OPERATION = 0x6060          #: INTEGER8, the requested mode
MODES_OF_OPERATION_DISPLAY = 0x6061  #: INTEGER8, the active mode
POSITION_ACTUAL = 0x6064             #: INTEGER32, position units (encoder counts)
VELOCITY_ACTUAL = 0x606C             #: INTEGER32, velocity units
TARGET_POSITION = 0x607A             #: INTEGER32, position units
VELOCITY_OFFSET = 0x60B1             #: INTEGER32, velocity units (feed-forward in the cyclic modes)

#: 0x6060 / 0x6061: cyclic synchronous position mode
MODE_CSP = 8

#: CANopen data types (CiA 301 table 44) of the objects above
UNSIGNED8, UNSIGNED16, UNSIGNED32 = 0x0005, 0x0006, 0x0007
INTEGER8, INTEGER16, INTEGER32 = 0x0002, 0x0003, 0x0004

# --- the CiA 402 state machine ------------------------------------------------------------------------------------


class DriveState(StrEnum):
    """The states of the CiA 402 power drive state machine, as the statusword (0x6041) shows them."""

    NOT_READY = "Not ready to switch on"
    SWITCH_ON_DISABLED = "Switch on disabled"
    READY = "Ready to switch on"
    SWITCHED_ON = "Switched on"
    OPERATION_ENABLED = "Operation enabled"
    QUICK_STOP = "Quick stop active"
    FAULT_REACTION = "Fault reaction active"
    FAULT = "Fault"
    UNKNOWN = "Unknown"


#: (mask, value, state): the statusword decoding of CiA 402 (bits 0-3, 5, 6)
_STATES = (
    (0x4F, 0x00, DriveState.NOT_READY),
    (0x4F, 0x40, DriveState.SWITCH_ON_DISABLED),
    (0x6F, 0x21, DriveState.READY),
    (0x6F, 0x23, DriveState.SWITCHED_ON),
    (0x6F, 0x27, DriveState.OPERATION_ENABLED),
    (0x6F, 0x07, DriveState.QUICK_STOP),
    (0x4F, 0x0F, DriveState.FAULT_REACTION),
    (0x4F, 0x08, DriveState.FAULT),
)

#: statusword bits beyond the state
SW_VOLTAGE_ENABLED = 1 << 4
SW_WARNING = 1 << 7
SW_REMOTE = 1 << 9
SW_TARGET_REACHED = 1 << 10
SW_FOLLOWS_COMMAND = 1 << 12       #: CSP: the drive follows the target value
SW_FOLLOWING_ERROR = 1 << 13       #: CSP: following error

#: the statusword a drive reports in each state (bits 0-6 of CiA 402 plus "remote" and "voltage enabled")
STATUSWORD_OF = {
    DriveState.NOT_READY: 0x0000,
    DriveState.SWITCH_ON_DISABLED: 0x0040 | SW_REMOTE,
    DriveState.READY: 0x0021 | SW_VOLTAGE_ENABLED | SW_REMOTE,
    DriveState.SWITCHED_ON: 0x0023 | SW_VOLTAGE_ENABLED | SW_REMOTE,
    DriveState.OPERATION_ENABLED: 0x0027 | SW_VOLTAGE_ENABLED | SW_REMOTE | SW_FOLLOWS_COMMAND,
    DriveState.QUICK_STOP: 0x0007 | SW_VOLTAGE_ENABLED | SW_REMOTE,
    DriveState.FAULT_REACTION: 0x000F | SW_VOLTAGE_ENABLED | SW_REMOTE,
    DriveState.FAULT: 0x0008 | SW_VOLTAGE_ENABLED | SW_REMOTE,
}


def drive_state(statusword: int) -> DriveState:
    """The CiA 402 state a statusword (0x6041) shows."""
    for mask, value, state in _STATES:
        if statusword & mask == value:
            return state
    return DriveState.UNKNOWN


# controlword (0x6040) commands, CiA 402 table 33 (bit 7 fault reset, bits 0-3 the device control command)
CW_DISABLE_VOLTAGE = 0x0000
CW_QUICK_STOP = 0x0002
CW_SHUTDOWN = 0x0006
CW_SWITCH_ON = 0x0007               #: also "disable operation" from Operation enabled
CW_ENABLE_OPERATION = 0x000F
CW_FAULT_RESET = 0x0080             #: acts on the rising edge of bit 7


class Command(StrEnum):
    """A device control command decoded from a controlword."""

    SHUTDOWN = "Shutdown"
    SWITCH_ON = "Switch on"
    ENABLE_OPERATION = "Enable operation"
    DISABLE_VOLTAGE = "Disable voltage"
    QUICK_STOP = "Quick stop"
    FAULT_RESET = "Fault reset"
    NONE = "none"


def controlword_command(controlword: int, previous: int = 0) -> Command:
    """The command a controlword (0x6040) gives, ``previous`` being the last one (fault reset is an edge)."""
    if controlword & 0x80 and not previous & 0x80:
        return Command.FAULT_RESET
    if controlword & 0x80:
        return Command.NONE
    if controlword & 0x02 == 0:
        return Command.DISABLE_VOLTAGE
    if controlword & 0x06 == 0x02:
        return Command.QUICK_STOP
    if controlword & 0x0F == 0x06 or controlword & 0x0F == 0x0E:
        return Command.SHUTDOWN
    if controlword & 0x0F == 0x07:
        return Command.SWITCH_ON
    if controlword & 0x0F == 0x0F:
        return Command.ENABLE_OPERATION
    return Command.NONE


# --- NMT (CiA 301) -----------------------------------------------------------------------------------------------

NMT_START = 0x01
NMT_STOP = 0x02
NMT_PRE_OPERATIONAL = 0x80
NMT_RESET_NODE = 0x81
NMT_RESET_COMMUNICATION = 0x82

#: the NMT state byte of a heartbeat (bit 7, the toggle bit, masked off)
NMT_STATE_NAMES = {0x00: "boot-up", 0x04: "stopped", 0x05: "operational", 0x7F: "pre-operational"}
NMT_OPERATIONAL = 0x05
NMT_PRE_OP_STATE = 0x7F

#: COB-ID bases of the pre-defined connection set
SYNC_COB_ID = 0x080
EMCY_BASE = 0x080
TPDO1_BASE, TPDO2_BASE = 0x180, 0x280
RPDO1_BASE, RPDO2_BASE = 0x200, 0x300
HEARTBEAT_BASE = 0x700

# --- EMCY (CiA 301 table 21, CiA 402 annex) -------------------------------------------------------------------

EMCY_DESCRIPTIONS = {
    0x0000: "error reset or no error",
    0x1000: "generic error",
    0x2310: "continuous over-current",
    0x2320: "short circuit or earth leakage",
    0x3210: "DC link over-voltage",
    0x3220: "DC link under-voltage",
    0x4210: "device over-temperature",
    0x4310: "drive over-temperature",
    0x5113: "supply low voltage",
    0x6010: "software reset (watchdog)",
    0x7121: "motor blocked",
    0x7305: "incremental sensor 1 fault",
    0x8110: "CAN overrun (objects lost)",
    0x8120: "CAN in error passive mode",
    0x8130: "life guard or heartbeat error",
    0x8140: "recovered from bus off",
    0x8210: "PDO not processed due to length error",
    0x8220: "PDO length exceeded",
    0x8611: "following error",
    0x8612: "reference limit",
    0xFF00: "device specific",
}

#: the error classes (high byte or nibble) for codes not listed above
_EMCY_CLASSES = ((0xFF00, 0x1000, "generic error"), (0xF000, 0x2000, "current"), (0xF000, 0x3000, "voltage"),
                 (0xF000, 0x4000, "temperature"), (0xFF00, 0x5000, "device hardware"),
                 (0xF000, 0x6000, "device software"), (0xFF00, 0x7000, "additional modules"),
                 (0xF000, 0x8000, "monitoring"), (0xFF00, 0x9000, "external error"),
                 (0xFF00, 0xF000, "additional functions"), (0xFF00, 0xFF00, "device specific"))


def emcy_description(code: int) -> str:
    """Words for an EMCY error code (CiA 301 / CiA 402), e.g. ``0x2310`` -> ``"continuous over-current"``."""
    if code in EMCY_DESCRIPTIONS:
        return EMCY_DESCRIPTIONS[code]
    for mask, value, text in _EMCY_CLASSES:
        if code & mask == value:
            return text
    return "unknown error"
