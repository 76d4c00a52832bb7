"""One emulated CiA 402 drive: a CANopen slave on a bus, in cyclic synchronous position mode.

What it does, per CiA 301 / CiA 402 and ``docs/can.md``:

* **Object dictionary and SDO**: a :class:`canopen.LocalNode` built from the drive's EDS
  serves SDO (expedited and segmented). Live objects (statusword 0x6041, position 0x6064,
  velocity 0x606C, error code 0x603F, error register 0x1001, error history 0x1003, ...) are
  read from the drive, not from the store. Writes are checked: modes of operation other
  than 8 (CSP), a non-zero write to 0x1003:0, an unmappable PDO entry or a PDO over 64 bits
  are refused with the standard abort codes.
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

import logging
import struct
from collections import deque
from collections.abc import Callable
from pathlib import Path

from canopen import LocalNode, objectdictionary
from canopen.sdo import SdoAbortedError

from hal.can.scaling import I32_MAX, I32_MIN, delta_i32, wrap_i32
from hal.emulator import pdo
from hal.emulator.drive_state import DriveStateMachine, PowerState

log = logging.getLogger(__name__)

# NMT states (heartbeat byte) and commands.
NMT_BOOTUP = 0x00
NMT_STOPPED = 0x04
NMT_OPERATIONAL = 0x05
NMT_PRE_OPERATIONAL = 0x7F
_NMT_START, _NMT_STOP, _NMT_PRE_OP, _NMT_RESET_NODE, _NMT_RESET_COMM = 0x01, 0x02, 0x80, 0x81, 0x82

# EMCY codes (CiA 301 / CiA 402) and error register bits.
EMCY_ERROR_RESET = 0x0000
EMCY_HEARTBEAT = 0x8130
EMCY_COMMUNICATION = 0x8100
EMCY_FOLLOWING_ERROR = 0x8611
EMCY_DEVICE_SPECIFIC = 0xFF00
ERR_GENERIC = 0x01
ERR_COMMUNICATION = 0x10
ERR_PROFILE = 0x20
ERR_MANUFACTURER = 0x80

CSP_MODE = 8
#: A fault reaction or quick stop no SYNC ends finishes after this long [s].
REACTION_TIMEOUT = 0.05
FOLLOWING_ERROR_OFF = 0xFFFF_FFFF
ABORT_VALUE_RANGE = 0x0609_0030
ABORT_WRITE_READ_ONLY = 0x0601_0002
_EMCY = struct.Struct("<HB5s")
_TPDOS = ((0x1800, 0x1A00), (0x1801, 0x1A01), (0x1802, 0x1A02), (0x1803, 0x1A03))
_RPDOS = ((0x1400, 0x1600), (0x1401, 0x1601), (0x1402, 0x1602), (0x1403, 0x1603))

_REACTIONS = (PowerState.FAULT_REACTION_ACTIVE, PowerState.QUICK_STOP_ACTIVE)

#: Sends one CAN frame: (11-bit identifier, data).
Sender = Callable[[int, bytes], None]


class EmulatedDrive:
    """The slave ``node_id`` named ``name`` (a joint or wheel), object dictionary from ``eds``."""

    def __init__(self, name: str, node_id: int, eds: str | Path, send: Sender):
        if not 1 <= node_id <= 127:
            raise ValueError(f"drive {name}: node id {node_id} is outside 1..127")
        self.name = name
        self.node_id = node_id
        try:
            self.node = LocalNode(node_id, str(eds))
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
        self.sm = DriveStateMachine()
        #: Called when a COB-ID the emulator routes on changes (RPDO, SYNC, heartbeat).
        self.on_routes_changed: Callable[[], None] = lambda: None
        # ---- fault injection (hal.emulator.faults) ----
        #: The node neither receives nor sends anything.
        self.silent = False
        #: The node sends no heartbeat.
        self.heartbeat_muted = False
        #: TPDOs leave this many SYNCs late.
        self.tpdo_delay = 0
        # ---- process values [counts], [counts/s] ----
        self.actual = 0
        self.velocity = 0
        self.target = 0
        self._hold = 0
        self._controlword = 0
        self._rpdo_fresh = False
        self._rpdo_data: list[bytes | None] = []
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
        self.node.sdo.network = _SdoSink(self)  # type: ignore[assignment]

    # ------------------------------------------------------------------------- routing

    def routes(self) -> dict[int, Callable[[bytes, float], None]]:
        """CAN identifier -> handler of every frame this drive listens to (SYNC aside)."""
        table: dict[int, Callable[[bytes, float], None]] = {
            0x000: self.on_nmt,
            0x600 + self.node_id: self.on_sdo,
        }
        for i, layout in enumerate(self._rpdo_layouts):
            if layout is not None and layout.enabled:
                table[layout.cob_id] = self._rpdo_handler(i)
        if self._consumer_node:
            table[0x700 + self._consumer_node] = self.on_heartbeat
        return table

    @property
    def sync_cob_id(self) -> int:
        return self._sync_cob

    # ------------------------------------------------------------------------ receiving

    def on_nmt(self, data: bytes, now: float) -> None:
        if self.silent or len(data) < 2 or data[1] not in (0, self.node_id):
            return
        command = data[0]
        if command == _NMT_START:
            self.nmt_state = NMT_OPERATIONAL
        elif command == _NMT_STOP:
            if self.nmt_state != NMT_STOPPED:
                self.nmt_state = NMT_STOPPED
                self._abort_connection("NMT stop")
        elif command == _NMT_PRE_OP:
            self.nmt_state = NMT_PRE_OPERATIONAL
        elif command == _NMT_RESET_NODE:
            self._reset_communication()
            self._reset_application()
            self._boot_up()
        elif command == _NMT_RESET_COMM:
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
        def handler(data: bytes, now: float) -> None:
            if not self.silent and self.nmt_state == NMT_OPERATIONAL:
                self._rpdo_data[i] = bytes(data)

        return handler

    # ---------------------------------------------------------------------------- cycle

    def latch(self) -> None:
        """SYNC: end reactions a TPDO has shown, then apply the RPDOs received since."""
        if self._reaction_cycles:
            self.sm.complete_reactions()
            self._reaction_cycles = 0
        fresh_target = False
        if self.nmt_state == NMT_OPERATIONAL:
            for i, data in enumerate(self._rpdo_data):
                layout = self._rpdo_layouts[i]
                if data is None or layout is None or not layout.enabled:
                    continue
                self._rpdo_data[i] = None
                if len(data) < layout.packer.size:
                    log.warning(
                        "drive %s: RPDO 0x%03X has %d bytes, its mapping needs %d: ignored",
                        self.name, layout.cob_id, len(data), layout.packer.size,
                    )  # fmt: skip
                    continue
                values = layout.packer.unpack_from(data)
                for (index, subindex), value in zip(layout.entries, values, strict=True):
                    if index == 0x607A:
                        self.target = int(value)
                        fresh_target = True
                    elif index == 0x6040:
                        self._apply_controlword(int(value))
                    else:
                        var = _variable(self.node, index, subindex)
                        self.node.data_store.setdefault(index, {})[subindex] = var.encode_raw(value)
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

    def sample(self, position: int, velocity: int, sim_time: float) -> None:
        """After the physics step: new actual values, supervision, TPDOs (OPERATIONAL)."""
        self.actual = wrap_i32(position)
        self.velocity = min(max(int(velocity), I32_MIN), I32_MAX)
        self._syncs += 1
        if self.silent:
            return
        self._supervise(sim_time)
        reacting = self.sm.state in _REACTIONS
        self._reaction_cycles = self._reaction_cycles + 1 if reacting else 0
        if self.nmt_state != NMT_OPERATIONAL:
            return
        for layout in self._tpdo_layouts:
            if layout is None or not layout.enabled:
                continue
            n = layout.trans_type
            if 1 <= n <= 240 and self._syncs % n:
                continue
            data = layout.packer.pack(*[self._value(i, s) for i, s in layout.entries])
            if self.tpdo_delay > 0:
                self._delayed.append((self._syncs + self.tpdo_delay, layout.cob_id, data))
            else:
                self._send(layout.cob_id, data)
        while self._delayed and (self._delayed[0][0] <= self._syncs or not self.tpdo_delay):
            _, cob_id, data = self._delayed.popleft()
            self._send(cob_id, data)

    def tick(self, now: float) -> None:
        """Time passes: heartbeat production, the master-heartbeat watchdog, and reactions
        that no SYNC ends (they end after :data:`REACTION_TIMEOUT`)."""
        self._now = now
        if self.sm.state in _REACTIONS:
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

    def _record_error(self, code: int, register: int) -> None:
        self._error_code = code & 0xFFFF
        self._error_register |= register & 0xFF
        self._history.appendleft(code & 0xFFFF)

    def _clear_error(self) -> None:
        self._error_code = 0
        self._error_register = 0

    def _value(self, index: int, subindex: int) -> int:
        """Current value of a mapped object."""
        if index == 0x6041:
            return self.sm.statusword
        if index == 0x6064:
            return self.actual
        if index == 0x606C:
            return self.velocity
        result = self._on_read(index, subindex)
        if result is not None:
            return int(result)
        var = _variable(self.node, index, subindex)
        return int(var.decode_raw(self.node.get_data(index, subindex)))

    def _on_read(self, index: int, subindex: int, **_: object) -> int | None:
        if index == 0x6041:
            return self.sm.statusword
        if index == 0x6064:
            return self.actual
        if index == 0x606C:
            return self.velocity
        if index == 0x607A:
            return self.target
        if index == 0x6040:
            return self._controlword
        if index == 0x6061:
            return CSP_MODE
        if index == 0x603F:
            return self._error_code
        if index == 0x1001:
            return self._error_register
        if index == 0x1003:
            if subindex == 0:
                return len(self._history)
            return self._history[subindex - 1] if subindex <= len(self._history) else 0
        return None

    def _on_write(self, index: int, subindex: int, od: object, data: bytes) -> None:
        """Check and apply an SDO write (runs before canopen stores ``data``)."""
        assert isinstance(od, objectdictionary.ODVariable)
        value = od.decode_raw(data)
        if index == 0x6040:
            self._apply_controlword(int(value))
            self._after_state_change(False)
        elif index == 0x607A:
            self.target = int(value)
        elif index == 0x6060:
            if value != CSP_MODE:
                raise SdoAbortedError(ABORT_VALUE_RANGE)
        elif index == 0x1003:
            if subindex != 0 or value != 0:
                raise SdoAbortedError(ABORT_VALUE_RANGE)
            self._history.clear()
        elif index == 0x1017:
            self._producer_period = int(value) / 1000.0
            self._next_heartbeat = self._now
        elif index == 0x1016 and subindex == 1:
            self._set_consumer(int(value))
        elif index == 0x1005:
            self._sync_cob = int(value) & 0x7FF
            self.on_routes_changed()
        elif index == 0x1014:
            self._emcy_cob = int(value)
        elif index == 0x605A:
            self.sm.quick_stop_option = int(value)
        elif index == 0x6065:
            self._fe_window = int(value)
        elif index == 0x6066:
            self._fe_time = int(value) / 1000.0
        elif index == 0x6007:
            self._abort_option = int(value)
        elif 0x1600 <= index <= 0x17FF or 0x1A00 <= index <= 0x1BFF:
            if subindex == 0:
                pdo.check_mapping_count(self.node, index, int(value))
            else:
                pdo.check_mapping_entry(self.node, int(value))
            self._pending_pdo = True  # compiled by refresh(), once canopen stored the value
        elif 0x1400 <= index <= 0x15FF or 0x1800 <= index <= 0x19FF:
            self._pending_pdo = True

    def _reset_communication(self) -> None:
        """Communication objects (0x1000-0x1FFF) back to the EDS values."""
        for index in [i for i in self.node.data_store if i < 0x2000]:
            del self.node.data_store[index]
        self._history = deque(maxlen=_history_length(self.node))
        self._error_code = 0
        self._error_register = 0
        self._sync_cob = self._od_int(0x1005, 0) & 0x7FF
        self._emcy_cob = self._od_int(0x1014, 0)
        self._producer_period = self._od_int(0x1017, 0) / 1000.0
        self._next_heartbeat = self._now
        self._set_consumer(self._od_int(0x1016, 1))
        self._compile_pdos()

    def _reset_application(self) -> None:
        """Device-profile objects back to the EDS values; the state machine boots."""
        for index in [i for i in self.node.data_store if i >= 0x2000]:
            del self.node.data_store[index]
        self.sm = _rebooted(self.sm)
        self.sm.quick_stop_option = self._od_int(0x605A, 0, default=2)
        self._fe_window = self._od_int(0x6065, 0, default=FOLLOWING_ERROR_OFF)
        self._fe_time = self._od_int(0x6066, 0, default=0) / 1000.0
        self._abort_option = self._od_int(0x6007, 0, default=1)
        self._outside_since = None
        self._controlword = 0
        self.target = self.actual
        self._hold = self.actual
        self._last_state = self.sm.state

    def _boot_up(self) -> None:
        self.nmt_state = NMT_PRE_OPERATIONAL
        if not self.silent:
            self._send(0x700 + self.node_id, bytes((NMT_BOOTUP,)))
        self._next_heartbeat = self._now + self._producer_period
        self.on_routes_changed()

    def boot(self) -> None:
        """Power on: boot-up message, then PRE-OPERATIONAL."""
        self._boot_up()

    def _set_consumer(self, value: int) -> None:
        node, ms = (value >> 16) & 0x7F, value & 0xFFFF
        self._consumer_node = node if ms else 0
        self._consumer_period = ms / 1000.0 if node else 0.0
        self._master_seen = None
        self._master_lost = False
        self.on_routes_changed()

    def _compile_pdos(self) -> None:
        od = self.node.object_dictionary
        self._rpdo_layouts = [
            pdo.read_layout(self.node, c, m) if c in od and m in od else None for c, m in _RPDOS
        ]
        self._tpdo_layouts = [
            pdo.read_layout(self.node, c, m) if c in od and m in od else None for c, m in _TPDOS
        ]
        self._rpdo_data = [None] * len(self._rpdo_layouts)
        self._pending_pdo = False

    def refresh(self) -> bool:
        """Recompile PDO layouts after SDO writes to them; True when they changed."""
        if not self._pending_pdo:
            return False
        try:
            self._compile_pdos()
        except SdoAbortedError as exc:
            log.warning("drive %s: inconsistent PDO mapping (%s): PDOs kept", self.name, exc)
            self._pending_pdo = False
            return False
        return True

    def _od_int(self, index: int, subindex: int, default: int = 0) -> int:
        if index not in self.node.object_dictionary:
            return default
        try:
            var = _variable(self.node, index, subindex)
            return int(var.decode_raw(self.node.get_data(index, subindex)))
        except (KeyError, SdoAbortedError):
            return default


class _SdoSink:
    """What the SDO server sends through: the drive's own sender (so faults apply)."""

    def __init__(self, drive: EmulatedDrive):
        self._drive = drive

    def send_message(self, can_id: int, data: bytes, remote: bool = False) -> None:
        self._drive._send(can_id, bytes(data))


def _variable(node: LocalNode, index: int, subindex: int) -> objectdictionary.ODVariable:
    obj = node.object_dictionary[index]
    if isinstance(obj, objectdictionary.ODVariable):
        return obj
    return obj[subindex]


def _history_length(node: LocalNode) -> int:
    obj = node.object_dictionary.get(0x1003)
    if obj is None or isinstance(obj, objectdictionary.ODVariable):
        return 1
    return max(1, len([s for s in obj.subindices if s > 0]))


def _rebooted(sm: DriveStateMachine) -> DriveStateMachine:
    refuse = sm.refuse_enable
    sm = DriveStateMachine()
    sm.refuse_enable = refuse
    sm.boot()
    return sm
