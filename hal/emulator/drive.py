"""One emulated CiA 402 drive: a CANopen slave on a bus, in cyclic synchronous position mode.

What it does, per CiA 301 / CiA 402 and ``docs/can.md``:

* **Object dictionary and SDO**: a :class:`canopen.LocalNode` built from the drive's EDS
  (:func:`object_dictionary`: parsed once per file and node id, a copy per drive) serves
  SDO (expedited and segmented); what reads and writes do is
  :mod:`hal.emulator.drive_objects` (a mixin of this class), the numbers are
  :mod:`hal.emulator.codes`.
* **NMT** (own slave; canopen's ``NmtSlave`` heartbeat runs on a wall-clock thread and could
  not be stepped): boot-up message, PRE-OPERATIONAL, OPERATIONAL, STOPPED, reset node (whole
  dictionary) and reset communication (0x1000-0x1FFF). SDO and EMCY are served in
  PRE-OPERATIONAL and OPERATIONAL, PDOs in OPERATIONAL only, heartbeat in every state.
* **Heartbeat**: producer 0x1017 [ms]; consumer 0x1016:1 = ``(node << 16) | ms`` monitors the
  master from its first heartbeat on. A loss sends EMCY 0x8130 (error register bit 4,
  statusword warning bit 7) and, while the motor is powered (Operation enabled, Quick stop
  active), reacts per 0x6007: 0 none, 1 fault, 2 disable voltage, 3 quick stop. The warning
  and error clear when the master's heartbeat comes back (a fault stays until reset). NMT
  stop is handled the same way (no EMCY: a stopped node sends none).
* **PDOs**: RPDOs are latched on SYNC (every transmission type); TPDOs with transmission
  type n = 1..240 go out on every n-th SYNC, types 0, 254 and 255 on every SYNC (no event
  timer, no inhibit time). A SYNC COB-ID (0x1005) per drive is honoured.
* **CSP**: in Operation enabled the drive follows 0x607A. On entering it without a fresh
  target the set-point is the actual position. Quick stop and fault reaction hold the
  position the drive had when they started.
* **Following error**: in Operation enabled, ``|target − actual|`` above 0x6065 [counts]
  (0xFFFFFFFF = off) for at least 0x6066 [ms] of simulated time is a fault: EMCY 0x8611,
  statusword bit 13.
* **Faults**: :meth:`EmulatedDrive.raise_fault` (transition 13) records 0x603F, 0x1001 and
  0x1003 and sends an EMCY; a fault reset (transition 15) clears them and sends the EMCY
  "error reset" (code 0).

Time: the drive never reads a clock. :meth:`EmulatedDrive.tick` gets the emulator's ``now``
[s] (heartbeats), :meth:`EmulatedDrive.sample` the simulated time (following error).
Not thread-safe: the emulator serialises every call.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import pickle
import struct
from collections import deque
from collections.abc import Callable
from pathlib import Path

import canopen
import numpy as np
from canopen import LocalNode

from hal.can.scaling import I32_MAX, I32_MIN, delta_i32, wrap_i32
from hal.emulator import pdo
from hal.emulator.bank import INT, BoolField, IntField, own_row
from hal.emulator.codes import (
    EMCY_COMMUNICATION,
    EMCY_DEVICE_SPECIFIC,
    EMCY_ERROR_RESET,
    EMCY_FOLLOWING_ERROR,
    EMCY_HEARTBEAT,
    ERR_COMMUNICATION,
    ERR_GENERIC,
    ERR_MANUFACTURER,
    ERR_PROFILE,
    FOLLOWING_ERROR_OFF,
    NMT_BOOTUP,
    NMT_OPERATIONAL,
    NMT_PRE_OP,
    NMT_PRE_OPERATIONAL,
    NMT_RESET_COMM,
    NMT_RESET_NODE,
    NMT_START,
    NMT_STOP,
    NMT_STOPPED,
    REACTION_TIMEOUT,
)
from hal.emulator.drive_objects import DriveObjects, SdoSink
from hal.emulator.drive_state import DriveStateMachine, PowerState

__all__ = [
    "EMCY_DEVICE_SPECIFIC",
    "EMCY_FOLLOWING_ERROR",
    "ERR_GENERIC",
    "ERR_MANUFACTURER",
    "ERR_PROFILE",
    "NMT_OPERATIONAL",
    "EmulatedDrive",
]

log = logging.getLogger(__name__)

_EMCY = struct.Struct("<HB5s")
_CSP = struct.Struct("<Hi")
_WAITING, _RX_FRESH, _RX_ORDER = INT["waiting"], INT["rx_fresh"], INT["rx_order"]
_RX_CONTROLWORD, _RX_TARGET = INT["rx_controlword"], INT["rx_target"]

_REACTIONS = (PowerState.FAULT_REACTION_ACTIVE, PowerState.QUICK_STOP_ACTIVE)
_REACTION_PATTERNS = tuple(state.pattern for state in _REACTIONS)
_STATE = INT["state"]

#: Sends one CAN frame: (11-bit identifier, data).
Sender = Callable[[int, bytes], None]


def object_dictionary(eds: Path, node_id: int) -> canopen.ObjectDictionary:
    """The object dictionary of the EDS/DCF file ``eds`` for node ``node_id``, an object of
    its own (the drive writes to it): unpickled (~1 ms) from a parse of the same contents for
    that node id, made once per process (~14 ms a parse; an emulator has a drive per joint
    and the tests build hundreds)."""
    text = eds.read_bytes()
    return pickle.loads(_parsed(str(eds), node_id, hashlib.sha256(text).digest()))


@functools.cache
def _parsed(path: str, node_id: int, digest: bytes) -> bytes:
    """canopen's parse of ``path`` (with contents ``digest``) for ``node_id``, pickled."""
    return pickle.dumps(canopen.import_od(path, node_id))


class EmulatedDrive(DriveObjects):
    """The slave ``node_id`` named ``name`` (a joint or wheel), object dictionary from ``eds``.

    ``rows``: the drive's int and float rows of the emulator's
    :class:`hal.emulator.bank.DriveBank` (default: rows of its own).
    """

    #: The node neither receives nor sends anything (fault injection).
    silent = BoolField("silent")
    #: TPDOs leave this many SYNCs late (fault injection).
    tpdo_delay = IntField("tpdo_delay")
    nmt_state = IntField("nmt_state")
    _syncs = IntField("syncs")
    _reaction_cycles = IntField("reaction_cycles")

    def __init__(
        self,
        name: str,
        node_id: int,
        eds: str | Path,
        send: Sender,
        rows: tuple[np.ndarray, np.ndarray] | None = None,
    ):
        if not 1 <= node_id <= 127:
            raise ValueError(f"drive {name}: node id {node_id} is outside 1..127")
        self._ints, self._floats = own_row() if rows is None else rows
        self.name = name
        self.node_id = node_id
        try:
            self.node = LocalNode(node_id, object_dictionary(Path(eds), node_id))
        except Exception as exc:  # canopen raises a variety of errors for a broken EDS
            raise ValueError(f"drive {name}: cannot load EDS {eds}: {exc}") from exc
        for index in (0x1016, 0x1017, 0x1005, 0x1014, 0x6040, 0x6041, 0x6064, 0x607A):
            if index not in self.node.object_dictionary:
                raise ValueError(f"drive {name}: EDS {eds} lacks object 0x{index:04X}")
        # canopen's NmtSlave starts a wall-clock heartbeat thread on writes to 0x1017: this
        # drive produces its heartbeat itself (see tick()).
        self.node.nmt.stop_heartbeat()
        callbacks = self.node._write_callbacks
        if self.node.nmt.on_write in callbacks:
            callbacks.remove(self.node.nmt.on_write)
        self.node.add_read_callback(self._on_read)
        self.node.add_write_callback(self._on_write)
        self._send = send
        self.sm = DriveStateMachine(self._ints)
        #: The COB-ID :meth:`routes` gives to the controlword + target RPDO (-1: none).
        self.csp_route = -1
        #: Called when a COB-ID the emulator routes on changes (RPDO, SYNC, heartbeat).
        self.on_routes_changed: Callable[[], None] = lambda: None
        # ---- fault injection (hal.emulator.faults) ----
        self.silent = False
        #: The node sends no heartbeat.
        self.heartbeat_muted = False
        self.tpdo_delay = 0
        # ---- process values [counts], [counts/s] ----
        self.actual = 0
        self.velocity = 0
        self.target = 0
        self._hold = 0
        self._controlword = 0
        self._rpdo_data: list[bytes | None] = []
        self._rpdo_waiting: list[int] = []
        self._rpdo_codecs: list[Callable[[bytes], bool] | None] = []
        self._tpdo_codecs: list[tuple[int, int, Callable[[], bytes]]] = []
        self._delayed: deque[tuple[int, int, bytes]] = deque()
        self._syncs = 0
        self._now = 0.0
        self.nmt_state = NMT_BOOTUP
        # Configuration cached from the object dictionary (set by the two resets below).
        self._history: deque[int] = deque(maxlen=1)
        self._error_code = 0
        self._error_register = 0
        self._sync_cob = 0x080
        self._emcy_cob = 0x080 + node_id
        self._producer_period = 0.0  # [s]
        self._next_heartbeat = 0.0
        self._consumer_node = 0
        self._consumer_period = 0.0  # [s]
        self._master_seen: float | None = None
        self._master_lost = False
        self._pending_pdo = False
        self._rpdo_layouts: list[pdo.PdoLayout | None] = []
        self._tpdo_layouts: list[pdo.PdoLayout | None] = []
        self._fe_window = FOLLOWING_ERROR_OFF  # [counts]
        self._fe_time = 0.0  # [s]
        self._abort_option = 1
        self._outside_since: float | None = None
        self._last_state = self.sm.state
        self._reaction_cycles = 0  # samples taken in a fault reaction / quick stop
        self._reaction_since: float | None = None
        self._reset_communication()
        self._reset_application()
        # SDO answers go through the drive's sender, so injected faults apply to them too.
        self.node.sdo.network = SdoSink(self._send)  # type: ignore[assignment]

    # ------------------------------------------------------------------------- routing

    def routes(self) -> dict[int, Callable[[bytes, float], None]]:
        """CAN identifier -> handler of every frame this drive listens to (SYNC aside)."""
        table: dict[int, Callable[[bytes, float], None]] = {
            0x000: self.on_nmt,
            0x600 + self.node_id: self.on_sdo,
        }
        csp = int(self._ints[INT["csp_rpdo"]])
        csp_handler = None
        for i, layout in enumerate(self._rpdo_layouts):
            if layout is not None and layout.enabled:
                table[layout.cob_id] = handler = self._rpdo_handler(i)
                if i == csp:
                    csp_handler = handler
        if self._consumer_node:
            table[0x700 + self._consumer_node] = self.on_heartbeat
        self.csp_route = next((i for i, h in table.items() if h is csp_handler), -1)
        return table

    @property
    def sync_cob_id(self) -> int:
        return self._sync_cob

    # ------------------------------------------------------------------------ receiving

    def on_nmt(self, data: bytes, now: float) -> None:
        if self.silent or len(data) < 2 or data[1] not in (0, self.node_id):
            return
        command = data[0]
        if command == NMT_START:
            self.nmt_state = NMT_OPERATIONAL
        elif command == NMT_STOP:
            if self.nmt_state != NMT_STOPPED:
                self.nmt_state = NMT_STOPPED
                self._abort_connection("NMT stop")
        elif command == NMT_PRE_OP:
            self.nmt_state = NMT_PRE_OPERATIONAL
        elif command == NMT_RESET_NODE:
            self._reset_communication()
            self._reset_application()
            self._boot_up()
        elif command == NMT_RESET_COMM:
            self._reset_communication()
            self._boot_up()

    def on_sdo(self, data: bytes, now: float) -> None:
        if self.silent or self.nmt_state not in (NMT_PRE_OPERATIONAL, NMT_OPERATIONAL):
            return
        if len(data) != 8:
            return  # CiA 301: an SDO request is always 8 bytes
        self.node.sdo.on_request(0x600 + self.node_id, bytearray(data), now)
        if self.refresh():
            self.on_routes_changed()

    def on_heartbeat(self, data: bytes, now: float) -> None:
        """A heartbeat of the monitored master."""
        if self.silent:
            return
        self._master_seen = now
        if self._master_lost:
            self._master_lost = False
            self.sm.warning = False
            if self.sm.state not in (PowerState.FAULT, PowerState.FAULT_REACTION_ACTIVE):
                self._clear_error()
            log.info("drive %s: master heartbeat back", self.name)

    def _rpdo_handler(self, i: int) -> Callable[[bytes, float], None]:
        ints = self._ints
        if i == ints[INT["csp_rpdo"]]:
            return self._csp_handler(i)

        def handler(data: bytes, now: float) -> None:
            if not self.silent and self.nmt_state == NMT_OPERATIONAL:
                self._rpdo_data[i] = data
                if i not in self._rpdo_waiting:
                    self._rpdo_waiting.append(i)
                    ints[_WAITING] = len(self._rpdo_waiting)

        return handler

    def _csp_handler(self, i: int) -> Callable[[bytes, float], None]:
        """The RPDO ``i`` mapped controlword + target: kept in the bank row (``rx_*``) for the
        SYNC, with its place among the other RPDOs received; a short one goes the way of the
        others (the SYNC ignores it with a warning)."""
        ints, size, unpack = self._ints, _CSP.size, _CSP.unpack_from

        def handler(data: bytes, now: float) -> None:
            if self.silent or self.nmt_state != NMT_OPERATIONAL:
                return
            waiting = self._rpdo_waiting
            if len(data) < size:
                if ints[_RX_FRESH]:
                    waiting.insert(int(ints[_RX_ORDER]), i)
                    ints[_RX_FRESH] = 0
                elif i not in waiting:
                    waiting.append(i)
                self._rpdo_data[i] = data
                ints[_WAITING] = len(waiting)
                return
            if i in waiting:  # a short one came first: this one takes its place
                ints[_RX_ORDER] = waiting.index(i)
                waiting.remove(i)
                self._rpdo_data[i] = None
                ints[_WAITING] = len(waiting)
            elif not ints[_RX_FRESH]:
                ints[_RX_ORDER] = len(waiting)
            ints[_RX_CONTROLWORD], ints[_RX_TARGET] = unpack(data)
            ints[_RX_FRESH] = 1

        return handler

    # ---------------------------------------------------------------------------- cycle

    def latch(self) -> None:
        """SYNC: end reactions a TPDO has shown, then apply the RPDOs received since."""
        if self._reaction_cycles:
            self.sm.complete_reactions()
            self._reaction_cycles = 0
        fresh_target = False
        ints = self._ints
        if (self._rpdo_waiting or ints[_RX_FRESH]) and self.nmt_state == NMT_OPERATIONAL:
            codecs, received, order = self._rpdo_codecs, self._rpdo_data, self._rpdo_waiting
            if ints[_RX_FRESH]:
                order.insert(int(ints[_RX_ORDER]), -1)  # -1: the CSP RPDO, in the bank
                ints[_RX_FRESH] = 0
            for i in order:
                if i < 0:
                    self.target = int(ints[_RX_TARGET])
                    self._apply_controlword(int(ints[_RX_CONTROLWORD]))
                    fresh_target = True
                    continue
                data, codec = received[i], codecs[i]
                received[i] = None
                if data is not None and codec is not None and codec(data):
                    fresh_target = True
            order.clear()
            ints[_WAITING] = 0
        self._after_state_change(fresh_target)

    def setpoint(self) -> tuple[int, bool]:
        """What the power stage does this cycle: (position set-point [counts], torque on)."""
        state = self.sm.state
        if state is PowerState.OPERATION_ENABLED:
            return self.target, True
        if state is PowerState.QUICK_STOP_ACTIVE or state is PowerState.FAULT_REACTION_ACTIVE:
            return self._hold, True
        return self.actual, False

    def place(self, position: int) -> None:
        """Power-on position [counts]: actual, target and hold all there."""
        self.actual = self.target = self._hold = wrap_i32(position)

    def move(self, position: int, velocity: int) -> None:
        """After a physics step: actual position [counts] and velocity [counts/s]."""
        self.actual = wrap_i32(position)
        self.velocity = min(max(int(velocity), I32_MIN), I32_MAX)

    def sample(self, sim_time: float) -> None:
        """SYNC, after :meth:`latch`: supervision at ``sim_time`` [s], then the TPDOs due
        (OPERATIONAL) with the values of this instant."""
        self._syncs += 1
        if self.silent:
            return
        self._supervise(sim_time)
        reacting = self.sm.state in _REACTIONS
        self._reaction_cycles = self._reaction_cycles + 1 if reacting else 0
        if self.nmt_state != NMT_OPERATIONAL:
            return
        for cob_id, n, encode in self._tpdo_codecs:
            if 1 <= n <= 240 and self._syncs % n:
                continue
            if self.tpdo_delay > 0:
                self._delayed.append((self._syncs + self.tpdo_delay, cob_id, encode()))
            else:
                self._send(cob_id, encode())
        while self._delayed and (self._delayed[0][0] <= self._syncs or not self.tpdo_delay):
            _, cob_id, data = self._delayed.popleft()
            self._send(cob_id, data)
        self._ints[INT["delayed"]] = len(self._delayed)

    def tick(self, now: float) -> None:
        """Time passes: heartbeat production, the master-heartbeat watchdog, and reactions
        that no SYNC ends (they end after :data:`REACTION_TIMEOUT`)."""
        self._now = now
        if self._ints[_STATE] in _REACTION_PATTERNS:  # (sm.state in _REACTIONS, cheaper)
            if self._reaction_since is None:
                self._reaction_since = now
            elif now - self._reaction_since > REACTION_TIMEOUT:
                self.sm.complete_reactions()
                self._after_state_change(False)
                self._reaction_since = None
        else:
            self._reaction_since = None
        if self._producer_period > 0 and now >= self._next_heartbeat:
            self._next_heartbeat = max(self._next_heartbeat + self._producer_period, now)
            if not (self.silent or self.heartbeat_muted):
                self._send(0x700 + self.node_id, bytes((self.nmt_state,)))
        if (
            self._consumer_period > 0
            and self._master_seen is not None
            and not self._master_lost
            and now - self._master_seen > self._consumer_period
        ):
            self._master_lost = True
            log.warning(
                "drive %s: no heartbeat from node %d for %.0f ms",
                self.name, self._consumer_node, 1e3 * (now - self._master_seen),
            )  # fmt: skip
            self._abort_connection("heartbeat loss", EMCY_HEARTBEAT, ERR_COMMUNICATION)

    # -------------------------------------------------------------------- fault interface

    def raise_fault(self, code: int, register: int = ERR_GENERIC, info: bytes = b"") -> None:
        """A fault: transition 13, 0x603F/0x1001/0x1003 set, EMCY ``code`` sent."""
        if not self.sm.fault():
            return
        self._hold = self.actual
        self._record_error(code, register)
        self.send_emcy(code, info)
        log.warning("drive %s: fault 0x%04X", self.name, code)

    def send_emcy(self, code: int, info: bytes = b"") -> None:
        """Send an EMCY frame (when the node may: not silent, not STOPPED, COB-ID valid)."""
        if self.silent or self.nmt_state == NMT_STOPPED or self._emcy_cob & pdo.PDO_NOT_VALID:
            return
        self._send(self._emcy_cob & 0x7FF, _EMCY.pack(code, self._error_register, info[:5]))

    # ------------------------------------------------------------------------ internals

    def _apply_controlword(self, value: int) -> None:
        self._controlword = value & 0xFFFF
        was_fault = self.sm.state is PowerState.FAULT
        self.sm.controlword(value)
        if was_fault and self.sm.state is not PowerState.FAULT:
            self._clear_error()
            self.send_emcy(EMCY_ERROR_RESET)

    def _after_state_change(self, fresh_target: bool) -> None:
        """Track the state the last commands led to: hold and CSP set-points."""
        state = self.sm.state
        if state is not self._last_state:
            if state is PowerState.OPERATION_ENABLED and not fresh_target:
                self.target = self.actual
            if state in (PowerState.QUICK_STOP_ACTIVE, PowerState.FAULT_REACTION_ACTIVE):
                self._hold = self.actual
            self._last_state = state

    def _supervise(self, sim_time: float) -> None:
        if self.sm.state is not PowerState.OPERATION_ENABLED:
            self._outside_since = None
            return
        error = abs(delta_i32(self.target, self.actual))
        if self._fe_window == FOLLOWING_ERROR_OFF or error <= self._fe_window:
            self._outside_since = None
            return
        if self._outside_since is None:
            self._outside_since = sim_time
        if sim_time - self._outside_since >= self._fe_time - 1e-9:
            self.sm.following_error = True
            self.raise_fault(EMCY_FOLLOWING_ERROR, ERR_GENERIC | ERR_PROFILE)
            self._last_state = self.sm.state

    def _abort_connection(self, why: str, code: int = 0, register: int = 0) -> None:
        """React per 0x6007 to a lost connection (heartbeat loss, NMT stop)."""
        option = self._abort_option
        if option == 1 and self.sm.torque:
            self.raise_fault(code or EMCY_COMMUNICATION, ERR_GENERIC | ERR_COMMUNICATION)
        else:
            if code:
                self.sm.warning = True
                self._record_error(code, ERR_GENERIC | register)
                self.send_emcy(code)
            if option == 2 and self.sm.torque:
                self.sm.disable_voltage()
            elif option == 3 and self.sm.torque:
                self.sm.quick_stop()
        self._after_state_change(False)
        log.info("drive %s: %s, abort connection option %d", self.name, why, option)

    def _boot_up(self) -> None:
        self.nmt_state = NMT_PRE_OPERATIONAL
        if not self.silent:
            self._send(0x700 + self.node_id, bytes((NMT_BOOTUP,)))
        self._next_heartbeat = self._now + self._producer_period
        self.on_routes_changed()

    def boot(self) -> None:
        """Power on: boot-up message, then PRE-OPERATIONAL."""
        self._boot_up()
