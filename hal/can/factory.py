"""Building the CAN backend for ``imotiond --hal can`` (called by :mod:`hal.factory`;
``--hal hil`` builds on it in :mod:`hal.hil`).

:class:`~hal.can.backend.CanBackend` on the buses of the robot's ``drives.yaml``. Options
(``hal_options`` of the daemon configuration):

====================  =======================================================================
``buses``             per bus, python-can settings overriding the profile, e.g.
                      ``{"arm_r": {"interface": "unix", "channel": "/tmp/sp5/arm_r"}}``
``drives``            path of another drive profile (default ``config/robots/<id>/drives.yaml``)
``feedback_wait``     [s] how long ``read()`` may wait for missing TPDOs (default 0)
``tpdo_timeout``      [s] TPDO1 missing this long too before 0x405: the timeout is
                      ``max(tpdo_timeout_cycles, ceil(tpdo_timeout / period))`` cycles
                      (default 0: ``tpdo_timeout_cycles`` of ``drives.yaml`` alone). For buses
                      whose partner is a process on a shared host (the emulator), not the wire
``heartbeat_timeout`` [s] at least this for both heartbeat consumers (``master_consumer_ms``,
                      ``drive_consumer_ms`` of ``drives.yaml`` raised to it; default 0: as
                      the profile says). Same purpose: a host that holds a process back
``enable_timeout``    [s] bound of ``activate()`` (default 0.5)
``reset_timeout``     [s] bound of ``reset_faults()`` (default 0.5)
``sdo_timeout``       [s] per SDO request at set-up (default 0.3)
====================  =======================================================================

The profile's worst-case bus load at the loop rate (:mod:`hal.can.busload`) is checked
first: over 100 % raises ValueError with the load table, over 70 % logs a warning.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from controller.model.robot import Robot
from hal.can import busload
from hal.can.backend import CanBackend
from hal.can.drive_profile import DriveProfile, drives_path, load_drive_profile

log = logging.getLogger(__name__)

#: Options of ``--hal can``; the numbers are seconds >= 0.
OPTIONS = ("buses", "drives", "feedback_wait", "tpdo_timeout", "heartbeat_timeout",
           "enable_timeout", "reset_timeout", "sdo_timeout")  # fmt: skip
_BACKEND_SECONDS = ("feedback_wait", "enable_timeout", "reset_timeout", "sdo_timeout")


@dataclass
class CanSettings:
    """Checked options: the profile (TPDO timeout applied), its directory, backend timing."""

    profile: DriveProfile
    directory: Path
    timing: dict[str, Any]
    buses: dict[str, dict[str, Any]]


def seconds(options: dict[str, Any], key: str) -> float | None:
    """``options[key]`` as seconds >= 0 (None when absent); ValueError naming the key."""
    if key not in options:
        return None
    value = options[key]
    if not isinstance(value, int | float) or isinstance(value, bool) or not value >= 0:
        raise ValueError(f"hal.options.{key}: a number of seconds >= 0, got {value!r}")
    return float(value)


def can_settings(
    kind: str, robot: Robot, dt: float, options: dict[str, Any], known: Iterable[str] = OPTIONS
) -> CanSettings:
    """Check ``options`` (names in ``known``) for hal ``kind``; load and check the profile."""
    known = tuple(known)
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise ValueError(f"hal.options: unknown keys {unknown} for hal {kind!r} (known: {known})")
    path = Path(options["drives"]) if "drives" in options else drives_path(robot)
    profile = load_drive_profile(path, robot)
    _, warning = busload.check(profile, 1.0 / dt)
    if warning:
        log.warning("%s", warning)
    timing: dict[str, Any] = {
        k: v for k in _BACKEND_SECONDS if (v := seconds(options, k)) is not None
    }
    tpdo_timeout = seconds(options, "tpdo_timeout")
    if tpdo_timeout:
        cycles = max(profile.tpdo_timeout_cycles, math.ceil(tpdo_timeout / dt - 1e-9))
        profile = profile.model_copy(update={"tpdo_timeout_cycles": cycles})
    heartbeat_timeout = seconds(options, "heartbeat_timeout")
    if heartbeat_timeout:
        ms = math.ceil(heartbeat_timeout * 1e3)
        hb = profile.heartbeat
        hb = hb.model_copy(
            update={"master_consumer_ms": max(hb.master_consumer_ms, ms),
                    "drive_consumer_ms": max(hb.drive_consumer_ms, ms)}
        )  # fmt: skip
        profile = profile.model_copy(update={"heartbeat": hb})
    buses = options.get("buses", {})
    if not isinstance(buses, dict) or not all(isinstance(v, dict) for v in buses.values()):
        raise ValueError(f"hal.options.buses: a mapping bus -> python-can settings, got {buses!r}")
    return CanSettings(profile, path.parent, timing, buses)


def make_can_backend(
    kind: str, robot: Robot, dt: float, options: dict[str, Any] | None = None
) -> CanBackend:
    """A CanBackend for ``robot`` at period ``dt`` [s] (``kind`` must be ``can``)."""
    if kind != "can":
        raise ValueError(f"make_can_backend: kind must be 'can', got {kind!r} (hil: hal.hil)")
    s = can_settings(kind, robot, dt, dict(options or {}))
    return CanBackend(robot, dt, s.profile, s.directory, s.buses, **s.timing)
