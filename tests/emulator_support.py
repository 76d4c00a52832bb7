"""A frame-level master for the drive-emulator tests: raw CAN frames on the emulator's bus.

The emulator runs in its synchronous mode (no thread): every helper sends frames on the
master's end of one emulated bus, then lets the emulator handle them (``poll``) at the
master's fake time ``now`` [s], and returns what came back.
"""

from __future__ import annotations

import struct

import can

from hal.emulator.drive_state import PowerState, decode_statusword
from hal.emulator.emulator import DriveEmulator

SDO_DOWNLOAD = {1: 0x2F, 2: 0x2B, 4: 0x23}  # expedited download, n bytes
SDO_UPLOAD = 0x40


class FakeClock:
    """The emulator's clock in a test: time [s] moves only when the test says so."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class FrameMaster:
    """The master's side of bus ``bus`` of ``emulator``, in lockstep by hand.

    ``clock`` must be the emulator's clock; :meth:`cycle` advances it by ``dt``.
    """

    def __init__(self, emulator: DriveEmulator, bus: str, clock: FakeClock):
        self.emulator = emulator
        self.bus = emulator.open_master_bus(bus)
        self.clock = clock

    @property
    def now(self) -> float:
        return self.clock.now

    @now.setter
    def now(self, value: float) -> None:
        self.clock.now = value

    def send(self, can_id: int, data: bytes | list[int] = b"") -> None:
        self.bus.send(can.Message(arbitration_id=can_id, data=bytes(data), is_extended_id=False))

    def frames(self) -> list[can.Message]:
        """Every frame the emulator has sent since the last call."""
        out = []
        while (msg := self.bus.recv(0.0)) is not None:
            out.append(msg)
        return out

    def exchange(self) -> list[can.Message]:
        """Let the emulator handle what was sent; return its answers."""
        self.emulator.poll(self.now)
        return self.frames()

    # ------------------------------------------------------------------------ services

    def nmt(self, command: int, node: int = 0) -> list[can.Message]:
        self.send(0x000, [command, node])
        return self.exchange()

    def cycle(
        self, rpdos: dict[int, tuple[int, int]] | None = None, dt: float = 0.002
    ) -> list[can.Message]:
        """One cycle: RPDO1 (controlword, target [counts]) per node, SYNC; the answers."""
        for node, (controlword, target) in (rpdos or {}).items():
            self.send(0x200 + node, struct.pack("<Hi", controlword, target))
        self.send(0x080)
        self.now += dt
        return self.exchange()

    def sdo_write(self, node: int, index: int, subindex: int, value: int, size: int) -> bytes:
        """Expedited SDO download; the server's answer (8 bytes) or b"" if none."""
        data = struct.pack("<BHB", SDO_DOWNLOAD[size], index, subindex)
        data += value.to_bytes(size, "little", signed=value < 0).ljust(4, b"\0")
        self.send(0x600 + node, data)
        return _sdo_answer(self.exchange(), node)

    def sdo_read(self, node: int, index: int, subindex: int = 0) -> bytes:
        """Expedited SDO upload request; the server's answer (8 bytes) or b"" if none."""
        self.send(0x600 + node, struct.pack("<BHB4x", SDO_UPLOAD, index, subindex))
        return _sdo_answer(self.exchange(), node)

    def close(self) -> None:
        self.bus.shutdown()


def _sdo_answer(frames: list[can.Message], node: int) -> bytes:
    for msg in frames:
        if msg.arbitration_id == 0x580 + node:
            return bytes(msg.data)
    return b""


def tpdo1(frames: list[can.Message], node: int) -> tuple[int, int] | None:
    """(statusword, position [counts]) of ``node``'s TPDO1 among ``frames``."""
    for msg in frames:
        if msg.arbitration_id == 0x180 + node:
            statusword, position = struct.unpack("<Hi", bytes(msg.data))
            return statusword, position
    return None


def state_of(frames: list[can.Message], node: int) -> PowerState | None:
    """The power state ``node``'s TPDO1 shows (None without a TPDO1)."""
    found = tpdo1(frames, node)
    return decode_statusword(found[0]) if found else None


def ids(frames: list[can.Message]) -> list[int]:
    return [m.arbitration_id for m in frames]


def emcy(frames: list[can.Message], node: int) -> list[tuple[int, int]]:
    """(error code, error register) of every EMCY of ``node`` among ``frames``."""
    out = []
    for msg in frames:
        if msg.arbitration_id == 0x080 + node:
            code, register = struct.unpack_from("<HB", bytes(msg.data))
            out.append((code, register))
    return out
