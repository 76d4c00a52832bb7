#!/usr/bin/env python3
"""HIL benchmark: motion core + CAN backend + drive emulator at a fixed rate.

Usage: python tools/bench_hil.py [--robot smartpal5] [--rate 500] [--seconds 60]
                                 [--emulator process|thread] [--drives PATH] [--no-realtime]

``--hal hil`` exactly as the daemon builds it (:func:`hal.factory.make_hardware`). By default
the emulator is its own process (``imotion-sim`` on ``unix`` buses, :mod:`hal.hil`): the
master runs as on real buses, no lockstep, supervision on its own timing; ``--emulator
thread`` puts it in this process in lockstep (one GIL for both). The loop runs the motion mix
of tools/bench_loop.py (hand lines, elbow swings, joint PTP, waist bend, vehicle out and
back). Prints cycle compute time (p50/p99/max, read + QP + write), wake latency, deadline
misses (overruns), alarms, frames per second and load per bus (worst-case bit lengths of the
frames actually sent and received), the master's own share per cycle (``read()`` +
``write()``: thread CPU time, i.e. encode, send, receive, decode, supervision without the
waits; and wall time, waits included), the load average, and as the last line a JSON object.
``--drives`` runs another drive profile (e.g. a bus split for 1 kHz).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

import numpy as np  # noqa: E402
from bench_loop import script  # noqa: E402

from controller.control.core import MotionCore  # noqa: E402
from controller.control.loop import FixedRateLoop  # noqa: E402
from controller.model.robot import load_robot  # noqa: E402
from controller.motion.motions import Motion  # noqa: E402
from controller.vocabulary import CoreState  # noqa: E402
from hal.can.backend import CanBackend  # noqa: E402
from hal.factory import make_hardware  # noqa: E402
from hal.interface import JointCommand, JointState  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="smartpal5")
    parser.add_argument("--rate", type=float, default=500.0)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--emulator", choices=("process", "thread"), default="process")
    parser.add_argument("--drives", help="another drive profile (default: the robot's)")
    parser.add_argument("--emulator-priority", type=int, default=None,
                        help="SCHED_FIFO priority of the emulator process's thread "
                             "(default: 70 with realtime, else 0)")  # fmt: skip
    parser.add_argument("--no-realtime", action="store_true", help="skip SCHED_FIFO etc.")
    parser.add_argument("--switch-interval", type=float, default=1e-4,
                        help="sys.setswitchinterval [s]")  # fmt: skip
    args = parser.parse_args()
    sys.setswitchinterval(args.switch_interval)

    robot = load_robot(args.robot)
    dt = 1.0 / args.rate
    options: dict[str, object] = {"emulator": args.emulator}
    priority = args.emulator_priority
    if priority is None:
        priority = 0 if args.no_realtime else 70  # below the loop's SCHED_FIFO 80
    if args.emulator == "process":
        options["emulator_priority"] = priority
    if args.drives:
        options["drives"] = args.drives
    hw = make_hardware("hil", robot, dt, options)
    assert isinstance(hw, CanBackend)
    master_cpu: list[float] = []
    master_wall: list[float] = []
    timing = {"cpu": 0.0, "wall": 0.0}
    read, write = hw.read, hw.write

    def timed_read() -> JointState:
        c, w = time.thread_time(), time.perf_counter()
        state = read()
        timing["cpu"], timing["wall"] = time.thread_time() - c, time.perf_counter() - w
        return state

    def timed_write(command: JointCommand) -> None:
        c, w = time.thread_time(), time.perf_counter()
        write(command)
        master_cpu.append(timing["cpu"] + time.thread_time() - c)
        master_wall.append(timing["wall"] + time.perf_counter() - w)

    hw.read = timed_read  # type: ignore[method-assign]
    hw.write = timed_write  # type: ignore[method-assign]
    core = MotionCore(robot, hw, dt)
    # Configure now; servo on from inside the running loop, as the daemon does: enabled
    # drives expect the cycle's heartbeat (a loop that stalls lets them time out and stop).
    hw.configure()
    mix = script(core)
    done = {"motions": 0, "skipped": 0, "next": 0}
    ready: list[Motion] = []
    finished = threading.Event()

    def planner() -> None:
        while not finished.is_set():
            if not ready and core.state == CoreState.READY and core.motion is None:
                core.planning_kinematics()
                motion = mix[done["next"] % len(mix)](core)
                done["next"] += 1
                if motion is None:
                    done["skipped"] += 1
                else:
                    ready.append(motion)
            time.sleep(0.001)

    def step(cycle: int, t: float) -> bool:
        if cycle == 1:
            core.servo_on()
        core.cycle()
        if ready and core.state == CoreState.READY and core.motion is None:
            core.start(ready.pop())
            done["motions"] += 1
        return core.state != CoreState.ALARM

    thread = threading.Thread(target=planner, daemon=True)
    thread.start()
    bits0, sent0, recv0 = dict(hw.bits), dict(hw.frames_sent), dict(hw.frames_received)
    loop = FixedRateLoop(
        args.rate, step, realtime=not args.no_realtime,
        stats_capacity=int(args.rate * args.seconds) + 10,
    )  # fmt: skip
    start = time.monotonic()
    loop.run(max_cycles=int(args.rate * args.seconds))
    elapsed = time.monotonic() - start
    finished.set()
    thread.join()
    stats = loop.stats.summary()
    buses = {}
    for name, cfg in hw.profile.buses.items():
        frames = hw.frames_sent[name] - sent0[name] + hw.frames_received[name] - recv0[name]
        bits = hw.bits[name] - bits0[name]
        buses[name] = {
            "frames_per_s": round(frames / elapsed, 1),
            "load_percent": round(100.0 * bits / elapsed / cfg.bitrate, 2),
        }
    hw.shutdown()
    load = os.getloadavg()
    skip = int(args.rate)  # the first second: set-up, enabling
    cpu = np.array(master_cpu[skip:] or [0.0]) * 1e6
    wall = np.array(master_wall[skip:] or [0.0]) * 1e6
    master = {
        "master_cpu_us_p50": round(float(np.percentile(cpu, 50)), 1),
        "master_cpu_us_p99": round(float(np.percentile(cpu, 99)), 1),
        "master_wall_us_p50": round(float(np.percentile(wall, 50)), 1),
        "master_wall_us_p99": round(float(np.percentile(wall, 99)), 1),
    }
    print(
        f"HIL {args.robot}, {args.rate:g} Hz, {args.seconds:g} s, {len(buses)} buses, "
        f"emulator {args.emulator}, "
        f"{done['motions']} motions ({done['skipped']} skipped), state {core.state.value}"
    )
    for name in ("compute_us", "wake_latency_us"):
        print(
            f"{name:16s} p50 {stats[f'{name}_p50']:8.1f}  p99 {stats[f'{name}_p99']:8.1f}  "
            f"max {stats[f'{name}_max']:8.1f}"
        )
    print(
        f"cycles {stats['cycles']}, deadline misses (overruns) {stats['overruns']}, "
        f"late by > half a period {stats['late_by_more_than_half_period']}, "
        f"lockstep timeouts {hw.lockstep_timeouts}"
    )
    print(
        f"master read+write per cycle: CPU p50 {master['master_cpu_us_p50']:.1f} "
        f"p99 {master['master_cpu_us_p99']:.1f} us; wall p50 {master['master_wall_us_p50']:.1f} "
        f"p99 {master['master_wall_us_p99']:.1f} us"
    )
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} ({os.cpu_count()} CPUs)")
    for name, figures in buses.items():
        print(f"bus {name:15s} {figures['frames_per_s']:8.1f} frames/s  "
              f"{figures['load_percent']:5.1f} % load")  # fmt: skip
    if core.alarms:
        print(f"alarms: {core.alarms}")
    result = {
        "robot": args.robot,
        "rate_hz": args.rate,
        "emulator": args.emulator,
        "emulator_priority": priority if args.emulator == "process" else None,
        "drives": args.drives,
        "load_average": [round(x, 2) for x in load],
        **master,
        "seconds": args.seconds,
        "motions": done["motions"],
        "alarms": len(core.alarms),
        "lockstep_timeouts": hw.lockstep_timeouts,
        "buses": buses,
        **stats,
    }
    print(json.dumps(result))
    return 0 if not core.alarms else 1


if __name__ == "__main__":
    sys.exit(main())
