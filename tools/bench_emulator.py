"""Per-SYNC cost of the drive emulator, in process (python-can virtual buses, no threads).

Each cycle a frame-level master sends every drive's RPDO1 (enable, a slow sine target) and
one SYNC per bus; the emulator handles them synchronously (``poll``): latch, MuJoCo step,
TPDO1 (+TPDO2) out. Reported per cycle [µs]: the whole ``poll`` (frames in, physics, frames
out) and, inside it, the cycle close (plant step + samples + TPDOs). The master's own send
and receive cost is not counted. Usage::

    python tools/bench_emulator.py [--robot smartpal5] [--cycles 2000] [--rate 500]

Prints a table and a final JSON line.
"""

from __future__ import annotations

import argparse
import json
import math
import struct
import time

import can
import numpy as np

from hal.emulator.emulator import DriveEmulator


def _percentiles(samples: list[float]) -> dict[str, float]:
    values = np.array(samples) * 1e6
    return {
        "mean_us": round(float(values.mean()), 1),
        "p50_us": round(float(np.percentile(values, 50)), 1),
        "p99_us": round(float(np.percentile(values, 99)), 1),
        "max_us": round(float(values.max()), 1),
    }


def bench(robot: str, cycles: int, rate: float) -> dict[str, object]:
    emulator = DriveEmulator(robot, period=1.0 / rate)
    emulator.open()
    masters = {bus: emulator.open_master_bus(bus) for bus in emulator.channels}
    for master in masters.values():
        master.send(can.Message(arbitration_id=0x000, data=[0x01, 0], is_extended_id=False))
    emulator.poll()
    nodes = {
        bus: [(d.node_id, d.actual) for d in emulator.drives.values() if d.name in names]
        for bus, names in ((b, emulator.profile.drives_on(b)) for b in masters)
    }
    polls: list[float] = []
    emulator.record_cycle_times = True
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
        for master in masters.values():
            master.send(can.Message(arbitration_id=0x080, is_extended_id=False))
        begin = time.perf_counter()
        emulator.poll()
        polls.append(time.perf_counter() - begin)
        for master in masters.values():
            while master.recv(0.0) is not None:
                frames_in += 1
    enabled = sum(d.sm.follows_target for d in emulator.drives.values())
    result: dict[str, object] = {
        "robot": robot,
        "drives": len(emulator.drives),
        "buses": len(masters),
        "rate_hz": rate,
        "cycles": emulator.cycles,
        "enabled": enabled,
        "tpdos_per_cycle": round(frames_in / cycles, 1),
        "poll": _percentiles(polls[10:]),
        "cycle_close": _percentiles(emulator.cycle_times[10:]),
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
    args = parser.parse_args()
    results = [
        bench(r, args.cycles, args.rate)
        for r in args.robot or ["smartpal5", "seednoid", "pa10", "rh"]
    ]
    header = f"{'robot':10} {'drives':>6} {'buses':>5} {'poll mean/p99 [µs]':>20}"
    print(header + f" {'close mean/p99 [µs]':>20} budget")
    for r in results:
        poll, close = r["poll"], r["cycle_close"]
        assert isinstance(poll, dict) and isinstance(close, dict)
        print(
            f"{r['robot']:10} {r['drives']:>6} {r['buses']:>5} "
            f"{poll['mean_us']:>9.0f} / {poll['p99_us']:<8.0f} {close['mean_us']:>9.0f} / "
            f"{close['p99_us']:<8.0f} {r['budget_us']:.0f} µs"
        )
    print(json.dumps({"bench": "emulator_per_sync", "results": results}))


if __name__ == "__main__":
    main()
