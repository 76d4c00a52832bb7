"""Worst-case CAN bus load of a drive profile at a loop rate.

Per bus and control cycle the master sends one RPDO1 per drive (6 bytes) and one SYNC
(0 bytes); every drive answers with TPDO1 (6 bytes) and, with ``velocity_feedback``, TPDO2
(4 bytes). On top of the cyclic traffic: each drive's heartbeat (1 byte every
``drive_producer_ms``) and the master's own heartbeat on every bus. EMCY and SDO traffic are
events, not planned load.

Frame lengths are worst case with bit stuffing, standard 11-bit identifiers:

* **Classic CAN**, ``n`` data bytes: ``47 + 8n`` bits of frame (SOF, identifier, control,
  data, CRC, delimiters, ACK, EOF and the 3-bit intermission) plus at most
  ``⌊(34 + 8n − 1) / 4⌋`` stuff bits over the 34 + 8n stuffed bits (SOF to CRC). An 8-byte
  frame: 135 bits (135 µs at 1 Mbit/s); a SYNC: 55 bits.
* **CAN FD** with bit-rate switch: the arbitration phase (SOF, identifier, RRS, IDE, FDF, res,
  BRS: 17 bits, ≤ 4 stuff bits) and the tail (CRC delimiter, ACK, EOF, intermission:
  12 bits) at the nominal bitrate; the data phase (ESI, DLC, data, stuff count, CRC-17/21
  with its fixed stuff bits, ≤ one dynamic stuff bit per 4 bits of ESI/DLC/data) at the
  data bitrate.

``load = bits per second / bitrate``. The daemon refuses a profile whose worst bus is above
:data:`REFUSE_ABOVE` (100 %) and warns above :data:`WARN_ABOVE` (70 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hal.can.drive_profile import BusConfig, DriveProfile

#: Load above which the configuration is refused [fraction of the bitrate].
REFUSE_ABOVE = 1.0
#: Load above which the daemon warns.
WARN_ABOVE = 0.7
#: Data bytes of the cyclic frames.
RPDO1_BYTES = 6
TPDO1_BYTES = 6
TPDO2_BYTES = 4
SYNC_BYTES = 0
HEARTBEAT_BYTES = 1


def classic_frame_bits(n: int) -> int:
    """Worst-case length [bit] of a classic CAN data frame with ``n`` (0..8) data bytes."""
    if not 0 <= n <= 8:
        raise ValueError(f"a classic CAN frame carries 0..8 data bytes, got {n}")
    return 47 + 8 * n + (34 + 8 * n - 1) // 4


#: Worst-case classic frame length [bit] per data length (0..8 bytes).
FRAME_BITS = [classic_frame_bits(n) for n in range(9)]


def fd_frame_time(n: int, bitrate: float, data_bitrate: float) -> float:
    """Worst-case duration [s] of a CAN FD frame (bit-rate switch) with ``n`` data bytes."""
    if not 0 <= n <= 64:
        raise ValueError(f"a CAN FD frame carries 0..64 data bytes, got {n}")
    sizes = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
    n = next(s for s in sizes if s >= n)  # padded to the next DLC size
    nominal = 17 + (17 - 1) // 4 + 12
    crc = 17 if n <= 16 else 21
    dynamic = 1 + 4 + 8 * n
    data = dynamic + (dynamic - 1) // 4 + 4 + crc + math.ceil((4 + crc) / 4)
    return nominal / bitrate + data / data_bitrate


def frame_time(bus: BusConfig, n: int) -> float:
    """Worst-case duration [s] of one frame with ``n`` data bytes on ``bus``."""
    if bus.fd:
        assert bus.data_bitrate is not None
        return fd_frame_time(n, bus.bitrate, bus.data_bitrate)
    return classic_frame_bits(n) / bus.bitrate


@dataclass(frozen=True)
class BusLoad:
    """Planned load of one bus."""

    bus: str
    drives: int
    #: Drives with TPDO2 (velocity actual).
    tpdo2: int
    #: Frames per second, cyclic and heartbeat.
    frames_per_s: float
    #: Bus time used per control cycle [s] (cyclic frames only).
    cycle_time: float
    #: Fraction of the bus's time, heartbeats included (1.0 = 100 %).
    load: float

    @property
    def verdict(self) -> str:
        if self.load > REFUSE_ABOVE:
            return "over 100 %: refused"
        if self.load > WARN_ABOVE:
            return "over 70 %: warning"
        return "ok"


def bus_load(profile: DriveProfile, bus_name: str, rate_hz: float) -> BusLoad:
    """Worst-case load of ``bus_name`` at ``rate_hz`` [Hz] (see the module doc)."""
    bus = profile.buses[bus_name]
    drives = profile.drives_on(bus_name)
    tpdo2 = sum(1 for d in drives.values() if d.velocity_feedback)
    n = len(drives)
    cycle = (
        frame_time(bus, SYNC_BYTES)
        + n * (frame_time(bus, RPDO1_BYTES) + frame_time(bus, TPDO1_BYTES))
        + tpdo2 * frame_time(bus, TPDO2_BYTES)
    )
    hb = profile.heartbeat
    heartbeats_per_s = n * 1000.0 / hb.drive_producer_ms + 1000.0 / hb.master_producer_ms
    busy = cycle * rate_hz + heartbeats_per_s * frame_time(bus, HEARTBEAT_BYTES)
    frames = (1 + 2 * n + tpdo2) * rate_hz + heartbeats_per_s
    return BusLoad(bus_name, n, tpdo2, frames, cycle, busy)


def plan(profile: DriveProfile, rate_hz: float) -> list[BusLoad]:
    """Load of every bus of ``profile`` at ``rate_hz`` [Hz], in file order."""
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be a positive number, got {rate_hz!r}")
    return [bus_load(profile, name, rate_hz) for name in profile.buses]


def worst(loads: list[BusLoad]) -> BusLoad:
    return max(loads, key=lambda b: b.load)


def table_text(profile: DriveProfile, rate_hz: float, loads: list[BusLoad] | None = None) -> str:
    """A plain-text table of :func:`plan` (for errors, logs and docs)."""
    loads = plan(profile, rate_hz) if loads is None else loads
    lines = [
        f"bus load of {profile.robot} at {rate_hz:g} Hz (worst case, bit stuffing):",
        f"{'bus':<15} {'kind':<16} {'drives':>6} {'TPDO2':>5} {'frames/s':>9} "
        f"{'µs/cycle':>8} {'load':>7}  verdict",
    ]
    for b in loads:
        bus = profile.buses[b.bus]
        kind = (
            f"FD {bus.bitrate // 1000}k/{(bus.data_bitrate or 0) // 1000}k"
            if bus.fd
            else (f"classic {bus.bitrate // 1000}k")
        )
        lines.append(
            f"{b.bus:<15} {kind:<16} {b.drives:>6} {b.tpdo2:>5} {b.frames_per_s:>9.0f} "
            f"{b.cycle_time * 1e6:>8.0f} {b.load * 100:>6.1f}%  {b.verdict}"
        )
    return "\n".join(lines)


def check(profile: DriveProfile, rate_hz: float) -> tuple[list[BusLoad], str | None]:
    """``(loads, warning)``; raises ValueError with the table when a bus is over 100 %."""
    loads = plan(profile, rate_hz)
    top = worst(loads)
    if top.load > REFUSE_ABOVE:
        raise ValueError(
            f"bus {top.bus} of {profile.robot} would be loaded {top.load * 100:.1f} % at "
            f"{rate_hz:g} Hz (limit 100 %): split its drives over more buses, lower the "
            f"rate or raise the bitrate\n{table_text(profile, rate_hz, loads)}"
        )
    if top.load > WARN_ABOVE:
        return loads, (
            f"bus {top.bus} of {profile.robot} is loaded {top.load * 100:.1f} % at "
            f"{rate_hz:g} Hz (above 70 %)\n{table_text(profile, rate_hz, loads)}"
        )
    return loads, None
