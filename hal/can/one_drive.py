"""A master for one drive (``imotion-can enable|disable|jog``): the backend's own parts.

Bus set-up :mod:`hal.can.ports`, SDO set-up :mod:`hal.can.setup` and cycle I/O
:mod:`hal.can.cycle` for a single drive: RPDO1, SYNC and the master heartbeat at the
profile's rate, one period of receiving per cycle. Supervision is off (a bring-up tool);
faults seen while sending or receiving (bus errors, EMCY) end it with :class:`ToolError`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from hal.can.cia402 import Goal, State
from hal.can.cycle import CycleIO
from hal.can.drive_profile import DriveProfile
from hal.can.ports import Port, close_ports, open_ports
from hal.can.setup import set_up_drives
from hal.can.supervision import Supervisor
from hal.interface import HardwareFault


class ToolError(Exception):
    """A drive or bus failed (exit status 1)."""


class OneDrive:
    """The master of drive ``name`` of ``profile`` on ``port`` at period ``dt`` [s]."""

    def __init__(self, profile: DriveProfile, port: Port, name: str, dt: float):
        drive = profile.drives[name]
        self.name = name
        self.dt = dt
        self.faults: list[HardwareFault] = []
        supervisor = Supervisor(
            [name], [drive.node_id], [drive.bus], dt, np.array([math.inf]), 1.0, math.inf, 1
        )
        period = profile.heartbeat.master_producer_ms / 1e3
        self.io = CycleIO([port], [drive.node_id], supervisor, self.faults.extend,
                          time.monotonic, period)  # fmt: skip

    @property
    def actual(self) -> int:
        """Position actual [counts] of the last TPDO1."""
        return self.io.position[0]

    @property
    def state(self) -> State:
        return self.io.states[0]

    def cycle(self, target: int | None = None) -> State:
        """RPDO1 (``target`` [counts] once enabled, else hold), SYNC, heartbeat; then one
        period of receiving. Returns the drive's state."""
        io = self.io
        if target is None or self.state is not State.OPERATION_ENABLED:
            io.hold_targets()
        else:
            io.target[0] = target
        io.send()
        now = time.monotonic()
        io.send_heartbeat(now)
        io.clear_fresh()
        io.receive(now + self.dt)
        if (left := now + self.dt - time.monotonic()) > 0:
            time.sleep(left)
        io.receive()
        io.decode_states()
        if self.faults:
            raise ToolError("; ".join(f"0x{f.code:03X} {f.description}" for f in self.faults))
        return self.state

    def run_to(self, goal: Goal, timeout: float) -> State:
        """Cycles until the drive is Operation enabled (goal ENABLED) or Switch on disabled
        (goal OFF), at most ``timeout`` [s]; returns the last state."""
        self.io.set_goal(goal)
        want = State.OPERATION_ENABLED if goal is Goal.ENABLED else State.SWITCH_ON_DISABLED
        end = time.monotonic() + timeout
        state = State.UNKNOWN
        while time.monotonic() < end:
            state = self.cycle()
            if state is want:
                break
        return state


@contextmanager
def one_drive(
    profile: DriveProfile,
    directory: Path,
    name: str,
    overrides: dict[str, dict[str, Any]] | None = None,
    sdo_timeout: float = 0.3,
) -> Iterator[OneDrive]:
    """Open drive ``name``'s bus (python-can ``overrides`` per bus), set the drive up (EDS
    relative to ``directory``), run its master; quick stop + disable at exit."""
    drive = profile.drives[name]
    dt = 1.0 / profile.rate_hz
    ports = open_ports(profile, [drive.bus], [drive.node_id], [drive.bus], overrides)
    try:
        port = ports[0]
        master = OneDrive(profile, port, name, dt)
        beat = lambda: master.io.send_heartbeat(time.monotonic())  # noqa: E731
        set_up_drives(port.bus, port.name, [name], profile, directory, dt, sdo_timeout, beat)
        try:
            yield master
        finally:
            master.faults.clear()
            try:
                master.run_to(Goal.OFF, 0.5)
            except ToolError:
                pass  # the bus failed: the drive stops on the missing heartbeat
    finally:
        close_ports(ports)
