"""Fault injection into the drive emulator: what a HIL test can make a drive or bus do.

========================  =================================================================
kind                      effect (``joint`` names the drive; parameters in brackets)
========================  =================================================================
``emcy``                  EMCY ``code`` (default 0xFF00, device specific) and, unless
                          ``fault=False``, transition 13 to Fault; [code, fault, info]
``silent``                the node stops answering: receives and sends nothing (SDO, NMT,
                          PDO, SYNC, heartbeat, EMCY); it keeps running inside, so it
                          faults itself on the master's heartbeat loss (0x1016)
``heartbeat_loss``        the node stops its heartbeat only
``following_error``       the following-error supervision trips at once: EMCY 0x8611,
                          statusword bit 13, Fault (as if the joint were blocked)
``refuse_enable``         enable operation is ignored (transitions 4 and 16 refused)
``bus_off``               everything on the drive's bus stops (or ``bus=<name>``): the
                          emulator neither receives nor sends there, and a master bus opened
                          with :meth:`DriveEmulator.open_master_bus` fails its sends
                          (``can.CanOperationError``) and receives nothing
``delayed_tpdo``          the drive's TPDOs leave ``cycles`` SYNCs late (default 1)
========================  =================================================================

One-shot kinds (``emcy``, ``following_error``) act at once and are not kept; the others last
until :meth:`FaultInjector.clear`. Clearing does not reset a drive's Fault state: the master
resets it (controlword bit 7), as on a real drive.
"""

from __future__ import annotations

import enum
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import can

from hal.emulator.codes import (
    EMCY_DEVICE_SPECIFIC,
    EMCY_FOLLOWING_ERROR,
    ERR_GENERIC,
    ERR_MANUFACTURER,
    ERR_PROFILE,
)
from hal.emulator.drive import EmulatedDrive

log = logging.getLogger(__name__)


class FaultKind(enum.Enum):
    EMCY = "emcy"
    SILENT = "silent"
    HEARTBEAT_LOSS = "heartbeat_loss"
    FOLLOWING_ERROR = "following_error"
    REFUSE_ENABLE = "refuse_enable"
    BUS_OFF = "bus_off"
    DELAYED_TPDO = "delayed_tpdo"


_PARAMS: dict[FaultKind, frozenset[str]] = {
    FaultKind.EMCY: frozenset({"code", "fault", "info"}),
    FaultKind.SILENT: frozenset(),
    FaultKind.HEARTBEAT_LOSS: frozenset(),
    FaultKind.FOLLOWING_ERROR: frozenset(),
    FaultKind.REFUSE_ENABLE: frozenset(),
    FaultKind.BUS_OFF: frozenset({"bus"}),
    FaultKind.DELAYED_TPDO: frozenset({"cycles"}),
}
_ONE_SHOT = frozenset({FaultKind.EMCY, FaultKind.FOLLOWING_ERROR})


@dataclass(frozen=True)
class ActiveFault:
    """A lasting injection: ``target`` is the drive name (or the bus name for bus_off)."""

    kind: FaultKind
    target: str
    params: dict[str, Any] = field(default_factory=dict)


class FaultableBus(can.BusABC):
    """A python-can bus whose sends fail and whose receptions vanish while ``bus_off``.

    Wraps the master's side of an emulated bus so an injected bus-off is seen by the master
    as on real hardware: ``send`` raises :class:`can.CanOperationError`, ``state`` is
    ``ERROR``, nothing is received.
    """

    def __init__(self, inner: can.BusABC, name: str):
        self.inner = inner
        self.name = name
        self.bus_off = False
        super().__init__(channel=getattr(inner, "channel", name))
        self.channel_info = f"{inner.channel_info} (emulated bus {name})"

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        if self.bus_off:
            raise can.CanOperationError(f"bus {self.name}: bus-off (injected by the emulator)")
        self.inner.send(msg, timeout)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        msg = self.inner.recv(timeout)
        if self.bus_off:
            return None, False
        return msg, False

    @property
    def state(self) -> can.BusState:
        return can.BusState.ERROR if self.bus_off else can.BusState.ACTIVE

    @state.setter
    def state(self, new_state: can.BusState) -> None:
        raise NotImplementedError(f"bus {self.name}: the emulated bus state cannot be set")

    def shutdown(self) -> None:
        if self._is_shutdown:
            return
        self.inner.shutdown()
        super().shutdown()


class FaultInjector:
    """Applies and clears injections on ``drives`` (by name) and buses (via ``set_bus_off``).

    ``bus_of`` names each drive's bus; ``set_bus_off(bus, on)`` switches a bus off/on.
    """

    def __init__(
        self,
        drives: Mapping[str, EmulatedDrive],
        bus_of: Mapping[str, str],
        set_bus_off: Callable[[str, bool], None],
    ):
        self._drives = drives
        self._bus_of = bus_of
        self._set_bus_off = set_bus_off
        self._active: list[ActiveFault] = []

    @property
    def active(self) -> list[ActiveFault]:
        """Lasting injections now in force."""
        return list(self._active)

    def inject(self, kind: str | FaultKind, joint: str | None = None, **params: Any) -> None:
        """Inject ``kind`` on drive ``joint`` (see the module table); ValueError if invalid."""
        kind = _kind(kind)
        unknown = set(params) - _PARAMS[kind]
        if unknown:
            allowed = ", ".join(sorted(_PARAMS[kind])) or "none"
            raise ValueError(
                f"fault {kind.value}: unknown parameters {sorted(unknown)} (allowed: {allowed})"
            )
        if kind is FaultKind.BUS_OFF:
            bus = params.get("bus") or (self._bus_of.get(joint, "") if joint else "")
            if bus not in set(self._bus_of.values()):
                raise ValueError(
                    f"fault bus_off: give a drive (joint=...) or a bus (bus=...); got "
                    f"joint={joint!r}, bus={params.get('bus')!r}"
                )
            self._set_bus_off(bus, True)
            self._remember(ActiveFault(kind, bus, dict(params)))
            log.warning("injected bus_off on bus %s", bus)
            return
        drive = self._drive(kind, joint)
        if kind is FaultKind.EMCY:
            code = _int_param(kind, params, "code", EMCY_DEVICE_SPECIFIC, 0, 0xFFFF)
            info = bytes(params.get("info", b""))
            if params.get("fault", True):
                drive.raise_fault(code, ERR_GENERIC | ERR_MANUFACTURER, info)
            else:
                drive.send_emcy(code, info)
        elif kind is FaultKind.FOLLOWING_ERROR:
            drive.sm.following_error = True
            drive.raise_fault(EMCY_FOLLOWING_ERROR, ERR_GENERIC | ERR_PROFILE)
        elif kind is FaultKind.SILENT:
            drive.silent = True
        elif kind is FaultKind.HEARTBEAT_LOSS:
            drive.heartbeat_muted = True
        elif kind is FaultKind.REFUSE_ENABLE:
            drive.sm.refuse_enable = True
        elif kind is FaultKind.DELAYED_TPDO:
            drive.tpdo_delay = _int_param(kind, params, "cycles", 1, 1, 1000)
        if kind not in _ONE_SHOT:
            self._remember(ActiveFault(kind, drive.name, dict(params)))
        log.warning("injected %s on drive %s %s", kind.value, drive.name, params or "")

    def clear(self, kind: str | FaultKind | None = None, joint: str | None = None) -> int:
        """Clear lasting injections matching ``kind`` and ``joint`` (None = any); how many."""
        wanted = _kind(kind) if kind is not None else None
        if joint is not None and joint not in self._drives and joint not in self._bus_of.values():
            raise ValueError(f"clear: {joint!r} is neither a drive nor a bus")
        keep, cleared = [], 0
        for fault in self._active:
            target_match = joint is None or fault.target == joint
            if fault.kind is FaultKind.BUS_OFF and joint is not None and joint in self._drives:
                target_match = self._bus_of[joint] == fault.target
            if (wanted is None or fault.kind is wanted) and target_match:
                self._undo(fault)
                cleared += 1
            else:
                keep.append(fault)
        self._active = keep
        return cleared

    # --------------------------------------------------------------------------- helpers

    def _undo(self, fault: ActiveFault) -> None:
        if fault.kind is FaultKind.BUS_OFF:
            self._set_bus_off(fault.target, False)
            return
        drive = self._drives[fault.target]
        if fault.kind is FaultKind.SILENT:
            drive.silent = False
        elif fault.kind is FaultKind.HEARTBEAT_LOSS:
            drive.heartbeat_muted = False
        elif fault.kind is FaultKind.REFUSE_ENABLE:
            drive.sm.refuse_enable = False
        elif fault.kind is FaultKind.DELAYED_TPDO:
            drive.tpdo_delay = 0
        log.info("cleared %s on %s", fault.kind.value, fault.target)

    def _remember(self, fault: ActiveFault) -> None:
        self._active = [
            f for f in self._active if (f.kind, f.target) != (fault.kind, fault.target)
        ] + [fault]

    def _drive(self, kind: FaultKind, joint: str | None) -> EmulatedDrive:
        drive = self._drives.get(joint or "")
        if drive is None:
            raise ValueError(
                f"fault {kind.value}: unknown drive {joint!r} (drives: {', '.join(self._drives)})"
            )
        return drive


def _kind(kind: str | FaultKind) -> FaultKind:
    if isinstance(kind, FaultKind):
        return kind
    try:
        return FaultKind(kind)
    except ValueError:
        names = ", ".join(k.value for k in FaultKind)
        raise ValueError(f"unknown fault kind {kind!r}: choose one of {names}") from None


def _int_param(
    kind: FaultKind, params: Mapping[str, Any], key: str, default: int, low: int, high: int
) -> int:
    value = params.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"fault {kind.value}: {key} must be an integer in [{low}, {high}]")
    return value
