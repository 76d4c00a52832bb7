"""Building the CAN backend for ``imotiond --hal can|hil`` (called by :mod:`hal.factory`).

* ``can``: :class:`~hal.can.backend.CanBackend` on the buses of the robot's ``drives.yaml``.
* ``hil``: the same backend on private python-can ``virtual`` buses, talking to the
  in-process drive emulator (:class:`hal.emulator.emulator.DriveEmulator`, its threads
  running) in deterministic lockstep: every ``read()`` waits until the emulator has answered
  the SYNCs of the cycle just sent (``lockstep_timeout``); the emulator stops when the
  backend shuts down.

Options (``hal_options`` of the daemon configuration):

====================  =======================================================================
``buses``             per bus, python-can settings overriding the profile, e.g.
                      ``{"arm_r": {"interface": "remote", "channel": "ws://127.0.0.1:54701/"}}``
                      (``can`` only)
``drives``            path of another drive profile (default ``config/robots/<id>/drives.yaml``)
``feedback_wait``     [s] how long ``read()`` may wait for missing TPDOs (default 0)
``lockstep_timeout``  [s] ``hil`` only: longest wait for the emulator to answer a cycle's
                      SYNCs before the cycle counts as missing its TPDOs (default 1.0)
``enable_timeout``    [s] bound of ``activate()`` (default 0.5)
``reset_timeout``     [s] bound of ``reset_faults()`` (default 0.5)
``sdo_timeout``       [s] per SDO request at set-up (default 0.3)
====================  =======================================================================

The profile's worst-case bus load at the loop rate (:mod:`hal.can.busload`) is checked
first: over 100 % raises ValueError with the load table, over 70 % logs a warning.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from controller.model.robot import Robot
from hal.can import busload
from hal.can.backend import CanBackend
from hal.can.drive_profile import drives_path, load_drive_profile

log = logging.getLogger(__name__)

OPTIONS = (
    "buses",
    "drives",
    "feedback_wait",
    "enable_timeout",
    "reset_timeout",
    "sdo_timeout",
    "lockstep_timeout",
)
_SECONDS = OPTIONS[2:]


def make_can_backend(
    kind: str, robot: Robot, dt: float, options: dict[str, Any] | None = None
) -> CanBackend:
    """A CanBackend (``kind`` = ``can`` or ``hil``) for ``robot`` at period ``dt`` [s]."""
    options = dict(options or {})
    unknown = sorted(set(options) - set(OPTIONS))
    if unknown:
        raise ValueError(f"hal.options: unknown keys {unknown} for hal {kind!r} (known: {OPTIONS})")
    path = Path(options["drives"]) if "drives" in options else drives_path(robot)
    profile = load_drive_profile(path, robot)
    _, warning = busload.check(profile, 1.0 / dt)
    if warning:
        log.warning("%s", warning)
    timing: dict[str, Any] = {}
    for key in _SECONDS:
        if key in options:
            value = options[key]
            if not isinstance(value, int | float) or isinstance(value, bool) or value < 0:
                raise ValueError(f"hal.options.{key}: a number of seconds >= 0, got {value!r}")
            timing[key] = float(value)
    buses = options.get("buses", {})
    if not isinstance(buses, dict) or not all(isinstance(v, dict) for v in buses.values()):
        raise ValueError(f"hal.options.buses: a mapping bus -> python-can settings, got {buses!r}")
    if kind == "can":
        if "lockstep_timeout" in timing:
            raise ValueError("hal.options.lockstep_timeout: only for hal 'hil' (no emulator)")
        return CanBackend(robot, dt, profile, path.parent, buses, **timing)
    if kind != "hil":
        raise ValueError(f"make_can_backend: kind must be 'can' or 'hil', got {kind!r}")
    if buses:
        raise ValueError("hal.options.buses: the hil buses are the emulator's; use hal 'can'")
    from hal.emulator.emulator import DriveEmulator

    emulator = DriveEmulator(robot, profile, period=dt)
    emulator.start()
    try:
        # Lockstep: the emulator is the plant. On a busy host its threads may answer late;
        # waiting for them (an overrun) is right where real drives would be on time.
        backend = CanBackend(
            robot,
            dt,
            profile,
            path.parent,
            bus_factory=lambda name, _kwargs: emulator.open_master_bus(name),
            lockstep=emulator,
            **timing,
        )
    except BaseException:
        emulator.close()
        raise
    backend.on_shutdown.append(emulator.close)
    backend.emulator = emulator
    return backend
