"""Per-SYNC-round cost of the drive emulator, in process, no threads.

Each round a frame-level master sends every drive's RPDO1 (enable, a slow sine target) and
one SYNC per bus; the emulator handles them synchronously (``poll``): per bus, on its own
SYNC, the physics step (first SYNC of the round), latch, sample, TPDO1 (+TPDO2) out.
Reported per round [µs]: ``poll`` CPU time of this thread (``time.thread_time``: the
emulator's own cost, not the host's noise) and wall time, and the SYNC handling alone
(``sync``: step + latch + sample + TPDOs, wall). ``--transport unix`` runs the buses on the
``unix`` interface (what ``--hal hil`` and ``imotion-sim --unix`` use), ``virtual`` on
python-can's in-process bus. The master's own send and receive are not counted. Usage::

    python tools/bench_emulator.py [--robot smartpal5] [--cycles 2000] [--rate 500]
                                   [--transport unix|virtual]

Prints a table, the load average, and a final JSON line.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import struct
import tempfile
import time

import can
import numpy as np

import hal.can  # noqa: F401  (interface "unix")
from hal.emulator.emulator import DriveEmulator


def _percentiles(samples: list[float]) -> dict[str, float]:
    values = np.array(samples) * 1e6
    return {
        "mean_us": round(float(values.mean()), 1),
        "p50_us": round(float(np.percentile(values, 50)), 1),
        "p99_us": round(float(np.percentile(values, 99)), 1),
        "max_us": round(float(values.max()), 1),
    }


def bench(robot: str, cycles: int, rate: float, transport: str) -> dict[str, object]:
    directory = tempfile.mkdtemp(prefix="bench-emu-")
    probe = DriveEmulator(robot, period=1.0 / rate)
    channels = None
    if transport == "unix":
        channels = {bus: ("unix", f"{directory}/{bus}") for bus in probe.channels}
    probe.close()
    emulator = DriveEmulator(robot, period=1.0 / rate, channels=channels)
    emulator.open()
    masters: dict[str, can.BusABC] = {}
    for bus, (interface, channel) in emulator.channels.items():
        masters[bus] = (
            emulator.open_master_bus(bus)
            if interface == "virtual"
            else can.Bus(interface=interface, channel=channel)
        )
    emulator.poll()  # unix: accept the masters
    for master in masters.values():
        master.send(can.Message(arbitration_id=0x000, data=[0x01, 0], is_extended_id=False))
    emulator.poll()
    nodes = {
        bus: [(d.node_id, d.actual) for d in emulator.drives.values() if d.name in names]
        for bus, names in ((b, emulator.profile.drives_on(b)) for b in masters)
    }
    cpu: list[float] = []
    wall: list[float] = []
    emulator.record_sync_times = True
    frames_in = 0
    for k in range(cycles):
        controlword = (0x06, 0x07)[k] if k < 2 else 0x0F
        offset = int(2000 * math.sin(2 * math.pi * k / rate))
        for bus, master in masters.items():
            for node, start in nodes[bus]:
                data = struct.pack("<Hi", controlword, start + offset)
                master.send(
                    can.Message(arbitration_id=0x200 + node, data=data, is_extended_id=False)
                )
            master.send(can.Message(arbitration_id=0x080, is_extended_id=False))
        c, w = time.thread_time(), time.perf_counter()
        emulator.poll()
        cpu.append(time.thread_time() - c)
        wall.append(time.perf_counter() - w)
        for master in masters.values():
            while master.recv(0.0) is not None:
                frames_in += 1
    enabled = sum(d.sm.follows_target for d in emulator.drives.values())
    buses = len(masters)
    result: dict[str, object] = {
        "robot": robot,
        "transport": transport,
        "drives": len(emulator.drives),
        "buses": buses,
        "rate_hz": rate,
        "cycles": emulator.cycles,
        "enabled": enabled,
        "frames_out_per_round": round(frames_in / cycles, 1),
        "poll_cpu": _percentiles(cpu[10:]),
        "poll_wall": _percentiles(wall[10:]),
        "sync_wall_per_round": _percentiles(
            [
                sum(emulator.sync_times[i : i + buses])
                for i in range(10 * buses, cycles * buses, buses)
            ]
        ),
        "budget_us": round(1e6 / rate, 1),
    }
    for master in masters.values():
        master.shutdown()
    emulator.close()
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", action="append", help="robot id (repeat; default: all four)")
    parser.add_argument("--cycles", type=int, default=2000)
    parser.add_argument("--rate", type=float, default=500.0, help="SYNC rate [Hz]")
    parser.add_argument("--transport", choices=("unix", "virtual"), default="unix")
    args = parser.parse_args()
    results = [
        bench(r, args.cycles, args.rate, args.transport)
        for r in args.robot or ["smartpal5", "seednoid", "pa10", "rh"]
    ]
    print(f"{'robot':10} {'drives':>6} {'buses':>5}  poll CPU p50/p99 [µs]  poll wall p50/p99"
          "  SYNCs wall p50  budget")  # fmt: skip
    for r in results:
        cpu, wall, sync = r["poll_cpu"], r["poll_wall"], r["sync_wall_per_round"]
        assert isinstance(cpu, dict) and isinstance(wall, dict) and isinstance(sync, dict)
        print(
            f"{r['robot']:10} {r['drives']:>6} {r['buses']:>5}  {cpu['p50_us']:>8.0f} / "
            f"{cpu['p99_us']:<8.0f}     {wall['p50_us']:>6.0f} / {wall['p99_us']:<8.0f} "
            f"{sync['p50_us']:>8.0f}  {r['budget_us']:.0f} µs"
        )
    load = os.getloadavg()
    print(f"transport {args.transport}; load average {load[0]:.2f} ({os.cpu_count()} CPUs)")
    print(json.dumps({"bench": "emulator_per_round", "load_average": load, "results": results}))


if __name__ == "__main__":
    main()
