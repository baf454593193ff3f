"""The ``canopen`` driver: an arm of CiA 402 joint drives on a CAN bus, in cyclic synchronous position mode.

Only the transport lives here (pliant's core does the smoothing, the limits, the watchdogs and the stops).  The
driver is the CANopen master (CiA 301) of the drives its joint map lists:

* **bring-up** (:meth:`CanopenDriver.open`): NMT *enter pre-operational*; per drive an SDO read of the device
  type 0x1000 (is it there, is it a CiA 402 drive?), the heartbeat producer time 0x1017, the heartbeat consumer
  0x1016 (the drive watches the master's heartbeat), the communication cycle period 0x1006, modes of operation
  0x6060 = 8 (cyclic synchronous position) checked on 0x6061; the PDOs (RPDO1: target position 0x607A and the
  velocity offset 0x60B1; TPDO1: statusword 0x6041 and position actual 0x6064; TPDO2: velocity actual 0x606C and
  modes of operation display 0x6061; all synchronous, transmission type 1); NMT *start*; then it waits for a
  complete set of TPDOs.
* **the cycle**: every :meth:`~CanopenDriver.write` sends each drive's RPDO1 and then one SYNC, so the drives
  take the new targets together and answer with their TPDOs; while the core is not writing (before it starts,
  after it stopped: no write for 1.5 ``sync_period``) a keep-alive SYNC repeats the held targets, with a zero
  velocity offset.  The keep-alive is serialised with the core's writes (one lock around every RPDO set + SYNC)
  and never contradicts the core's stream: while the stream's last command moved (a non-zero velocity, or a
  target other than the one before), a late write is waited for -- repeating its target would be a one-cycle
  stand-still at the drives, far beyond the acceleration limit -- and the keep-alive resumes once the stream
  holds (its last command at rest), has ended (:meth:`~CanopenDriver.shutdown`) or stayed silent for
  ``stream_timeout`` (then it is gone, and holding its last target is the stop a CSP drive makes anyway).
  The TPDOs answering one SYNC make one :class:`~pliant.hardware.state.JointState`, stamped with that SYNC's time.
* **enable** (:meth:`~CanopenDriver.enable`): the CiA 402 state machine through the controlword 0x6040 (fault
  reset from Fault, Shutdown, Switch on, Enable operation) while reading the statusword 0x6041, with each drive's
  target first set to its actual position.
* **supervision**: a heartbeat consumer per drive (no heartbeat for ``heartbeat_timeout``, a boot-up or an NMT
  state other than operational is a fault, and joint states stop), EMCY messages (their error codes in words),
  the statusword's Fault and Quick stop states, and every received frame's length: a TPDO, heartbeat or EMCY of
  the wrong length is a fault and is never decoded.  :meth:`~CanopenDriver.robot_status` reports them.  Each
  fault is one entry (and one ERROR log line) however long it lasts: a lost heartbeat's entry keeps its age
  current ("none for 0.401 s") without adding entries.
"""

from __future__ import annotations

import logging
import struct
import threading
import time
from dataclasses import dataclass

import numpy as np
from pliant.api import (
    ConfigError,
    ConnectionLost,
    Driver,
    DriverError,
    DriverOptions,
    JointState,
    RobotDisabled,
    RobotStatus,
    option,
)

from pliant_canopen import cia402
from pliant_canopen.cia402 import DriveState, drive_state
from pliant_canopen.jointmap import JointMap, load_joint_map, load_object_dictionary

log = logging.getLogger(__name__)

#: TPDO1 (statusword UNSIGNED16, position actual INTEGER32) and TPDO2 (velocity actual INTEGER32, mode INTEGER8)
TPDO1 = struct.Struct("<Hi")
TPDO2 = struct.Struct("<ib")
#: RPDO1: target position INTEGER32 (+ velocity offset INTEGER32)
RPDO_POSITION = struct.Struct("<i")
RPDO_POSITION_VELOCITY = struct.Struct("<ii")
#: seconds between two polls of the statusword while enabling
POLL = 0.002


@dataclass(frozen=True)
class CanopenDriverOptions(DriverOptions):
    """Options of the ``canopen`` driver (on top of every driver's options)."""

    joint_map: str | None = option(None, "joint-map TOML file: node id, scaling, direction and offset per URDF joint "
                                   "and the limits file (pliant_canopen.jointmap); default the bundled 7-joint "
                                   "KUKA iiwa example")
    interface: str = option("virtual", "python-can interface (virtual, socketcan, pcan, kvaser, udp_multicast ...)")
    channel: str = option("pliant-canopen", "python-can channel (e.g. can0; any name on the virtual interface)")
    bitrate: int = option(1_000_000, "CAN bit rate (bit/s)", minimum=10_000, maximum=1_000_000)
    sync_period: float | None = option(None, "SYNC period while the core is not writing (s); while it streams, "
                                       "each write is followed by one SYNC; default the limits' command period",
                                       minimum=1e-4, maximum=1.0)
    heartbeat_timeout: float = option(0.25, "heartbeat consumer timeout (s), both ways: a drive silent this long is "
                                      "a fault, and the drives fault when the master is; producers send every "
                                      "quarter of it", minimum=0.004, maximum=60.0)
    sdo_timeout: float = option(0.3, "seconds to wait for one SDO answer (configuration and enabling)",
                                minimum=0.01, maximum=10.0)
    enable_timeout: float = option(1.0, "seconds each CiA 402 state change may take when enabling", minimum=0.01)
    velocity_feedforward: bool = option(True, "map the velocity offset 0x60B1 into RPDO1 (the command's velocity as "
                                        "feed-forward); off: RPDO1 holds only the target position 0x607A")
    master_node_id: int = option(127, "node id of the master's heartbeat (COB-ID 0x700 + id) that the drives "
                                 "consume through 0x1016; 0: no master heartbeat", minimum=0, maximum=127)
    stream_timeout: float = option(0.5, "a moving command stream silent this long has ended (s): the keep-alive "
                                   "SYNC then holds its last target; a shorter silence is a late command, waited for",
                                   minimum=0.001)
    reset_faults: bool = option(False, "on open, reset drive faults left from an earlier session (controlword "
                                "fault reset); off: a faulted drive refuses to connect")


class _Drive:
    """What the driver knows about one drive (mutated under the driver's lock)."""

    def __init__(self, index: int, name: str, node_id: int) -> None:
        self.index = index
        self.name = name
        self.id = node_id
        self.remote = None                  # canopen.RemoteNode
        self.statusword: int | None = None
        self.position: int | None = None    # counts
        self.velocity: int | None = None    # velocity units
        self.mode: int | None = None
        self.heartbeat: float | None = None  # monotonic time of the last heartbeat
        self.nmt: int | None = None
        self.emcy: dict[int, str] = {}       # active EMCY codes -> description
        self.received = 0                    # bit 0: TPDO1, bit 1: TPDO2 for the current SYNC
        self.controlword = 0
        self.consumer = False                # 0x1016 configured

    @property
    def label(self) -> str:
        """``node N (joint)`` for messages."""
        return f"node {self.id} ({self.name})"

    @property
    def state(self) -> DriveState | None:
        """The CiA 402 state of the last statusword (0x6041), ``None`` before the first."""
        return None if self.statusword is None else drive_state(self.statusword)


class CanopenDriver(Driver):
    """An arm of CiA 402 joint drives over CANopen (python-can + canopen); see the module docstring.

    Joint names, node ids and scaling come from the ``joint_map`` option's file; positions are rad, velocities
    rad/s in :meth:`joint_names` order.  Objects touched: 0x1000, 0x1006, 0x1016, 0x1017, 0x1400-0x1401,
    0x1600-0x1601, 0x1800-0x1801, 0x1A00-0x1A01 (CiA 301) and 0x6040, 0x6041, 0x6060, 0x6061, 0x6064, 0x606C,
    0x607A, 0x60B1 (CiA 402).
    """

    Options = CanopenDriverOptions

    def __init__(self, options=None, **kwargs) -> None:
        super().__init__(options, **kwargs)
        self._map: JointMap | None = None
        self._lock = threading.RLock()
        self._send_lock = threading.Lock()
        self._network = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._closing = False
        self._reset_runtime()

    # --- the joint map ------------------------------------------------------------------------------------------

    @property
    def joint_map(self) -> JointMap:
        """The joint map (read from the ``joint_map`` option's file on first use)."""
        if self._map is None:
            self._map = load_joint_map(self.options.joint_map)
        return self._map

    def joint_names(self) -> tuple[str, ...]:
        """The URDF joint names, in the joint map's order (the command order)."""
        return self.joint_map.names

    def default_limits_file(self):
        """The limits file the joint map names (its ``limits`` field)."""
        return self.joint_map.limits

    # --- runtime state ----------------------------------------------------------------------------------------

    def _reset_runtime(self) -> None:
        self._drives: list[_Drive] = []
        self._state: JointState | None = None
        self._sequence = 0
        self._sync_index = 0
        self._published_sync = -1                        # the SYNC of the newest joint state
        self._sync_time = 0.0
        self._last_sync = 0.0
        self._last_master_heartbeat = 0.0
        self._hold: np.ndarray | None = None            # counts, per drive
        self._hold_velocity: np.ndarray | None = None   # velocity units, per drive
        self._comm_faults: dict[str, str] = {}          # what the fault is -> its text (latched until open)
        self._stream_moving = False                     # the core's last write moved (see _keep_alive)
        self._syncing = False
        self._operational = False
        self._period = 0.01
        self._heartbeat_period = 0.05

    def _comm_fault(self, text: str, key: str | None = None) -> None:
        """Latch a communication fault (until the next open): joint states stop, robot_status reports it.

        ``key`` is the fault's identity (default the text): a fault already latched under it only has its text
        updated (a lost heartbeat's age), so one fault is one entry and one ERROR line however often it is seen.
        """
        key = text if key is None else key
        with self._lock:
            if key not in self._comm_faults:
                log.error("canopen: %s", text)
            self._comm_faults[key] = text

    @property
    def _where(self) -> str:
        return f"{self.options.interface} channel {self.options.channel!r}"

    # --- open ----------------------------------------------------------------------------------------------------

    def open(self) -> None:
        """Bring the drives up (NMT, SDO configuration, PDOs, NMT start) and wait for their first TPDOs.

        Raises :class:`~pliant.errors.ConnectionLost` (one line: which node did not answer) when a drive is absent,
        :class:`~pliant.errors.ConfigError` for a bad joint map or EDS, :class:`~pliant.errors.DriverError` when a
        drive refuses its configuration.
        """
        if self._network is not None:
            return
        import can
        import canopen

        o = self.options
        jm = self.joint_map
        limits = self.limits
        jm.check_range(limits.lower, limits.upper, limits.velocity)
        if o.master_node_id in jm.nodes:
            raise ConfigError("is also a drive's node id in the joint map", source=jm.source, field="master_node_id",
                              value=o.master_node_id)
        dictionaries = [load_object_dictionary(j.eds, j.node, velocity_offset=o.velocity_feedforward)
                        for j in jm.joints]
        self._reset_runtime()
        self._period = float(o.sync_period or limits.period)
        self._heartbeat_period = max(0.001, o.heartbeat_timeout / 4)
        try:
            bus = can.Bus(interface=o.interface, channel=o.channel, bitrate=o.bitrate)
        except Exception as exc:
            raise ConnectionLost(f"cannot open CAN {self._where}: {type(exc).__name__}: {exc}".replace("\n", " "),
                                 field="interface") from None
        network = canopen.Network(bus)
        network.NOTIFIER_CYCLE = 0.05      # shut down within 50 ms
        network.connect()
        self._network = network
        self._stop.clear()
        try:
            self._bring_up(network, dictionaries)
        except BaseException:
            self.shutdown()
            raise

    def _bring_up(self, network, dictionaries) -> None:
        import canopen

        o = self.options
        jm = self.joint_map
        for i, (joint, od) in enumerate(zip(jm.joints, dictionaries)):
            drive = _Drive(i, joint.name, joint.node)
            remote = canopen.RemoteNode(joint.node, od)
            remote.sdo.RESPONSE_TIMEOUT = o.sdo_timeout
            remote.sdo.MAX_RETRIES = 1
            network.add_node(remote)
            drive.remote = remote
            network.subscribe(cia402.HEARTBEAT_BASE + joint.node, self._heartbeat_callback(drive))
            network.subscribe(cia402.EMCY_BASE + joint.node, self._emcy_callback(drive))
            network.subscribe(cia402.TPDO1_BASE + joint.node, self._tpdo_callback(drive, 0, TPDO1))
            network.subscribe(cia402.TPDO2_BASE + joint.node, self._tpdo_callback(drive, 1, TPDO2))
            self._drives.append(drive)
        self._thread = threading.Thread(target=self._run, name="pliant-canopen-sync", daemon=True)
        self._thread.start()
        for drive in self._drives:
            drive.remote.nmt.send_command(cia402.NMT_PRE_OPERATIONAL)
        for drive in self._drives:
            self._configure(drive)
        for drive in self._drives:
            self._configure_pdos(drive)
        with self._lock:
            self._syncing = True
        for drive in self._drives:
            drive.remote.nmt.send_command(cia402.NMT_START)
        self._wait_operational()
        if o.reset_faults:
            for drive in self._drives:
                if drive.state in (DriveState.FAULT, DriveState.FAULT_REACTION):
                    self._fault_reset(drive)

    def _sdo(self, drive: _Drive, what: str, call, *args):
        """One SDO transfer; a silent drive raises ConnectionLost, a refusal DriverError naming the object."""
        import canopen

        try:
            return call(*args)
        except canopen.SdoCommunicationError:
            with self._lock:
                heard = drive.heartbeat is not None
            why = ("its heartbeat arrives but it does not answer SDO" if heard else
                   "no heartbeat and no SDO answer")
            raise ConnectionLost(f"CANopen {drive.label} on {self._where}: {why} within {self.options.sdo_timeout:g} "
                                 f"s ({what}); is the drive powered, on this bus and at this node id and bit rate?",
                                 field="joint_map") from None
        except canopen.SdoAbortedError as exc:
            raise DriverError(f"CANopen {drive.label} refused {what}: {exc}", joint=drive.name) from None

    def _configure(self, drive: _Drive) -> None:
        """Check the device type, set the heartbeats, the cycle period and cyclic synchronous position mode."""
        o = self.options
        sdo = drive.remote.sdo
        raw = self._sdo(drive, "reading the device type 0x1000", sdo.upload, cia402.DEVICE_TYPE, 0)
        device_type = int.from_bytes(raw[:4], "little")
        if device_type & 0xFFFF != cia402.DEVICE_PROFILE_DRIVE:
            raise DriverError(f"CANopen {drive.label} is not a CiA 402 drive (device type 0x1000 = "
                              f"0x{device_type:08X})", joint=drive.name)
        ms = max(1, round(self._heartbeat_period * 1000))
        self._sdo(drive, "the producer heartbeat time 0x1017", sdo.download, cia402.PRODUCER_HEARTBEAT_TIME, 0,
                  struct.pack("<H", ms))
        od = drive.remote.object_dictionary
        if o.master_node_id and cia402.CONSUMER_HEARTBEAT_TIME in od:
            timeout_ms = min(0xFFFF, max(1, round(o.heartbeat_timeout * 1000)))
            self._sdo(drive, "the consumer heartbeat time 0x1016:01", sdo.download, cia402.CONSUMER_HEARTBEAT_TIME,
                      1, struct.pack("<I", (o.master_node_id << 16) | timeout_ms))
            drive.consumer = True
        if cia402.COMMUNICATION_CYCLE_PERIOD in od:
            self._sdo(drive, "the communication cycle period 0x1006", sdo.download,
                      cia402.COMMUNICATION_CYCLE_PERIOD, 0, struct.pack("<I", round(self._period * 1e6)))
        self._sdo(drive, "modes of operation 0x6060 = 8", sdo.download, cia402.MODES_OF_OPERATION, 0,
                  struct.pack("<b", cia402.MODE_CSP))
        deadline = time.monotonic() + o.enable_timeout
        while True:
            mode = struct.unpack("<b", self._sdo(drive, "reading 0x6061", sdo.upload,
                                                 cia402.MODES_OF_OPERATION_DISPLAY, 0)[:1])[0]
            if mode == cia402.MODE_CSP:
                break
            if time.monotonic() > deadline:
                raise DriverError(f"CANopen {drive.label} does not enter cyclic synchronous position mode "
                                  f"(0x6061 = {mode} after 0x6060 = 8)", joint=drive.name)
            time.sleep(POLL)

    def _configure_pdos(self, drive: _Drive) -> None:
        """RPDO1: 0x607A (+ 0x60B1); TPDO1: 0x6041, 0x6064; TPDO2: 0x606C, 0x6061; synchronous; others off."""
        import canopen

        remote = drive.remote
        node = drive.id
        try:
            remote.rpdo.read(from_od=True)
            remote.tpdo.read(from_od=True)
            for number, pdo in remote.rpdo.map.items():
                pdo.enabled = number == 1
            rpdo = remote.rpdo[1]
            rpdo.clear()
            rpdo.add_variable(cia402.TARGET_POSITION)
            if self.options.velocity_feedforward:
                rpdo.add_variable(cia402.VELOCITY_OFFSET)
            rpdo.cob_id, rpdo.trans_type = cia402.RPDO1_BASE + node, 1
            for number, pdo in remote.tpdo.map.items():
                pdo.enabled = number in (1, 2)
            tpdo1, tpdo2 = remote.tpdo[1], remote.tpdo[2]
            tpdo1.clear()
            tpdo1.add_variable(cia402.STATUSWORD)
            tpdo1.add_variable(cia402.POSITION_ACTUAL)
            tpdo1.cob_id, tpdo1.trans_type = cia402.TPDO1_BASE + node, 1
            tpdo2.clear()
            tpdo2.add_variable(cia402.VELOCITY_ACTUAL)
            tpdo2.add_variable(cia402.MODES_OF_OPERATION_DISPLAY)
            tpdo2.cob_id, tpdo2.trans_type = cia402.TPDO2_BASE + node, 1
            remote.rpdo.save()
            remote.tpdo.save()
        except canopen.SdoCommunicationError:
            raise ConnectionLost(f"CANopen {drive.label} stopped answering SDO while its PDOs were configured on "
                                 f"{self._where}", field="joint_map") from None
        except canopen.SdoAbortedError as exc:
            raise DriverError(f"CANopen {drive.label} refused its PDO mapping (0x1400/0x1600/0x1800/0x1A00): {exc}",
                              joint=drive.name) from None

    def _wait_operational(self) -> None:
        """Wait (connect_timeout) for every drive to report NMT operational and for one complete joint state."""
        deadline = time.monotonic() + self.options.connect_timeout
        while time.monotonic() < deadline:
            with self._lock:
                if self._comm_faults:
                    first = next(iter(self._comm_faults.values()))
                    raise ConnectionLost(f"CANopen bring-up failed: {first}", field="joint_map")
                if self._state is not None and all(d.nmt == cia402.NMT_OPERATIONAL for d in self._drives):
                    self._operational = True
                    return
            time.sleep(POLL)
        with self._lock:
            for drive in self._drives:
                if drive.nmt != cia402.NMT_OPERATIONAL:
                    state = cia402.NMT_STATE_NAMES.get(drive.nmt, "no heartbeat") if drive.nmt is not None \
                        else "no heartbeat"
                    raise ConnectionLost(f"CANopen {drive.label} did not become NMT operational within "
                                         f"{self.options.connect_timeout:g} s ({state})", field="joint_map")
            missing = [d.label for d in self._drives if d.received != 3]
        raise ConnectionLost(f"no complete TPDOs from the drives within {self.options.connect_timeout:g} s after NMT "
                             f"start (missing: {', '.join(missing) or 'none'})", field="joint_map")

    # --- the receive callbacks (python-can notifier thread) -----------------------------------------------------

    def _heartbeat_callback(self, drive: _Drive):
        def on_heartbeat(can_id: int, data: bytearray, timestamp: float) -> None:
            """Heartbeat (0x700 + node): 1 byte, the NMT state."""
            if len(data) != 1:
                self._comm_fault(f"{drive.label}: heartbeat frame (COB-ID 0x{can_id:03X}) of {len(data)} bytes, "
                                 "expected 1: not decoded")
                return
            state = data[0] & 0x7F
            with self._lock:
                drive.heartbeat = time.monotonic()
                drive.nmt = state
                operational = self._operational
            if operational and state != cia402.NMT_OPERATIONAL:
                what = "rebooted (boot-up message)" if state == 0 else \
                    f"left NMT operational ({cia402.NMT_STATE_NAMES.get(state, hex(state))})"
                self._comm_fault(f"{drive.label} {what}")
        return on_heartbeat

    def _emcy_callback(self, drive: _Drive):
        def on_emcy(can_id: int, data: bytearray, timestamp: float) -> None:
            """EMCY (0x080 + node): 8 bytes, error code, error register, vendor data."""
            if len(data) != 8:
                self._comm_fault(f"{drive.label}: EMCY frame (COB-ID 0x{can_id:03X}) of {len(data)} bytes, "
                                 "expected 8: not decoded")
                return
            code, register = struct.unpack_from("<HB", data)
            with self._lock:
                if code & 0xFF00 == 0:
                    drive.emcy.clear()
                    return
                drive.emcy[code] = (f"EMCY 0x{code:04X} {cia402.emcy_description(code)} "
                                    f"(error register 0x{register:02X})")
            log.warning("canopen: %s: %s", drive.label, drive.emcy[code])
        return on_emcy

    def _tpdo_callback(self, drive: _Drive, bit: int, layout: struct.Struct):
        def on_tpdo(can_id: int, data: bytearray, timestamp: float) -> None:
            """TPDO1 / TPDO2 (0x180 / 0x280 + node): exactly the mapped length, else a fault."""
            if len(data) != layout.size:
                self._comm_fault(f"{drive.label}: TPDO{bit + 1} (COB-ID 0x{can_id:03X}) carried {len(data)} bytes, its "
                                 f"mapping has {layout.size}: frame not decoded")
                return
            first, second = layout.unpack(bytes(data))
            with self._lock:
                if bit == 0:
                    drive.statusword, drive.position = first, second
                else:
                    drive.velocity, drive.mode = first, second
                drive.received |= 1 << bit
                if all(d.received == 3 for d in self._drives):
                    self._publish()
        return on_tpdo

    def _publish(self) -> None:
        """Make the joint state of the current SYNC (under the lock, all TPDOs in)."""
        for d in self._drives:
            d.received = 0
        counts = np.array([d.position for d in self._drives], dtype=np.int64)
        if self._hold is None:
            self._hold = counts.copy()
            self._hold_velocity = np.zeros(len(counts), dtype=np.int64)
        if self._comm_faults:
            return
        if self._published_sync == self._sync_index:
            # a second complete set for one SYNC: TPDOs of the previous SYNC came after this one was sent (a loaded
            # machine) and completed the first.  One state per SYNC: two states with one stamp and different
            # positions are a fault of the robot to the safety layer; the next SYNC brings this data anyway
            return
        self._published_sync = self._sync_index
        jm = self.joint_map
        velocities = jm.to_radians_per_second(np.array([d.velocity for d in self._drives], dtype=np.int64))
        self._sequence += 1
        self._state = JointState(jm.names, jm.to_radians(counts), velocities, self._sync_time, time.monotonic(),
                                 self._sequence)

    # --- the cycle -----------------------------------------------------------------------------------------------

    def _cycle(self) -> None:
        """Send every drive's RPDO1 with the held target, then one SYNC (CiA 301: RPDO data applies on SYNC)."""
        with self._send_lock:
            self._send_held()

    def _send_held(self, still: bool = False) -> None:
        """The body of :meth:`_cycle` (the caller holds ``_send_lock``); ``still``: a zero velocity offset."""
        network = self._network
        if network is None:
            return
        with self._lock:
            hold = None if self._hold is None else \
                (self._hold.copy(), np.zeros_like(self._hold_velocity) if still else self._hold_velocity.copy())
            drives = list(self._drives)
        if hold is not None:
            for drive, target, velocity in zip(drives, *hold):
                data = (RPDO_POSITION_VELOCITY.pack(int(target), int(velocity)) if self.options.velocity_feedforward
                        else RPDO_POSITION.pack(int(target)))
                network.send_message(cia402.RPDO1_BASE + drive.id, data)
        with self._lock:
            self._sync_index += 1
            self._sync_time = self._last_sync = time.monotonic()
            for d in drives:
                d.received = 0
        network.send_message(cia402.SYNC_COB_ID, b"")

    def _keep_alive(self) -> bool:
        """One keep-alive cycle (the held targets, zero velocity offset) if the core's stream is late *and* holds.

        Under the same lock as :meth:`write`'s cycle, so the two never interleave; and never while the stream's
        last command moved: repeating a moving target would make the drives stand still for one cycle between two
        moving targets (a deceleration of velocity / period, tens of times the limit) -- unless the stream has been
        silent for ``stream_timeout`` (it is gone; holding is the stop).  Returns whether it sent.
        """
        with self._send_lock:
            with self._lock:
                silent = time.monotonic() - self._last_sync
                if not self._syncing or silent < 1.5 * self._period \
                        or (self._stream_moving and silent < self.options.stream_timeout):
                    return False
                self._stream_moving = False      # from now on the drives hold: keep-alive every period
            self._send_held(still=True)
            return True

    def _run(self) -> None:
        """Keep-alive SYNC, the master's heartbeat and the heartbeat consumer, until shutdown."""
        master = self.options.master_node_id
        tick = max(0.001, min(self._period, self._heartbeat_period) / 2)
        while not self._stop.wait(tick):
            now = time.monotonic()
            try:
                if master and now - self._last_master_heartbeat >= self._heartbeat_period:
                    self._last_master_heartbeat = now
                    self._network.send_message(cia402.HEARTBEAT_BASE + master, bytes([cia402.NMT_OPERATIONAL]))
                if self._syncing and now - self._last_sync >= 1.5 * self._period:
                    self._keep_alive()
            except Exception as exc:  # the bus is gone
                if not self._stop.is_set():
                    self._comm_fault(f"sending on {self._where} failed: {type(exc).__name__}: {exc}")
            self._watch(now)

    def _watch(self, now: float) -> None:
        """The heartbeat consumer: a drive silent for heartbeat_timeout is a fault (once operational)."""
        with self._lock:
            if not self._operational:
                return
            timeout = self.options.heartbeat_timeout
            for drive in self._drives:
                if drive.heartbeat is None or now - drive.heartbeat > timeout:
                    age = "none received" if drive.heartbeat is None else f"none for {now - drive.heartbeat:.3f} s"
                    # the age is not part of the fault's identity: one entry per lost heartbeat, its age kept current
                    self._comm_fault(f"{drive.label}: heartbeat lost ({age}, consumer timeout {timeout:g} s)",
                                     key=f"{drive.label}: heartbeat lost")

    # --- the transport -----------------------------------------------------------------------------------------

    def latest_state(self) -> JointState | None:
        """The joint state of the newest SYNC whose TPDOs all arrived (rad, rad/s; stamp: the SYNC's monotonic
        time); it stops changing on a communication fault (heartbeat lost, a frame of the wrong length)."""
        with self._lock:
            return self._state

    def write(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Send positions ``(d,)`` rad as target position 0x607A (counts) and velocities ``(d,)`` rad/s as velocity
        offset 0x60B1 (velocity units) in each drive's RPDO1, then one SYNC (one cycle, never interleaved with a
        keep-alive cycle)."""
        jm = self.joint_map
        counts = jm.to_counts(positions)
        units = jm.to_velocity_units(velocities)
        with self._send_lock:
            with self._lock:
                if self._network is None or self._closing:
                    raise ConnectionLost("the CANopen driver is not open", field="driver")
                previous = self._hold
                self._stream_moving = bool(np.any(units != 0) or previous is None or np.any(counts != previous))
                self._hold, self._hold_velocity = counts, units
            try:
                self._send_held()
            except Exception as exc:
                raise ConnectionLost(f"sending on {self._where} failed: {type(exc).__name__}: {exc}") from None

    def robot_status(self) -> RobotStatus:
        """Enabled: every drive's statusword shows Operation enabled.  Estop: a drive is in Quick stop active.
        Lost: communication faults (heartbeat lost, NMT state lost, frames of the wrong length).  Fault: drives in
        Fault or Fault reaction active, active EMCY codes.  Detail: every drive's CiA 402 state."""
        self._watch(time.monotonic())
        with self._lock:
            if self._network is None:
                return RobotStatus(enabled=False, detail="not connected")
            lost = list(self._comm_faults.values())
            faults: list[str] = []
            details = []
            for d in self._drives:
                state = d.state
                details.append(f"{d.label}: {state.value if state is not None else 'no statusword yet'}")
                if state in (DriveState.FAULT, DriveState.FAULT_REACTION):
                    faults.append(f"{d.label}: drive {state.value.lower()} (statusword 0x{d.statusword:04X})"
                                  + "".join(f", {text}" for text in d.emcy.values()))
                elif d.emcy:
                    faults.append(f"{d.label}: " + ", ".join(d.emcy.values()))
                if state == DriveState.OPERATION_ENABLED and d.mode not in (None, cia402.MODE_CSP):
                    faults.append(f"{d.label}: left cyclic synchronous position mode (0x6061 = {d.mode})")
            enabled = bool(self._drives) and all(d.state == DriveState.OPERATION_ENABLED for d in self._drives)
            estop = any(d.state == DriveState.QUICK_STOP for d in self._drives)
        return RobotStatus(enabled=enabled, estop=estop, fault="; ".join(faults), lost="; ".join(lost),
                           detail="; ".join(details))

    def enable(self) -> None:
        """Bring every drive to Operation enabled through the CiA 402 state machine (controlword 0x6040, statusword
        0x6041 by SDO): fault reset from Fault, then Shutdown, Switch on, Enable operation, each drive's target
        position first set to its actual position.  Raises :class:`~pliant.errors.RobotDisabled` naming the drive
        and the state it stayed in."""
        if self._network is None:
            raise ConnectionLost("the CANopen driver is not open; connect first", field="driver")
        for drive in self._drives:
            state = self._read_state(drive)
            if state == DriveState.OPERATION_ENABLED:
                continue
            if state in (DriveState.FAULT, DriveState.FAULT_REACTION):
                self._fault_reset(drive)
            actual = struct.unpack("<i", self._sdo(drive, "reading position actual 0x6064", drive.remote.sdo.upload,
                                                   cia402.POSITION_ACTUAL, 0)[:4])[0]
            with self._lock:
                if self._hold is not None:
                    self._hold[drive.index] = actual
                    self._hold_velocity[drive.index] = 0
            self._cycle()
            state = self._read_state(drive)
            if state == DriveState.QUICK_STOP:
                self._command(drive, cia402.CW_DISABLE_VOLTAGE, DriveState.SWITCH_ON_DISABLED)
            for controlword, wanted in ((cia402.CW_SHUTDOWN, DriveState.READY),
                                        (cia402.CW_SWITCH_ON, DriveState.SWITCHED_ON),
                                        (cia402.CW_ENABLE_OPERATION, DriveState.OPERATION_ENABLED)):
                self._command(drive, controlword, wanted)

    def _read_state(self, drive: _Drive) -> DriveState:
        raw = self._sdo(drive, "reading the statusword 0x6041", drive.remote.sdo.upload, cia402.STATUSWORD, 0)
        statusword = int.from_bytes(raw[:2], "little")
        with self._lock:
            drive.statusword = statusword
        return drive_state(statusword)

    def _command(self, drive: _Drive, controlword: int, wanted: DriveState) -> None:
        """Write ``controlword`` to 0x6040 and wait (enable_timeout) until the statusword shows ``wanted``."""
        name = cia402.controlword_command(controlword, drive.controlword).value
        self._sdo(drive, f"controlword 0x6040 = 0x{controlword:04X} ({name})", drive.remote.sdo.download,
                  cia402.CONTROLWORD, 0, struct.pack("<H", controlword))
        drive.controlword = controlword
        deadline = time.monotonic() + self.options.enable_timeout
        while (state := self._read_state(drive)) != wanted:
            if time.monotonic() > deadline:
                raise RobotDisabled(f"CANopen {drive.label}: {name} (controlword 0x{controlword:04X}) did not bring "
                                    f"the drive to {wanted.value} within {self.options.enable_timeout:g} s: it shows "
                                    f"{state.value} (statusword 0x{drive.statusword:04X})", joint=drive.name)
            time.sleep(POLL)

    def _fault_reset(self, drive: _Drive) -> None:
        """CiA 402 fault reset: controlword bit 7 rising edge; Fault -> Switch on disabled; clears its EMCYs."""
        if drive.controlword & cia402.CW_FAULT_RESET:
            self._sdo(drive, "controlword 0x6040 = 0x0000", drive.remote.sdo.download, cia402.CONTROLWORD, 0,
                      struct.pack("<H", 0))
            drive.controlword = 0
        self._command(drive, cia402.CW_FAULT_RESET, DriveState.SWITCH_ON_DISABLED)
        with self._lock:
            drive.emcy.clear()

    def _settle(self, timeout: float = 1.0) -> None:
        """Before disabling: let enabled drives come to rest on their held targets (keep-alive SYNC running), so
        that the power stage is not switched off under a moving joint; at most ``timeout`` s."""
        deadline = time.monotonic() + timeout
        factors = [j.velocity_factor for j in self.joint_map.joints]
        while time.monotonic() < deadline:
            with self._lock:
                if not self._syncing or self._comm_faults:
                    break
                moving = any(d.state == DriveState.OPERATION_ENABLED and d.velocity is not None
                             and abs(d.velocity) / factors[d.index] > 1e-3 for d in self._drives)
            if not moving:
                break
            time.sleep(self._period)
        with self._lock:
            self._syncing = False

    # --- shutdown ------------------------------------------------------------------------------------------------

    def shutdown(self) -> None:
        """Let moving drives settle on their held targets (at most 1 s), disable them (controlword Shutdown:
        power stage off), stop their heartbeat consumers (0x1016), NMT pre-operational, stop SYNC and the master
        heartbeat and close the bus.  Drives whose heartbeat is lost are left alone.  Safe to call twice."""
        with self._lock:
            network = self._network
            if network is None or self._closing:
                return
            self._closing = True
            self._operational = False
            self._stream_moving = False     # the stream has ended: the keep-alive holds its last target
            drives = list(self._drives)
        try:
            self._settle()
            now = time.monotonic()
            for drive in drives:
                alive = drive.heartbeat is not None and now - drive.heartbeat <= self.options.heartbeat_timeout
                if drive.remote is None or not alive:
                    continue
                drive.remote.sdo.RESPONSE_TIMEOUT = min(self.options.sdo_timeout, 0.1)
                try:
                    if drive.state not in (None, DriveState.FAULT, DriveState.FAULT_REACTION,
                                           DriveState.SWITCH_ON_DISABLED, DriveState.READY):
                        word = cia402.CW_DISABLE_VOLTAGE if drive.state == DriveState.QUICK_STOP else \
                            cia402.CW_SHUTDOWN
                        drive.remote.sdo.download(cia402.CONTROLWORD, 0, struct.pack("<H", word))
                    if drive.consumer:
                        drive.remote.sdo.download(cia402.CONSUMER_HEARTBEAT_TIME, 1, struct.pack("<I", 0))
                    drive.remote.nmt.send_command(cia402.NMT_PRE_OPERATIONAL)
                except Exception as exc:
                    log.warning("canopen: shutting %s down: %s: %s", drive.label, type(exc).__name__, exc)
        finally:
            self._stop.set()
            if self._thread is not None:
                self._thread.join(timeout=2.0)
                self._thread = None
            with self._lock:
                self._network = None
                self._closing = False
            try:
                network.disconnect()
            except Exception as exc:
                log.warning("canopen: closing the bus: %s: %s", type(exc).__name__, exc)
