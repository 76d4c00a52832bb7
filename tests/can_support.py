"""HIL harness for the CAN tests: CanBackend + the drive emulator in one process, lock-step.

Deterministic: one fake clock drives the backend's heartbeat/timeouts and the emulator's;
"sleeping" a period advances it and lets the emulator handle every waiting frame
(:meth:`DriveEmulator.poll`, no threads). Only the SDO set-up runs the emulator's threads,
because the canopen SDO client blocks for its answers.
"""

from __future__ import annotations

import can
import numpy as np

from controller.control.core import MotionCore
from controller.model.robot import Robot
from hal.can.backend import CanBackend
from hal.can.drive_profile import DriveProfile, drives_path, load_drive_profile
from hal.emulator.emulator import DriveEmulator
from hal.interface import JointCommand, JointState
from tests.support import robot as cached_robot

#: [s] per SDO request at set-up in the harness.
SDO_TIMEOUT = 2.0


class FakeClock:
    """Monotonic seconds that move only when told."""

    def __init__(self, start: float = 1000.0):
        self.t = start

    def __call__(self) -> float:
        return self.t


class Sniffer:
    """Records every frame on the emulator's buses (a third party on each virtual channel)."""

    def __init__(self, emulator: DriveEmulator):
        self.buses = {
            name: can.Bus(interface=interface, channel=channel)
            for name, (interface, channel) in emulator.channels.items()
        }

    def frames(self) -> list[tuple[str, can.Message]]:
        out = []
        for name, bus in self.buses.items():
            while (msg := bus.recv(0.0)) is not None:
                out.append((name, msg))
        return out

    def close(self) -> None:
        for bus in self.buses.values():
            bus.shutdown()


class Hil:
    """Backend + emulator for ``robot_id`` at period ``dt`` [s]."""

    def __init__(self, robot_id: str, dt: float = 0.002, profile: DriveProfile | None = None):
        self.robot: Robot = cached_robot(robot_id)
        self.dt = dt
        self.profile = profile or load_drive_profile(drives_path(self.robot), self.robot)
        self.clock = FakeClock()
        self.emulator = DriveEmulator(self.robot, self.profile, period=dt, clock=self.clock)
        self.sniffer = Sniffer(self.emulator)
        self.backend = CanBackend(
            self.robot,
            dt,
            self.profile,
            bus_factory=lambda name, _kw: self.emulator.open_master_bus(name),
            # The set-up runs the emulator's threads in real time: on a loaded host an SDO
            # answer may take longer than the 0.3 s default (these tests are not about it).
            sdo_timeout=SDO_TIMEOUT,
            clock=self.clock,
            sleep=self.sleep,
        )

    def sleep(self, seconds: float) -> None:
        self.clock.t += seconds
        self.emulator.poll()

    def configure(self) -> None:
        self.emulator.start()
        try:
            self.backend.configure()
        finally:
            self.emulator.stop()
        self.sleep(self.dt)

    def cycle(self, command: np.ndarray | None = None) -> JointState:
        """One backend cycle (hold when ``command`` is None), then one emulator period."""
        state = self.backend.read()
        position = state.position if command is None else command
        self.backend.write(JointCommand(position))
        self.sleep(self.dt)
        return state

    def core_cycle(self, core: MotionCore) -> None:
        core.cycle()
        self.sleep(self.dt)

    def drive_state(self, name: str) -> str:
        """The emulated drive's own power state (its statusword, decoded by the emulator)."""
        from hal.can.cia402 import decode

        return decode(self.emulator.drives[name].sm.statusword).value

    def close(self) -> None:
        self.backend.shutdown()
        self.emulator.close()
        self.sniffer.close()
