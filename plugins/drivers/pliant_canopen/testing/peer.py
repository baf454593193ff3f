"""The robot peer: emulated CiA 402 servo drives on a python-can bus, one ``canopen.LocalNode`` per joint.

:class:`CanopenPeer` starts one :class:`PeerDrive` per joint of a joint map on its own bus (the ``virtual``
interface connects the buses of one process; ``socketcan`` / ``udp_multicast`` reach other processes).  Each drive:

* is a CANopen slave (CiA 301): an SDO server over the shipped EDS (or the joint's own), NMT (boot-up, then
  pre-operational; start, stop, reset), a heartbeat producer (0x1017), a heartbeat consumer (0x1016: the master
  silent for its timeout is a fault, EMCY 0x8130), PDOs as the master maps them (0x1400/0x1600 RPDOs,
  0x1800/0x1A00 TPDOs), synchronous RPDOs applied on the next SYNC, synchronous TPDOs sent on every SYNC, an
  RPDO of the wrong length refused with EMCY 0x8210;
* runs the CiA 402 state machine on its controlword 0x6040 and shows it in its statusword 0x6041 (every change is
  logged in :attr:`PeerDrive.transitions`); modes of operation 0x6060 / 0x6061 (8: cyclic synchronous position);
* moves a joint model on each SYNC while Operation enabled: a first-order servo (time constant ``tau``) toward the
  target position 0x607A, its speed capped at the joint's velocity limit (from the limits file); position actual
  0x6064 and velocity actual 0x606C report it.  Disabled or faulted, the joint holds (brakes) and the target
  follows the actual position.

Every target position received is recorded in :attr:`CanopenPeer.targets` (monotonic time, node id, counts,
velocity offset) so that tests can check that none broke a limit.  Faults to inject: :meth:`CanopenPeer.fault`
(drive fault mid-motion: Fault state and EMCY), :meth:`CanopenPeer.drop_heartbeat` (heartbeat loss),
:meth:`CanopenPeer.short_frame` (a TPDO shorter than mapped), :meth:`CanopenPeer.refuse_enable` (a drive that
stays in Ready to switch on, e.g. without main power).
"""

from __future__ import annotations

import sys
import threading
import time
from collections import deque
from pathlib import Path

import numpy as np

from pliant_canopen.jointmap import JointMap, load_joint_map
from pliant_canopen.testing.drive import PeerDrive

#: seconds between two checks of the heartbeat consumers
SUPERVISION_PERIOD = 0.005
#: targets kept in :attr:`CanopenPeer.targets`
MAX_TARGETS = 1_000_000


class CanopenPeer:
    """Emulated CiA 402 drives for every joint of ``joint_map`` (a path, a :class:`JointMap` or ``None`` for the
    bundled iiwa example) on a python-can bus; see the module docstring.

    interface / channel / bitrate: the python-can bus.  initial: the joints' positions at power-up ``(d,)`` rad
    (default 0, or the middle of the range when 0 is outside it).  tau: the servo's time constant (s).  nodes:
    only these node ids of the joint map are emulated (default all: leave one out to test a missing drive).
    """

    def __init__(self, joint_map: str | Path | JointMap | None = None, *, interface: str = "virtual",
                 channel: str = "pliant-canopen", bitrate: int = 1_000_000, initial=None, tau: float = 0.01,
                 nodes=None) -> None:
        from pliant.api import load_limits

        self.joint_map = joint_map if isinstance(joint_map, JointMap) else load_joint_map(joint_map)
        self.limits = load_limits(self.joint_map.limits).select(self.joint_map.names)
        self.interface, self.channel, self.bitrate = interface, channel, bitrate
        lim = self.limits
        if initial is None:
            initial = np.where((lim.lower < 0) & (lim.upper > 0), 0.0, (lim.lower + lim.upper) / 2)
        counts = self.joint_map.to_counts(np.asarray(initial, dtype=np.float64))
        speed = lim.velocity * np.array([j.counts_per_radian for j in self.joint_map.joints])
        wanted = set(self.joint_map.nodes if nodes is None else nodes)
        self.drives: dict[int, PeerDrive] = {}
        for i, joint in enumerate(self.joint_map.joints):
            if joint.node in wanted:
                self.drives[joint.node] = PeerDrive(self, joint, position=int(counts[i]), max_velocity=speed[i],
                                                    tau=tau)
        #: every target position received: (monotonic time, node id, counts, velocity offset units); the newest
        #: MAX_TARGETS (7 drives at 100 Hz: about 24 minutes)
        self.targets: deque[tuple[float, int, int, int]] = deque(maxlen=MAX_TARGETS)
        self._lock = threading.Lock()
        self._network = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def record(self, node: int, counts: int, velocity: int) -> None:
        """Log one received target (called by the drives)."""
        with self._lock:
            self.targets.append((time.monotonic(), node, int(counts), int(velocity)))

    def drive(self, joint: int | str) -> PeerDrive:
        """The drive of node id ``joint`` (an int) or of the URDF joint named ``joint``."""
        if isinstance(joint, str):
            joint = self.joint_map.nodes[self.joint_map.names.index(joint)]
        return self.drives[joint]

    # --- start and stop -----------------------------------------------------------------------------------------

    def start(self) -> CanopenPeer:
        """Open the bus, boot every drive (boot-up message, pre-operational, heartbeat) and start supervising."""
        import can
        import canopen

        bus = can.Bus(interface=self.interface, channel=self.channel, bitrate=self.bitrate)
        network = canopen.Network(bus)
        network.NOTIFIER_CYCLE = 0.05
        for drive in self.drives.values():
            drive.attach(network)
        network.connect()
        self._network = network
        for drive in self.drives.values():
            drive.boot()
        self._stop.clear()
        self._thread = threading.Thread(target=self._supervise, name="pliant-canopen-peer", daemon=True)
        self._thread.start()
        return self

    def _supervise(self) -> None:
        while not self._stop.wait(SUPERVISION_PERIOD):
            now = time.monotonic()
            for drive in list(self.drives.values()):
                drive.supervise(now)

    def stop(self) -> None:
        """Stop the heartbeats and the supervision and close the bus; safe to call twice."""
        network, self._network = self._network, None
        if network is None:
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        for drive in self.drives.values():
            drive.node.nmt.stop_heartbeat()
        network.disconnect()

    def __enter__(self) -> CanopenPeer:
        return self if self._network is not None else self.start()

    def __exit__(self, *exc_info) -> None:
        self.stop()

    # --- what tests read and inject ------------------------------------------------------------------------------

    def positions(self) -> np.ndarray:
        """The emulated joints' actual positions ``(d,)`` rad, in joint-map order (NaN for a joint not emulated)."""
        counts = [self.drives[n].position if n in self.drives else np.nan for n in self.joint_map.nodes]
        return self.joint_map.to_radians(np.array(counts))

    def targets_in_radians(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The recorded targets as ``(times (k,), joint indices (k,), positions (k,) rad)``."""
        with self._lock:
            records = list(self.targets)
        if not records:
            return np.zeros(0), np.zeros(0, dtype=int), np.zeros(0)
        index = {n: i for i, n in enumerate(self.joint_map.nodes)}
        times = np.array([r[0] for r in records])
        joints = np.array([index[r[1]] for r in records])
        jm = self.joint_map
        positions = (jm._offset[joints] + jm._sign[joints] * np.array([r[2] for r in records], dtype=np.float64)
                     / jm._cpr[joints])
        return times, joints, positions

    def fault(self, joint: int | str, code: int = 0x2310) -> None:
        """Drive fault on ``joint`` (node id or URDF name): Fault state, the joint stops, EMCY ``code``
        (default 0x2310 continuous over-current)."""
        self.drive(joint).fault(code)

    def drop_heartbeat(self, joint: int | str) -> None:
        """``joint``'s drive stops producing heartbeats (PDOs continue)."""
        self.drive(joint).drop_heartbeat()

    def short_frame(self, joint: int | str, tpdo: int = 1, size: int | None = None, count: int = 1) -> None:
        """``joint``'s drive sends its next ``count`` TPDO ``tpdo`` frames ``size`` bytes long (default 2 short)."""
        self.drive(joint).short_frame(tpdo, size, count)

    def refuse_enable(self, joint: int | str, reason: str = "no main power (STO active)") -> None:
        """``joint``'s drive stays in Ready to switch on: Switch on and Enable operation are ignored."""
        self.drive(joint).enable_refused = reason


def run_peer(joint_map=None, *, interface: str = "socketcan", channel: str = "vcan0", bitrate: int = 1_000_000,
             duration: float | None = None) -> int:
    """``pliant canopen-peer``: run emulated drives until Ctrl-C (or ``duration`` s); prints each state change."""
    peer = CanopenPeer(joint_map, interface=interface, channel=channel, bitrate=bitrate)
    print(f"emulating {len(peer.drives)} CiA 402 drives (nodes {', '.join(map(str, peer.drives))}) of "
          f"{peer.joint_map.source} on {interface} {channel}; Ctrl-C stops")
    seen = {n: 0 for n in peer.drives}
    end = None if duration is None else time.monotonic() + duration
    try:
        peer.start()
    except Exception as exc:   # no such interface or channel: one line, not a traceback
        print(f"error: cannot open CAN {interface} channel {channel!r}: {type(exc).__name__}: {exc}".replace(
            "\n", " "), file=sys.stderr)
        return 2
    with peer:
        try:
            while end is None or time.monotonic() < end:
                time.sleep(0.1)
                for n, drive in peer.drives.items():
                    for _, state, word in drive.transitions[seen[n]:]:
                        print(f"node {n} ({drive.joint.name}): {state.value} (statusword 0x{word:04X})")
                    seen[n] = len(drive.transitions)
        except KeyboardInterrupt:
            pass
    return 0


__all__ = ["CanopenPeer", "PeerDrive", "run_peer"]
