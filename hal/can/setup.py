"""Drive set-up over SDO and NMT with the canopen library (configure time only, never per cycle).

Per drive, in this order (objects of the contract, docs/can.md):

1. NMT enter pre-operational.
2. 0x6060 modes of operation = 8 (CSP); 0x60C2 interpolation period = the loop period.
3. 0x6065 following-error window [counts], 0x6066 following-error time out [ms].
4. 0x605A quick stop option = 2, 0x6007 abort connection option (profile, default 3).
5. 0x1017 producer heartbeat [ms]; 0x1016:1 consumer heartbeat = (master id << 16) | ms.
6. PDO mapping with canopen's PDO API: RPDO1 = 0x6040 + 0x607A, TPDO1 = 0x6041 + 0x6064,
   TPDO2 = 0x606C (enabled only with ``velocity_feedback``); transmission type 1 (SYNC).
7. NMT start (operational).

The master heartbeat is sent between steps (the caller's ``beat``) so drives that still
consume it from an earlier run do not time out during a long set-up.

The caller hands over an open python-can bus and what to set up (:func:`set_up_drives`);
this module knows nothing of the backend.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import can
import canopen
from canopen.sdo.exceptions import SdoError

from controller.model.alarms import AlarmCode
from hal.can import pdo
from hal.can.drive_profile import DriveConfig, DriveProfile, eds_path
from hal.can.supervision import DriveError
from hal.interface import HardwareFault

log = logging.getLogger(__name__)

#: How often canopen's receive thread wakes while the set-up runs [s].
NOTIFIER_TIMEOUT = 0.02


def quiet_canopen() -> None:
    """canopen logs every SDO and PDO step at INFO (~490 lines at SmartPal V's set-up): its
    loggers go to WARNING unless asked for, i.e. unless the ``canopen`` logger has a level
    of its own or the root logger is at DEBUG."""
    logger = logging.getLogger("canopen")
    if logger.level == logging.NOTSET and logging.getLogger().getEffectiveLevel() > logging.DEBUG:
        logger.setLevel(logging.WARNING)


def interpolation_period(dt: float) -> tuple[int, int]:
    """0x60C2 (value u8, index i8) with value·10^index = ``dt`` [s]."""
    for index in (-3, -4, -5, -6):
        value = dt * 10.0**-index
        if abs(value - round(value)) < 1e-6 and 1 <= round(value) <= 255:
            return round(value), index
    raise ValueError(f"the period {dt!r} s has no exact 0x60C2 representation")


@functools.cache
def object_dictionary(path: Path) -> canopen.ObjectDictionary:
    """The parsed EDS/DCF at ``path`` (parsed once per process)."""
    return canopen.import_od(str(path))


class SetupNetwork:
    """A canopen network on an already open python-can bus, with its receive thread.

    :meth:`close` stops the thread but leaves the bus open (the cycle reads it itself).
    """

    def __init__(self, bus: can.BusABC, sdo_timeout: float = 0.3):
        quiet_canopen()
        self.network = canopen.Network(bus)
        self.network.notifier = can.Notifier(bus, self.network.listeners, NOTIFIER_TIMEOUT)
        self.sdo_timeout = sdo_timeout

    def node(self, node_id: int, eds: Path) -> canopen.RemoteNode:
        node = canopen.RemoteNode(node_id, object_dictionary(eds))
        node.sdo.RESPONSE_TIMEOUT = self.sdo_timeout
        self.network.add_node(node)
        return node

    def close(self) -> None:
        if self.network.notifier is not None:
            self.network.notifier.stop(1.0)
            self.network.notifier = None
        self.network.bus = None  # keep the bus open: canopen must not shut it down


def setup_error(name: str, node_id: int, bus: str, what: str, exc: BaseException) -> DriveError:
    return DriveError(
        [
            HardwareFault(
                int(AlarmCode.DRIVE_FAULT),
                name,
                f"node {node_id} on bus {bus}: set-up failed at {what}: "
                f"{exc or type(exc).__name__}",
            )
        ]
    )


def set_up_drive(
    node: canopen.RemoteNode,
    drive: DriveConfig,
    profile: DriveProfile,
    period: tuple[int, int],
    beat: Callable[[], None] = lambda: None,
) -> None:
    """Everything of the module doc for one drive; raises canopen/python-can errors."""
    scaling = drive.scaling()
    window = scaling.window_to_counts(profile.following_window_of(drive))
    hb = profile.heartbeat
    node.nmt.send_command(pdo.NmtCommand.PRE_OPERATIONAL)
    sdo = node.sdo
    nid = int(node.id or 0)
    steps: list[tuple[str, Callable[[], Any]]] = [
        ("0x6060 modes of operation", lambda: _set(sdo[0x6060], 8)),
        ("0x60C2:1 interpolation period", lambda: _set(sdo[0x60C2][1], period[0])),
        ("0x60C2:2 interpolation index", lambda: _set(sdo[0x60C2][2], period[1])),
        ("0x6065 following error window", lambda: _set(sdo[0x6065], window)),
        (
            "0x6066 following error time out",
            lambda: _set(sdo[0x6066], profile.following_error.time_ms),
        ),
        ("0x605A quick stop option", lambda: _set(sdo[0x605A], 2)),
        (
            "0x6007 abort connection option",
            lambda: _set(sdo[0x6007], profile.abort_connection_option),
        ),
        ("0x1017 producer heartbeat", lambda: _set(sdo[0x1017], hb.drive_producer_ms)),
        (
            "0x1016:1 consumer heartbeat",
            lambda: _set(sdo[0x1016][1], (profile.master_node_id << 16) | hb.drive_consumer_ms),
        ),
        ("RPDO1 mapping", lambda: _map(node.rpdo[1], pdo.RPDO1 + nid, (0x6040, 0x607A), True)),
        ("TPDO1 mapping", lambda: _map(node.tpdo[1], pdo.TPDO1 + nid, (0x6041, 0x6064), True)),
        (
            "TPDO2 mapping",
            lambda: _map(node.tpdo[2], pdo.TPDO2 + nid, (0x606C,), drive.velocity_feedback),
        ),
    ]
    for what, step in steps:
        try:
            step()
        except (SdoError, can.CanError, KeyError) as exc:
            raise _Failed(what, exc) from exc
        beat()
    node.nmt.send_command(pdo.NmtCommand.START)


class _Failed(Exception):
    def __init__(self, what: str, exc: BaseException):
        super().__init__(what)
        self.what = what
        self.exc = exc


def _set(var: Any, value: int) -> None:
    var.raw = value


def _map(pdo_map: Any, cob_id: int, objects: tuple[int, ...], enabled: bool) -> None:
    pdo_map.clear()
    for index in objects:
        pdo_map.add_variable(index)
    pdo_map.cob_id = cob_id
    pdo_map.trans_type = 1
    # A disabled map is saved with COB-ID bit 31 (not valid) set and stays so.
    pdo_map.enabled = enabled
    pdo_map.save()


def set_up_drives(
    bus: can.BusABC,
    bus_name: str,
    names: Sequence[str],
    profile: DriveProfile,
    directory: Path,
    dt: float,
    sdo_timeout: float = 0.3,
    beat: Callable[[], None] = lambda: None,
) -> None:
    """Set up drives ``names`` of ``profile`` on the open ``bus`` for loop period ``dt`` [s]
    (EDS paths relative to ``directory``); ``beat`` after every step sends the master's
    heartbeat when due. Raises :class:`DriveError` naming the drive."""
    period = interpolation_period(dt)
    net = SetupNetwork(bus, sdo_timeout)
    try:
        for name in names:
            drive = profile.drives[name]
            eds = eds_path(profile, name, directory)
            try:
                node = net.node(drive.node_id, eds)
            except (OSError, ValueError) as exc:
                raise setup_error(name, drive.node_id, bus_name, f"EDS {eds}", exc) from exc
            try:
                set_up_drive(node, drive, profile, period, beat)
            except _Failed as failed:
                raise setup_error(
                    name, drive.node_id, bus_name, failed.what, failed.exc
                ) from failed.exc
            log.info("set up %s (node %d on bus %s)", name, drive.node_id, bus_name)
    finally:
        net.close()
