"""The object dictionary side of an emulated drive: SDO reads and writes, resets, PDO codecs.

:class:`DriveObjects` is the part of :class:`hal.emulator.drive.EmulatedDrive` that the SDO
server (a :class:`canopen.LocalNode` built from the drive's EDS) talks to:

* live objects (statusword 0x6041, position 0x6064, velocity 0x606C, error code 0x603F,
  error register 0x1001, error history 0x1003, ...) are read from the drive, not from the
  store (:meth:`DriveObjects._on_read`);
* writes are checked and applied (:meth:`DriveObjects._on_write`): modes of operation other
  than 8 (CSP), a non-zero write to 0x1003:0, an unmappable PDO entry or a PDO over 64 bits
  are refused with the standard abort codes; heartbeat, SYNC/EMCY COB-IDs, quick stop option,
  following-error window and time, abort connection option take effect at once;
* reset communication (0x1000-0x1FFF) and reset application (0x2000-) bring back the EDS
  values;
* PDO layouts are compiled after mapping changes, each into a codec (RPDO data -> objects,
  objects -> TPDO data) so the per-SYNC work is one ``struct`` call per PDO.

A mixin: it works on the drive's own attributes (declared below) and is not used alone.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable

import numpy as np
from canopen import LocalNode, objectdictionary
from canopen.sdo import SdoAbortedError

from hal.emulator import pdo
from hal.emulator.bank import (
    INT,
    TPDO_STATUS_POSITION,
    TPDO_VELOCITY,
    FloatField,
    IntField,
    OptionalFloatField,
)
from hal.emulator.codes import ABORT_VALUE_RANGE, CSP_MODE, FOLLOWING_ERROR_OFF
from hal.emulator.drive_state import DriveStateMachine, StateField

log = logging.getLogger(__name__)

_TPDOS = ((0x1800, 0x1A00), (0x1801, 0x1A01), (0x1802, 0x1A02), (0x1803, 0x1A03))
_RPDOS = ((0x1400, 0x1600), (0x1401, 0x1601), (0x1402, 0x1602), (0x1403, 0x1603))
#: The mapping of the master's RPDO1 (controlword + target), kept in the bank when received.
_CSP_RPDO = ((0x6040, 0), (0x607A, 0))


class DriveObjects:
    """Object dictionary behaviour of an emulated drive (module doc)."""

    name: str
    node: LocalNode
    sm: DriveStateMachine
    # The values a SYNC round touches, in the drive's bank rows (hal.emulator.bank).
    _ints: np.ndarray
    _floats: np.ndarray
    actual = IntField("actual")
    velocity = IntField("velocity")
    target = IntField("target")
    _hold = IntField("hold")
    _controlword = IntField("controlword")
    _fe_window = IntField("fe_window")
    _fe_time = FloatField("fe_time")
    _outside_since = OptionalFloatField("outside_since")
    _now: float
    _history: deque[int]
    _error_code: int
    _error_register: int
    _sync_cob: int
    _emcy_cob: int
    _producer_period: float
    _next_heartbeat: float
    _consumer_node: int
    _consumer_period: float
    _master_seen: float | None
    _master_lost: bool
    _pending_pdo: bool
    _rpdo_layouts: list[pdo.PdoLayout | None]
    _tpdo_layouts: list[pdo.PdoLayout | None]
    #: Per RPDO: its codec (None: disabled or absent).
    _rpdo_codecs: list[Callable[[bytes], bool] | None]
    #: Per enabled TPDO: (COB-ID, transmission type, codec).
    _tpdo_codecs: list[tuple[int, int, Callable[[], bytes]]]
    _rpdo_data: list[bytes | None]
    #: RPDOs received since the last SYNC (indices into :attr:`_rpdo_data`).
    _rpdo_waiting: list[int]
    _abort_option: int
    _last_state = StateField("last_state")
    on_routes_changed: Callable[[], None]

    def _apply_controlword(self, value: int) -> None:
        raise NotImplementedError

    def _after_state_change(self, fresh_target: bool) -> None:
        raise NotImplementedError

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

    def _set_consumer(self, value: int) -> None:
        node, ms = (value >> 16) & 0x7F, value & 0xFFFF
        self._consumer_node = node if ms else 0
        self._consumer_period = ms / 1000.0 if node else 0.0
        self._master_seen = None
        self._master_lost = False
        self.on_routes_changed()

    def _compile_pdos(self) -> None:
        """PDO layouts from the dictionary, and per enabled PDO a precompiled codec: RPDO
        data -> objects, objects -> TPDO data (one ``struct`` call for the usual mappings)."""
        od = self.node.object_dictionary
        self._rpdo_layouts = [
            pdo.read_layout(self.node, c, m) if c in od and m in od else None for c, m in _RPDOS
        ]
        self._tpdo_layouts = [
            pdo.read_layout(self.node, c, m) if c in od and m in od else None for c, m in _TPDOS
        ]
        self._rpdo_codecs = [
            self._rpdo_codec(layout) if layout is not None and layout.enabled else None
            for layout in self._rpdo_layouts
        ]
        self._tpdo_codecs = [
            (layout.cob_id, layout.trans_type, self._tpdo_codec(layout))
            for layout in self._tpdo_layouts
            if layout is not None and layout.enabled
        ]
        self._rpdo_data = [None] * len(self._rpdo_layouts)
        self._rpdo_waiting = []
        self._pending_pdo = False
        self._bank_pdos()

    def _bank_pdos(self) -> None:
        """The PDO configuration in the bank row, for the compiled round (hal.emulator.bank):
        which RPDO carries controlword + target, the TPDOs' kinds, COB-IDs and types, and
        whether every TPDO is a kind the compiled round encodes."""
        ints = self._ints
        ints[INT["csp_rpdo"]] = next(
            (
                i
                for i, layout in enumerate(self._rpdo_layouts)
                if layout is not None and layout.enabled and layout.entries == _CSP_RPDO
            ),
            -1,
        )
        ints[INT["waiting"]] = 0
        ints[INT["rx_fresh"]] = 0
        enabled = [t for t in self._tpdo_layouts if t is not None and t.enabled]
        kinds = [_tpdo_kind(layout) for layout in enabled]
        ints[INT["fast"]] = all(kinds) and len(enabled) <= 4
        ints[INT["tpdos"]] = len(enabled)
        for k, (kind, layout) in enumerate(zip(kinds[:4], enabled[:4], strict=True)):
            ints[INT[f"tpdo_kind{k}"]] = kind
            ints[INT[f"tpdo_cob{k}"]] = layout.cob_id
            ints[INT[f"tpdo_type{k}"]] = layout.trans_type

    def _rpdo_codec(self, layout: pdo.PdoLayout) -> Callable[[bytes], bool]:
        """Applies an RPDO's data to the drive; True when it carried a target (0x607A)."""
        unpack, size, entries = layout.packer.unpack_from, layout.packer.size, layout.entries

        def apply(data: bytes) -> bool:
            if len(data) < size:
                log.warning("drive %s: RPDO 0x%03X has %d bytes, its mapping needs %d: ignored",
                            self.name, layout.cob_id, len(data), size)  # fmt: skip
                return False
            fresh = False
            for (index, subindex), value in zip(entries, unpack(data), strict=True):
                if index == 0x607A:
                    self.target = int(value)
                    fresh = True
                elif index == 0x6040:
                    self._apply_controlword(int(value))
                else:
                    var = _variable(self.node, index, subindex)
                    self.node.data_store.setdefault(index, {})[subindex] = var.encode_raw(value)
            return fresh

        if entries != _CSP_RPDO:
            return apply

        def apply_csp(data: bytes) -> bool:  # controlword + target, the master's RPDO1
            if len(data) < size:
                return apply(data)
            controlword, self.target = unpack(data)
            self._apply_controlword(controlword)
            return True

        return apply_csp

    def _tpdo_codec(self, layout: pdo.PdoLayout) -> Callable[[], bytes]:
        """The TPDO's data from the drive's current values."""
        pack, entries = layout.packer.pack, layout.entries
        if entries == ((0x6041, 0), (0x6064, 0)):
            return lambda: pack(self.sm.statusword, self.actual)
        if entries == ((0x606C, 0),):
            return lambda: pack(self.velocity)
        return lambda: pack(*[self._value(i, s) for i, s in entries])

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


class SdoSink:
    """What the SDO server sends through: the drive's own sender (so faults apply)."""

    def __init__(self, send: Callable[[int, bytes], None]):
        self._send = send

    def send_message(self, can_id: int, data: bytes, remote: bool = False) -> None:
        self._send(can_id, bytes(data))


def _tpdo_kind(layout: pdo.PdoLayout) -> int:
    """The bank's kind of a TPDO's mapping (:data:`hal.emulator.bank.TPDO_VELOCITY`, ...), 0
    for a mapping only the Python codec encodes."""
    if layout.entries == ((0x6041, 0), (0x6064, 0)) and layout.packer.format == "<Hi":
        return TPDO_STATUS_POSITION
    if layout.entries == ((0x606C, 0),) and layout.packer.format == "<i":
        return TPDO_VELOCITY
    return 0


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
    sm = DriveStateMachine(sm._ints)  # the same bank row
    sm.refuse_enable = refuse
    sm.boot()
    return sm
