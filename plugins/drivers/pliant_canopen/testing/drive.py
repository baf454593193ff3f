"""One emulated CiA 402 servo drive of the CANopen peer: a ``canopen.LocalNode`` over the EDS, its CiA 402 state
machine and its joint model (see :mod:`pliant_canopen.testing.peer`)."""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

from pliant_canopen import cia402
from pliant_canopen.cia402 import Command, DriveState
from pliant_canopen.jointmap import JointDrive

if TYPE_CHECKING:
    from pliant_canopen.testing.peer import CanopenPeer

log = logging.getLogger(__name__)



@dataclass(frozen=True)
class _Mapping:
    """One PDO as configured in a drive's object dictionary: COB-ID, transmission type, mapped (index, sub, bits)."""

    cob_id: int
    trans_type: int
    entries: tuple[tuple[int, int, int], ...]

    @property
    def size(self) -> int:
        """The PDO's length in bytes."""
        return sum(bits for _, _, bits in self.entries) // 8


class PeerDrive:
    """One emulated CiA 402 drive: a ``canopen.LocalNode`` over the EDS, its state machine and joint model.

    Units are the drive's: positions in counts, the model's velocity in counts/s (``max_velocity``; 0x606C reports
    it in the joint map's velocity units), ``tau`` in s.
    """

    def __init__(self, peer: CanopenPeer, joint: JointDrive, *, position: int, max_velocity: float,
                 tau: float) -> None:
        import canopen

        self.peer = peer
        self.joint = joint
        self.id = joint.node
        self.node = canopen.LocalNode(joint.node, str(joint.eds))
        self.state = DriveState.NOT_READY
        self.position = float(position)       # counts
        self.velocity = 0.0                   # counts/s
        self._units_per_count = joint.velocity_factor / joint.counts_per_radian   # 0x606C units per count/s
        self.target = int(position)           # counts, applied
        self.velocity_offset = 0              # velocity units, applied
        self.max_velocity = float(max_velocity)
        self.tau = float(tau)
        self.mode = 0
        self.controlword = 0
        self.cycle_period = 0.0               # s, 0x1006
        self.transitions: list[tuple[float, DriveState, int]] = []   # (monotonic time, state, statusword)
        self.emcy_sent: list[int] = []
        self.rpdo_length_errors = 0
        self._pending: dict[int, int] = {}    # object index -> value, applied on the next SYNC
        self._rpdos: list[_Mapping] = []
        self._tpdos: list[_Mapping] = []
        self._last_sync: float | None = None
        self._sync_count = 0
        self._consumer: tuple[int, float] | None = None   # (master node id, timeout s)
        self._master_seen: float | None = None
        self._consumer_tripped = False
        # injected faults
        self.heartbeat_dropped = False
        self.enable_refused = ""
        self._short: dict[int, tuple[int, int]] = {}      # TPDO number -> (frames left, bytes to send)
        self.node.add_read_callback(self._on_read)
        self.node.add_write_callback(self._on_write)

    # --- CANopen plumbing ---------------------------------------------------------------------------------------

    def attach(self, network) -> None:
        """Join ``network`` and listen to NMT, SYNC and (when configured) the master's heartbeat."""
        network.add_node(self.node)
        network.subscribe(0, self._on_nmt)
        network.subscribe(cia402.SYNC_COB_ID, self._on_sync)

    def boot(self) -> None:
        """Power-up: boot-up message, NMT pre-operational (heartbeat starts), CiA 402 Switch on disabled."""
        self.node.nmt.send_command(cia402.NMT_RESET_NODE)        # INITIALISING: sends the boot-up message
        self.node.nmt.send_command(cia402.NMT_PRE_OPERATIONAL)   # starts the heartbeat (0x1017)
        if self.heartbeat_dropped:
            self.node.nmt.stop_heartbeat()
        self._set_state(DriveState.SWITCH_ON_DISABLED)

    @property
    def nmt_operational(self) -> bool:
        """Whether the drive's NMT state is operational (PDOs and SYNC are processed only then)."""
        return self.node.nmt.state == "OPERATIONAL"

    @property
    def statusword(self) -> int:
        """0x6041 from the state, with target reached (bit 10) in Operation enabled."""
        word = cia402.STATUSWORD_OF[self.state]
        if self.state == DriveState.OPERATION_ENABLED and abs(self.target - self.position) < 1.0:
            word |= cia402.SW_TARGET_REACHED
        return word

    def _on_read(self, index: int, subindex: int, od):
        values = {cia402.STATUSWORD: self.statusword, cia402.MODES_OF_OPERATION_DISPLAY: self.mode,
                  cia402.POSITION_ACTUAL: round(self.position),
                  cia402.VELOCITY_ACTUAL: round(self.velocity * self._units_per_count),
                  cia402.CONTROLWORD: self.controlword, cia402.MODES_OF_OPERATION: self.mode}
        return values.get(index)

    def _on_write(self, index: int, subindex: int, od, data: bytes) -> None:
        value = od.decode_raw(data)
        if index == cia402.CONTROLWORD:
            self._controlword(value)
        elif index == cia402.MODES_OF_OPERATION:
            self.mode = value
        elif index == cia402.TARGET_POSITION:
            self._pending[index] = value
        elif index == cia402.COMMUNICATION_CYCLE_PERIOD:
            self.cycle_period = value * 1e-6
        elif index == cia402.CONSUMER_HEARTBEAT_TIME and subindex == 1:
            self._configure_consumer(value)
        elif index == cia402.PRODUCER_HEARTBEAT_TIME and self.heartbeat_dropped:
            self.node.nmt.stop_heartbeat()      # the NMT slave restarted it; the fault keeps it off

    def _configure_consumer(self, value: int) -> None:
        master, timeout_ms = (value >> 16) & 0x7F, value & 0xFFFF
        network = self.node.network
        if self._consumer is not None:
            network.unsubscribe(cia402.HEARTBEAT_BASE + self._consumer[0], self._on_master_heartbeat)
        self._consumer, self._master_seen, self._consumer_tripped = None, None, False
        if master and timeout_ms:
            self._consumer = (master, timeout_ms / 1000)
            network.subscribe(cia402.HEARTBEAT_BASE + master, self._on_master_heartbeat)

    @property
    def master_heard(self) -> bool:
        """Whether the heartbeat consumer (0x1016) is set and has heard the master: only from its first heartbeat on
        does a silent master trip it (CiA 301's consumer starts with the first heartbeat it receives)."""
        return self._consumer is not None and self._master_seen is not None

    def _on_master_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        self._master_seen = time.monotonic()
        self._consumer_tripped = False

    def supervise(self, now: float) -> None:
        """The heartbeat consumer (0x1016): the master silent for its timeout -> EMCY 0x8130 and Fault."""
        consumer = self._consumer
        if consumer is None or self._master_seen is None or self._consumer_tripped:
            return
        if now - self._master_seen > consumer[1]:
            self._consumer_tripped = True
            log.warning("peer node %d: master heartbeat lost", self.id)
            self.fault(0x8130)

    def _on_nmt(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if len(data) != 2:
            return
        command, node = data[0], data[1]
        if node not in (0, self.id):
            return
        if command in (cia402.NMT_RESET_NODE, cia402.NMT_RESET_COMMUNICATION):
            if command == cia402.NMT_RESET_NODE:
                self.node.data_store.clear()
                self.mode = 0
            else:
                for index in [i for i in self.node.data_store if 0x1000 <= i < 0x2000]:
                    del self.node.data_store[index]
            self._consumer = None
            self.boot()
        elif command == cia402.NMT_START:
            self._load_pdos()
        if not self.nmt_operational:
            self._pending.clear()

    def _load_pdos(self) -> None:
        """Read the PDO configuration (0x1400-0x15FF / 0x1600, 0x1800 / 0x1A00) from the object dictionary."""
        network = self.node.network
        for mapping in self._rpdos:
            network.unsubscribe(mapping.cob_id, self._on_rpdo)
        self._rpdos = self._read_pdos(cia402.RPDO_COMMUNICATION, cia402.RPDO_MAPPING)
        self._tpdos = self._read_pdos(cia402.TPDO_COMMUNICATION, cia402.TPDO_MAPPING)
        for mapping in self._rpdos:
            network.subscribe(mapping.cob_id, self._on_rpdo)

    def _read_pdos(self, communication: int, mapping: int) -> list[_Mapping]:
        sdo = self.node.sdo
        od = self.node.object_dictionary
        pdos = []
        for n in range(512):
            if communication + n not in od:
                continue
            cob = sdo[communication + n][1].raw
            if cob & (1 << 31):
                pdos.append(None)
                continue
            entries = []
            for sub in range(1, sdo[mapping + n][0].raw + 1):
                value = sdo[mapping + n][sub].raw
                entries.append((value >> 16, (value >> 8) & 0xFF, value & 0xFF))
            pdos.append(_Mapping(cob & 0x7FF, sdo[communication + n][2].raw, tuple(entries)))
        return [p for p in pdos if p is not None] if communication == cia402.RPDO_COMMUNICATION else pdos

    # --- PDOs and SYNC ------------------------------------------------------------------------------------------

    def _on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if not self.nmt_operational:
            return
        mapping = next((m for m in self._rpdos if m.cob_id == can_id), None)
        if mapping is None:
            return
        if len(data) != mapping.size:
            self.rpdo_length_errors += 1
            self.emcy(0x8210)
            return
        values, offset = {}, 0
        for index, sub, bits in mapping.entries:
            od = self.node.object_dictionary.get_variable(index, sub)
            values[index] = od.decode_raw(bytes(data[offset:offset + bits // 8]))
            offset += bits // 8
        if cia402.TARGET_POSITION in values:
            self.peer.record(self.id, values[cia402.TARGET_POSITION], values.get(cia402.VELOCITY_OFFSET, 0))
        if mapping.trans_type <= 240:
            self._pending.update(values)
        else:
            self._apply(values)

    def _apply(self, values: dict[int, int]) -> None:
        if cia402.CONTROLWORD in values:
            self._controlword(values[cia402.CONTROLWORD])
        if self.state == DriveState.OPERATION_ENABLED and self.mode == cia402.MODE_CSP:
            if cia402.TARGET_POSITION in values:
                self.target = values[cia402.TARGET_POSITION]
            if cia402.VELOCITY_OFFSET in values:
                self.velocity_offset = values[cia402.VELOCITY_OFFSET]

    def _on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        now = time.monotonic()
        dt = 0.0 if self._last_sync is None else now - self._last_sync
        self._last_sync = now
        if not self.nmt_operational:
            return
        self._sync_count += 1
        pending, self._pending = self._pending, {}
        self._apply(pending)
        self._step(min(dt, 5 * (self.cycle_period or 0.01)))
        for number, mapping in enumerate(self._tpdos, start=1):
            if mapping is None or mapping.trans_type == 0 or mapping.trans_type > 240:
                continue
            if self._sync_count % mapping.trans_type:
                continue
            self._send_tpdo(number, mapping)

    def _step(self, dt: float) -> None:
        """Move the joint model by ``dt`` s: a first-order servo toward the target, capped at max_velocity."""
        if self.state == DriveState.OPERATION_ENABLED and self.mode == cia402.MODE_CSP and dt > 0:
            error = self.target - self.position
            move = error * (1.0 - math.exp(-dt / self.tau))
            limit = self.max_velocity * dt
            move = max(-limit, min(limit, move))
            self.position += move
            self.velocity = move / dt
        else:
            self.velocity = 0.0
            if self.state != DriveState.OPERATION_ENABLED:
                self.target = round(self.position)

    def _send_tpdo(self, number: int, mapping: _Mapping) -> None:
        data = bytearray()
        for index, sub, bits in mapping.entries:
            od = self.node.object_dictionary.get_variable(index, sub)
            value = self._on_read(index, sub, od)
            raw = od.encode_raw(value) if value is not None else self.node.get_data(index, sub)
            data += raw[:bits // 8]
        short = self._short.get(number)
        if short is not None:
            left, size = short
            data = data[:size]
            self._short[number] = (left - 1, size)
            if left <= 1:
                del self._short[number]
        self.node.network.send_message(mapping.cob_id, bytes(data))

    # --- the CiA 402 state machine -----------------------------------------------------------------------------

    def _set_state(self, state: DriveState) -> None:
        if state == self.state:
            return
        if state == DriveState.OPERATION_ENABLED:
            self.target = round(self.position)     # a CSP drive starts from where it is
            self._pending.pop(cia402.TARGET_POSITION, None)
        self.state = state
        self.transitions.append((time.monotonic(), state, self.statusword))

    def _controlword(self, controlword: int) -> None:
        command = cia402.controlword_command(controlword, self.controlword)
        self.controlword = controlword
        s, S = self.state, DriveState
        if command == Command.FAULT_RESET:
            if s == S.FAULT:
                self._set_state(S.SWITCH_ON_DISABLED)
                self.emcy(0x0000)
            return
        if s in (S.FAULT, S.FAULT_REACTION, S.NOT_READY):
            return
        if command == Command.DISABLE_VOLTAGE:
            self._set_state(S.SWITCH_ON_DISABLED)
        elif command == Command.QUICK_STOP:
            self._set_state(S.QUICK_STOP if s == S.OPERATION_ENABLED else S.SWITCH_ON_DISABLED)
        elif command == Command.SHUTDOWN:
            if s in (S.SWITCH_ON_DISABLED, S.SWITCHED_ON, S.OPERATION_ENABLED):
                self._set_state(S.READY)
        elif command == Command.SWITCH_ON:
            if s == S.READY and not self.enable_refused:
                self._set_state(S.SWITCHED_ON)
            elif s == S.OPERATION_ENABLED:
                self._set_state(S.SWITCHED_ON)
        elif command == Command.ENABLE_OPERATION:
            if s in (S.SWITCHED_ON, S.QUICK_STOP) or (s == S.READY and not self.enable_refused):
                self._set_state(S.OPERATION_ENABLED)

    # --- faults ----------------------------------------------------------------------------------------------

    def emcy(self, code: int, register: int | None = None) -> None:
        """Send an EMCY (CiA 301): error ``code``, error register 0x1001 (default generic error, bit 0)."""
        if register is None:
            register = 0 if code == 0 else 0x01 | (0x02 if code & 0xF000 == 0x2000 else 0) | \
                (0x10 if code & 0xF000 == 0x8000 else 0)
        self.emcy_sent.append(code)
        try:
            self.node.emcy.send(code, register)
        except Exception as exc:  # the bus closed under us
            log.debug("peer node %d: EMCY not sent: %s", self.id, exc)

    def fault(self, code: int = 0x2310) -> None:
        """A drive fault: Fault reaction active, then Fault (the joint stops and holds), and EMCY ``code``."""
        self.velocity = 0.0
        self.target = round(self.position)
        self._set_state(DriveState.FAULT_REACTION)
        self._set_state(DriveState.FAULT)
        self.emcy(code)

    def drop_heartbeat(self) -> None:
        """Stop producing heartbeats (everything else keeps working)."""
        self.heartbeat_dropped = True
        self.node.nmt.stop_heartbeat()

    def short_frame(self, tpdo: int = 1, size: int | None = None, count: int = 1) -> None:
        """Send the next ``count`` frames of TPDO ``tpdo`` with only ``size`` bytes (default two fewer)."""
        mapping = self._tpdos[tpdo - 1] if len(self._tpdos) >= tpdo else None
        full = mapping.size if mapping is not None else 6
        self._short[tpdo] = (count, max(0, full - 2) if size is None else size)
