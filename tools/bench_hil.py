#!/usr/bin/env python3
"""HIL benchmark: motion core + CAN backend + drive emulator at a fixed rate.

Usage: python tools/bench_hil.py [--robot smartpal5] [--rate 500 | --rates 1000,800,625,500]
                                 [--seconds 60] [--floor-seconds S]
                                 [--emulator process|thread] [--drives PATH]
                                 [--planner process|thread] [--gc slack|automatic]
                                 [--planner-priority 50] [--no-realtime]
                                 [--spin-us US] [--trace-out cycles.npz]

``--hal hil`` exactly as the daemon builds it (:func:`hal.factory.make_hardware`). By
default the emulator is its own process (``imotion-sim`` on ``unix`` buses, :mod:`hal.hil`):
the master runs as on real buses, no lockstep, supervision on its own timing; ``--emulator
thread`` puts it in this process in lockstep (one GIL for both). The loop runs the motion
mix of tools/loop_mix.py (hand lines, elbow swings, joint PTP, waist bend, vehicle out and
back, arms close), planned in a planning thread as the daemon's gateway plans them (the
specs it would send) and each started as the control process starts a command
(:mod:`controller.control.pending_start`: accepted in a step, built in its slack, started in
the next step). Prints cycle
compute time (p50/p99/max, read + QP + write), wake latency, deadline misses (overruns),
alarms, frames per second and load per bus (worst-case bit lengths of the frames actually
sent and received), the master's own share per cycle (``read()`` + ``write()``: thread CPU
time, i.e. encode, send, receive, decode, supervision without the waits; and wall time,
waits included), the CPU time per cycle of the emulator process and of this process (all
threads), the load average, the garbage collections of both processes, one row per overrun
with what it was made of and its cause (:mod:`overrun_trace`: gc, TPDO wait, off CPU,
steal, late wake, slow CPU, own CPU; steal, late wake and slow CPU are the host's, counted
as ``host_overruns``), the steal time of each CPU over the run (``steal_s_per_cpu``, and per
overrun row around its cycle), and as the last line a JSON object. ``--trace-out`` saves
every measured cycle's figures (:meth:`overrun_trace.CycleTrace.save`, for ``perf``).
The first second (servo on: ``activate()`` blocks the loop for its enabling cycles, by
design; the first motion) is a warm-up, reported apart and not counted; it is the same loop
as the measured run (as the daemon runs one loop), the counters put aside in the slack of
its last cycle: a loop started anew after it (the real-time set-up again, 70-130 ms without
a cycle) made the first measured step 2-3 times dearer, cold after the pause, and it
overran now and then (``warmup_seam_periods``: periods between the warm-up's last cycle and
the first measured one, 1 unless that cycle overran). The emulator's collections are
counted from the warm-up on (its ``status`` is a round trip to its process, never asked
while the loop runs). Alarms (FAULT type: the loop stops) and warnings (e.g. a motion that
ended off its target) are counted apart. As in the daemon, the garbage collector runs in
the loop's slack (``--gc automatic``: CPython's own) and the planning of the hand line and
arms close, the only planning that costs milliseconds, runs in a worker process
(``--planner thread``: in the planning thread, sharing the loop's GIL). ``--drives`` runs
another drive profile (e.g. ``config/robots/smartpal5/drives-1khz.yaml``, a bus split for
1 kHz). ``--rates`` runs each rate in turn (a fresh emulator each), prints a summary line per
rate and the highest rate without overruns and alarms; the JSON line then holds every run
(``runs``) and ``highest_clean_rate_hz``. ``--planner-priority`` runs the planning thread
under SCHED_FIFO (below the loop's 80 and the emulator's 70): a planner that the host
deschedules while it holds the GIL stalls the real-time loop for as long. The planning
thread sleeps until the loop finds the robot idle (no polling).

Last, the machine's floor (:mod:`machine_floor`; ``--floor-seconds``, default as long as a
run, 0: none), after the runs, at each run's rate: a bare SCHED_FIFO 80 thread sleeping to
the same deadlines and, with the emulator process under SCHED_FIFO, a second bare one at its
priority in another process at the same time (the real setup has two real-time threads on
this 2-core machine). Each counts its wakes later than the period minus the run's compute
p50 (a wake that late makes a step of median cost overrun), printed beside the run's
overruns and in the JSON line (``floor_late``, ``floor_late_emulator``, ``machine_floor``):
a run's overruns near the floor's count are the host's, not the loop's.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

import machine_floor  # noqa: E402
import numpy as np  # noqa: E402
from loop_mix import WorkerLineCheck, planned_segments  # noqa: E402
from overrun_trace import HOST_CAUSES, CycleTrace, print_overruns  # noqa: E402

from controller.contract.motion_specs import MotionSpec  # noqa: E402
from controller.control.collector import SlackCollector  # noqa: E402
from controller.control.core import MotionCore  # noqa: E402
from controller.control.loop import FixedRateLoop  # noqa: E402
from controller.control.pending_start import PendingStart  # noqa: E402
from controller.model import jit  # noqa: E402
from controller.model.alarms import AlarmType  # noqa: E402
from controller.model.robot import load_robot  # noqa: E402
from controller.vocabulary import CoreState  # noqa: E402
from hal.can.backend import CanBackend  # noqa: E402
from hal.can.setup import interpolation_period  # noqa: E402
from hal.factory import make_hardware  # noqa: E402
from hal.interface import JointCommand, JointState  # noqa: E402

#: Seconds of cycles before the measured run (module doc).
WARMUP_S = 1.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="smartpal5")
    parser.add_argument("--rate", type=float, default=500.0)
    parser.add_argument("--rates", help="comma-separated rates [Hz], each run in turn")
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--emulator", choices=("process", "thread"), default="process")
    parser.add_argument("--drives", help="another drive profile (default: the robot's)")
    parser.add_argument("--emulator-priority", type=int, default=None,
                        help="SCHED_FIFO priority of the emulator process's thread "
                             "(default: 70 with realtime, else 0)")  # fmt: skip
    parser.add_argument("--no-realtime", action="store_true", help="skip SCHED_FIFO etc.")
    parser.add_argument("--planner-priority", type=int, default=0,
                        help="SCHED_FIFO priority of the planning thread (0: normal)")  # fmt: skip
    parser.add_argument("--planner", choices=("process", "thread"), default="process",
                        help="where the mix's Cartesian moves are planned: a worker "
                             "process, as the daemon's gateway plans (default), or the "
                             "planning thread of this process")  # fmt: skip
    parser.add_argument("--gc", choices=("slack", "automatic"), default="slack",
                        help="garbage collection in the loop's slack as the daemon does "
                             "(default), or CPython's automatic collection")  # fmt: skip
    parser.add_argument("--switch-interval", type=float, default=1e-4,
                        help="sys.setswitchinterval [s]")  # fmt: skip
    parser.add_argument("--spin-us", type=float, default=0.0,
                        help="busy-wait the last microseconds before each deadline, as "
                             "realtime.spin_us in the daemon (the floor's loop thread "
                             "too)")  # fmt: skip
    parser.add_argument("--floor-seconds", type=float, default=None,
                        help="after the runs, the machine's floor at each run's rate "
                             "(tools/machine_floor.py) this long [s] (default: --seconds; "
                             "0: skip)")  # fmt: skip
    parser.add_argument("--trace-out", help="save every measured cycle's figures (.npz)")
    args = parser.parse_args()
    sys.setswitchinterval(args.switch_interval)
    floor_seconds = args.seconds if args.floor_seconds is None else args.floor_seconds
    if not args.rates:
        result = run(args, args.rate)
        if floor_seconds > 0:
            add_floor(result, floor_seconds)
        print(json.dumps(result))
        return 0 if not result["alarms"] else 1
    rates = [float(rate) for rate in args.rates.split(",")]
    for rate in rates:  # the drives' 0x60C2 must hold the period exactly (not 667 Hz)
        try:
            interpolation_period(1.0 / rate)
        except ValueError as exc:
            parser.error(f"--rates: {rate:g} Hz: {exc}")
    runs = [run(args, rate) for rate in rates]
    if floor_seconds > 0:
        for r in runs:
            add_floor(r, floor_seconds)
    print("summary (rate, overruns, machine floor's late wakes (FIFO 80 / 70), alarms, "
          "compute p99, wake p99, master CPU p50, load avg):")  # fmt: skip
    for r in runs:
        print(f"  {r['rate_hz']:7g} Hz  overruns {r['overruns']:6d} / {r['cycles']}  "
              f"floor {_count(r.get('floor_late'))} / {_count(r.get('floor_late_emulator'))}  "
              f"(host's {r['host_overruns']})  "
              f"alarms {r['alarms']}  compute p99 {r['compute_us_p99']:7.1f} us  "
              f"wake p99 {r['wake_latency_us_p99']:7.1f} us  "
              f"master {r['master_cpu_us_p50']:6.1f} us  "
              f"load {r['load_average'][0]:.2f}")  # fmt: skip
    clean = [r["rate_hz"] for r in runs if not r["overruns"] and not r["alarms"]]
    best = max(clean) if clean else None
    print(f"highest rate without overruns and alarms: {f'{best:g} Hz' if best else 'none'}")
    print(json.dumps({"runs": runs, "highest_clean_rate_hz": best}))
    return 0


def run(args: argparse.Namespace, rate: float) -> dict[str, Any]:
    """One run at ``rate`` [Hz] (module doc); prints its figures, returns them."""
    robot = load_robot(args.robot)
    dt = 1.0 / rate
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
    timing = {"cpu": 0.0, "wall": 0.0}
    read, write = hw.read, hw.write
    trace = CycleTrace(int(rate * args.seconds) + 10)

    def timed_read() -> JointState:
        c, w = time.thread_time(), time.perf_counter()
        state = read()
        timing["cpu"], timing["wall"] = time.thread_time() - c, time.perf_counter() - w
        missing = int(hw.io.fresh.size - np.count_nonzero(hw.io.fresh))
        trace.read_done(timing["wall"], timing["cpu"], missing)
        return state

    def timed_write(command: JointCommand) -> None:
        c, w = time.thread_time(), time.perf_counter()
        write(command)
        trace.write_done(time.perf_counter() - w, time.thread_time() - c)

    def timed_sender(send: Any) -> Any:
        def timed_send(record: Any) -> None:
            c, w = time.thread_time(), time.perf_counter()
            send(record)
            trace.sent(time.perf_counter() - w, time.thread_time() - c)

        return timed_send

    hw.read = timed_read  # type: ignore[method-assign]
    hw.write = timed_write  # type: ignore[method-assign]
    core = MotionCore(robot, hw, dt)
    # Configure now; servo on from inside the running loop, as the daemon does: enabled
    # drives expect the cycle's heartbeat (a loop that stalls lets them time out and stop).
    hw.configure()
    for port in hw.io.ports:  # write()'s socket sends, timed apart
        if port.send_record is not None:
            port.send_record = timed_sender(port.send_record)
    line_check = WorkerLineCheck(args.robot, dt) if args.planner == "process" else None
    refused: list[str] = []  # moves of the mix the daemon's planning refused (skipped)
    mix = planned_segments(core, line_check, refused)
    done = {"motions": 0, "skipped": 0, "next": 0, "servo_on": 0}
    ready: list[tuple[str, MotionSpec]] = []
    pending: list[tuple[str, PendingStart]] = []  # accepted, built in the slack, started next
    running = [""]  # the segment whose motion runs: it names the alarms raised meanwhile
    by_segment: list[str] = []  # "segment: code" of every alarm and warning, in order
    finished = threading.Event()
    wanted = threading.Event()  # the robot is idle: the planner plans the next motion

    def planner() -> None:
        if args.planner_priority:  # SCHED_FIFO: not descheduled while it holds the GIL
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.planner_priority))
        while not finished.is_set():
            # Woken by the loop when the robot is idle: a thread of the loop's process that
            # polled would take the GIL a thousand times a second, each time a chance to be
            # descheduled holding it while the loop waits.
            wanted.wait()
            wanted.clear()
            if not ready and core.state == CoreState.READY and core.motion is None:
                trace.planning += 1
                core.planning_kinematics()
                name, make = mix[done["next"] % len(mix)]
                spec = make(core)
                trace.planning += 1
                done["next"] += 1
                if spec is None:
                    done["skipped"] += 1
                else:
                    ready.append((name, spec))

    warm_cycles = int(rate * WARMUP_S)
    seam: dict[str, Any] = {}  # the counters where the measured run begins
    child = getattr(getattr(hw, "emulator", None), "process", None)
    if not isinstance(child, subprocess.Popen):  # (a DriveEmulator's process() is a method)
        child = None
    # The emulator's garbage collections: a round trip to its process, never while the
    # loop runs (its main thread answers holding the emulator's lock): counted from here.
    status0 = emulator_status(hw)

    def step(cycle: int, t: float) -> bool:
        measured = cycle - warm_cycles  # < 0: the warm-up (not recorded)
        if measured <= 0:
            seam["t_first" if measured == 0 else "t_last_warm"] = t
        trace.begin(measured if measured >= 0 else -1)
        if cycle == 1 and not done["servo_on"]:
            done["servo_on"] = 1
            core.servo_on()
        core.cycle()
        if len(core.alarms) > len(by_segment):
            by_segment.extend(
                f"{running[0] or '-'}: 0x{a.code:03X}" for a in core.alarms[len(by_segment) :]
            )
        # As the control process starts a command's motion: accepted after a step's cycle,
        # built from its spec in that step's slack, started after the next step's cycle.
        if pending:
            running[0], accepted = pending.pop()
            if core.state == CoreState.READY and core.motion is None:
                core.start(accepted.take(core.kin, core.dt))
                trace.motion_started()
                done["motions"] += 1
        elif core.state == CoreState.READY and core.motion is None:
            if ready:
                name, spec = ready.pop()
                pending.append((name, PendingStart(spec)))
            elif not wanted.is_set():
                wanted.set()
        trace.end()
        return core.state != CoreState.ALARM

    def slack(ns: int) -> None:
        t0 = time.monotonic_ns()
        if pending and not pending[0][1].built:  # as the daemon's slack builds it
            pending[0][1].build(core.kin, core.dt)
            trace.motion_built()
        if loop.stats.cycles == warm_cycles:  # after the warm-up's last step
            start_measuring()
        else:
            trace.sample_steal()
        if collector is not None:  # what the build left
            collector(ns - (time.monotonic_ns() - t0))

    def start_measuring() -> None:
        """The counters of the warm-up put aside, in the slack of its last step (outside
        every step; cheap reads only)."""
        trace.forget_collections()
        trace.sample_steal(first=True)
        seam.update(
            stats=(loop.stats.overruns, loop.stats.late), bits=dict(hw.bits),
            sent=dict(hw.frames_sent), received=dict(hw.frames_received),
            slack=list(collector.collections) if collector is not None else [0, 0],
            own_cpu=sum(os.times()[:2]), start=time.monotonic(),
            emulator_cpu=process_cpu(child.pid) if child is not None else None,
        )  # fmt: skip

    thread = threading.Thread(target=planner, daemon=True)
    thread.start()
    # One loop for the warm-up (servo on: activate() blocks the loop for its enabling
    # cycles, by design; the first motion) and the measured run, as the daemon runs one: a
    # second loop started after the warm-up (real-time set-up again: mlockall after
    # munlockall, 70-90 ms without cycles) made the first measured step 2-3 times dearer.
    collector = SlackCollector() if args.gc == "slack" else None
    if collector is not None:
        collector.start()
    loop = FixedRateLoop(
        rate, step, realtime=not args.no_realtime,
        stats_capacity=warm_cycles + int(rate * args.seconds) + 10, slack=slack,
        spin_us=args.spin_us,
    )  # fmt: skip
    with jit.compiled_meanwhile() as compiled:  # kernels compiled in the loop: none due
        loop.run(max_cycles=warm_cycles + int(rate * args.seconds))
    if compiled:
        print(f"kernels compiled while the loop ran (their cycles waited): {compiled}")
    if "start" not in seam:  # stopped in the warm-up (an alarm): nothing measured
        start_measuring()
    elapsed = time.monotonic() - seam["start"]
    own_cpu = sum(os.times()[:2]) - seam["own_cpu"]
    emulator_cpu0 = seam["emulator_cpu"]
    emulator_cpu1 = process_cpu(child.pid) if child is not None else None
    emulator_cpu = (
        emulator_cpu1 - emulator_cpu0
        if emulator_cpu0 is not None and emulator_cpu1 is not None
        else None
    )
    if collector is not None:
        collector.stop()
    trace.close()
    # The loop stopped: so did the master's heartbeat. Shut the drives down first (before
    # they time out and fault), then the planner.
    emulator_gc = emulator_status(hw, status0)
    buses = {}
    for name, cfg in hw.profile.buses.items():
        frames = hw.frames_sent[name] - seam["sent"][name]
        frames += hw.frames_received[name] - seam["received"][name]
        bits = hw.bits[name] - seam["bits"][name]
        buses[name] = {
            "frames_per_s": round(frames / elapsed, 1),
            "load_percent": round(100.0 * bits / elapsed / cfg.bitrate, 2),
        }
    hw.shutdown()
    finished.set()
    wanted.set()
    thread.join()
    if line_check is not None:
        line_check.close()
    latency_us, compute_us = loop.stats.latency_us(), loop.stats.compute_us()
    warmup = summary(latency_us[:warm_cycles], compute_us[:warm_cycles], seam["stats"])
    overruns0, late0 = seam["stats"]
    stats = summary(
        latency_us[warm_cycles:],
        compute_us[warm_cycles:],
        (loop.stats.overruns - overruns0, loop.stats.late - late0),
    )
    # The measured run continues the warm-up's loop: its first deadline is a whole number
    # of periods after the warm-up's last one (1 unless that step overran).
    seam_periods = round(
        (seam.get("t_first", math.nan) - seam.get("t_last_warm", math.nan)) / dt, 6
    )
    overruns = trace.overruns(dt, hw.feedback_wait, latency_us[warm_cycles:],
                              compute_us[warm_cycles:])  # fmt: skip
    if args.trace_out:
        trace.save(args.trace_out, latency_us[warm_cycles:], compute_us[warm_cycles:])
    load = os.getloadavg()
    measured = max(1, min(int(stats["cycles"]), trace.capacity))
    cpu = trace.master_cpu[:measured] * 1e6
    wall = trace.master_wall[:measured] * 1e6
    master = {
        "master_cpu_us_p50": round(float(np.percentile(cpu, 50)), 1),
        "master_cpu_us_p99": round(float(np.percentile(cpu, 99)), 1),
        "master_wall_us_p50": round(float(np.percentile(wall, 50)), 1),
        "master_wall_us_p99": round(float(np.percentile(wall, 99)), 1),
        # write()'s socket sends (one record per bus), wall time per cycle
        "send_us_p50": round(float(np.percentile(trace.send_wall[:measured], 50)) * 1e6, 1),
        "send_us_p99": round(float(np.percentile(trace.send_wall[:measured], 99)) * 1e6, 1),
        "send_us_max": round(float(trace.send_wall[:measured].max()) * 1e6, 1),
        "sends_over_400us": int(np.count_nonzero(trace.send_wall[:measured] > 400e-6)),
    }
    steal = trace.steal_total()
    cycles = max(1, int(stats["cycles"]))
    cpu_share = {
        "process_cpu_us_per_cycle": round(own_cpu / cycles * 1e6, 1),
        "emulator_cpu_us_per_cycle": (
            round(emulator_cpu / cycles * 1e6, 1) if emulator_cpu is not None else None
        ),
    }
    alarms = [a for a in core.alarms if a.type == AlarmType.FAULT]
    warnings = [a for a in core.alarms if a.type != AlarmType.FAULT]
    print(
        f"HIL {args.robot}, {rate:g} Hz, {args.seconds:g} s, {len(buses)} buses, "
        f"emulator {args.emulator}, "
        f"{done['motions']} motions ({done['skipped']} skipped), state {core.state.value}"
    )
    for name in ("compute_us", "wake_latency_us"):
        print(
            f"{name:16s} p50 {stats[f'{name}_p50']:8.1f}  p99 {stats[f'{name}_p99']:8.1f}  "
            f"max {stats[f'{name}_max']:8.1f}"
        )
    print(
        f"warm-up {WARMUP_S:g} s (servo on, first motion; not counted): overruns "
        f"{warmup['overruns']}, compute max {warmup['compute_us_max']:.0f} us; the "
        f"measured run continues its loop ({seam_periods:g} period(s) after its last cycle)"
    )
    print(
        f"cycles {stats['cycles']}, deadline misses (overruns) {stats['overruns']}, "
        f"late by > half a period {stats['late_by_more_than_half_period']}, "
        f"lockstep timeouts {hw.lockstep_timeouts}"
    )
    print(
        f"master read+write per cycle: CPU p50 {master['master_cpu_us_p50']:.1f} "
        f"p99 {master['master_cpu_us_p99']:.1f} us; wall p50 {master['master_wall_us_p50']:.1f} "
        f"p99 {master['master_wall_us_p99']:.1f} us; write()'s socket sends (a record per bus) "
        f"p50 {master['send_us_p50']:.1f} p99 {master['send_us_p99']:.1f} max "
        f"{master['send_us_max']:.0f} us, over 0.4 ms in {master['sends_over_400us']} cycles"
    )
    emulator_text = (
        f"{cpu_share['emulator_cpu_us_per_cycle']:.1f}" if emulator_cpu is not None else "-"
    )
    own = cpu_share["process_cpu_us_per_cycle"]
    print(f"CPU per cycle [us]: this process (loop, master, planner) {own:.1f}, "
          f"emulator process {emulator_text}")  # fmt: skip
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} ({os.cpu_count()} CPUs); "
          f"steal time (the hypervisor's) per CPU over the run: "
          f"{', '.join(f'{x * 1e3:.0f}' for x in steal)} ms")  # fmt: skip
    for name, figures in buses.items():
        print(f"bus {name:15s} {figures['frames_per_s']:8.1f} frames/s  "
              f"{figures['load_percent']:5.1f} % load")  # fmt: skip
    gc_figures = {
        "gc": args.gc,
        "gc_in_slack": (
            [a - b for a, b in zip(collector.collections, seam["slack"], strict=True)]
            if collector is not None
            else None
        ),
        "gc_collections": trace.gc_counts,
        "gc_total_ms": round(trace.gc_total * 1e3, 1),
        "gc_longest_ms": round(trace.gc_longest * 1e3, 2),
        "gc_longest_generation": trace.gc_longest_generation,
    }
    if collector is not None:
        print(f"garbage collection in the loop's slack (--gc slack, as the daemon): "
              f"{gc_figures['gc_in_slack']} young/middle collections run by the loop")  # fmt: skip
    print(f"garbage collections in this process: {trace.gc_counts} (generations 0/1/2), "
          f"{gc_figures['gc_total_ms']:.1f} ms in all, longest {gc_figures['gc_longest_ms']:.2f} "
          f"ms (generation {trace.gc_longest_generation})")  # fmt: skip
    if emulator_gc:
        print(f"garbage collections in the emulator process: {emulator_gc['gc_collections']}, "
              f"{emulator_gc['gc_total_ms']:.1f} ms in all, longest "
              f"{emulator_gc['gc_longest_ms']:.2f} ms (counts from the warm-up on, longest over "
              f"its life)")  # fmt: skip
    if by_segment:
        print("alarms and warnings by segment of the mix: " + ", ".join(by_segment))
    if refused:
        print(f"skipped (refused by the planning): {len(refused)}; first: {refused[0]}")
    causes = print_overruns(overruns)
    for name, found in (("alarms", alarms), ("warnings", warnings)):
        if found:
            print(f"{name}: " + "; ".join(f"0x{a.code:03X} {a.description}" for a in found))
    result = {
        "robot": args.robot,
        "rate_hz": rate,
        "spin_us": args.spin_us,
        "emulator": args.emulator,
        "emulator_priority": priority if args.emulator == "process" else None,
        "planner": args.planner,
        "drives": args.drives,
        "load_average": [round(x, 2) for x in load],
        **master,
        **cpu_share,
        "seconds": args.seconds,
        "motions": done["motions"],
        "refused": refused[:10],
        "alarms_by_segment": by_segment[:50],
        "alarms": len(alarms),
        "warnings": len(warnings),
        "lockstep_timeouts": hw.lockstep_timeouts,
        "buses": buses,
        **gc_figures,
        "emulator_gc": emulator_gc,
        "overrun_causes": causes,
        "host_overruns": sum(causes[c] for c in HOST_CAUSES),
        "steal_s_per_cpu": steal,
        "compiled_in_loop": compiled,
        "warmup_overruns": warmup["overruns"],
        "warmup_compute_us_max": warmup["compute_us_max"],
        "warmup_seam_periods": seam_periods,
        "overrun_cycles": overruns[:100],
        **stats,
    }
    return result


def add_floor(result: dict[str, Any], seconds: float) -> None:
    """The machine's floor for the run ``result`` (module doc), measured now for
    ``seconds`` [s] at its rate: a bare SCHED_FIFO 80 thread, and with an emulator process
    under SCHED_FIFO a second one at its priority in another process, at the same time.
    Each counts its wakes later than the period minus the run's compute p50 (a wake that
    late makes a step of median cost overrun). Adds ``machine_floor``, ``floor_late`` and
    ``floor_late_emulator`` (None without a second thread) to ``result`` and prints them
    beside the run's overruns."""
    rate = float(result["rate_hz"])
    compute = float(result["compute_us_p50"])
    threshold = 1e6 / rate - (compute if math.isfinite(compute) else 0.0)
    priorities = [machine_floor.LOOP_PRIORITY]
    second = result["emulator"] == "process" and bool(result["emulator_priority"])
    if second:
        priorities.append(int(result["emulator_priority"]))
    spin = float(result.get("spin_us", 0.0))
    floors = machine_floor.measure_together(rate, seconds, priorities, threshold, spin)
    result["machine_floor"] = {
        "seconds": seconds,
        "threshold_us": round(threshold, 1),
        "loop": floors[0],
        "emulator": floors[1] if second else None,
    }
    result["floor_late"] = floors[0].get("late_past_threshold")
    result["floor_late_emulator"] = floors[1].get("late_past_threshold") if second else None
    text = (
        f"{_count(result['floor_late'])} wakes later than {threshold:.0f} us (period - compute "
        f"p50) of a bare SCHED_FIFO {priorities[0]} thread (wake p99 "
        f"{floors[0].get('wake_p99_us')} us, max {floors[0].get('wake_max_us')} us)"
    )
    if second:
        text += (
            f", {_count(result['floor_late_emulator'])} of a second one at {priorities[1]} in "
            f"another process (the emulator's; wake p99 {floors[1].get('wake_p99_us')} us)"
        )
    print(
        f"{result['rate_hz']:g} Hz: overruns {result['overruns']} / {result['cycles']}; the "
        f"machine's floor for {seconds:g} s after it: {text}"
    )


def _count(value: object) -> str:
    return "-" if value is None else str(value)


def summary(
    latency_us: np.ndarray, compute_us: np.ndarray, counts: tuple[int, int]
) -> dict[str, Any]:
    """The loop's figures over some of its cycles, as :meth:`LoopStats.summary` gives them
    for all: wake latency and compute time [µs] (p50, p99, max; NaN without cycles) and
    ``counts``, their (overruns, late by more than half a period)."""
    out: dict[str, Any] = {"cycles": int(compute_us.size), "overruns": int(counts[0]),
                           "late_by_more_than_half_period": int(counts[1])}  # fmt: skip
    for name, values in (("compute_us", compute_us), ("wake_latency_us", latency_us)):
        p50, p99, top = (
            (float(np.percentile(values, q)) for q in (50, 99, 100))
            if values.size
            else (math.nan,) * 3
        )
        out.update({f"{name}_p50": p50, f"{name}_p99": p99, f"{name}_max": top})
    return out


def emulator_status(hw: CanBackend, since: dict[str, Any] | None = None) -> dict[str, Any]:
    """The emulator process's garbage collections (its ``status``): counts per generation
    and total [ms] since ``since`` (an earlier answer), longest [ms] over its life; {} for
    an emulator in this process."""
    command = getattr(hw.emulator, "command", None)
    if command is None:
        return {}
    words = dict(w.split("=", 1) for w in command("status").split()[1:] if "=" in w)
    if "gc" not in words:
        return {}
    counts = [int(n) for n in words["gc"].split("/")]
    total = float(words["gc_ms"])
    if since:
        counts = [a - b for a, b in zip(counts, since["gc_collections"], strict=True)]
        total -= since["gc_total_ms"]
    return {"gc_collections": counts, "gc_total_ms": round(total, 1),
            "gc_longest_ms": float(words["gc_max_ms"])}  # fmt: skip


def process_cpu(pid: int) -> float | None:
    """User + system CPU time [s] of process ``pid`` so far (Linux /proc), None if unknown."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


if __name__ == "__main__":
    sys.exit(main())
