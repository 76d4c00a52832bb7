#!/usr/bin/env python3
"""Per-cycle cost of the CAN master alone: no emulator, drives answering precomputed frames.

The backend (:class:`hal.can.backend.CanBackend`, exactly as ``--hal can`` builds it) runs on
stub buses (:class:`hal.can.stub_bus.StubDrivesBus`, one per profile bus) that answer each
SYNC with every drive's TPDO1 (+TPDO2) built once, so what is measured is the master's own
work: encode (joint set-points -> counts, RPDO1 packing), send, receive, decode (TPDOs ->
SI joint state, vehicle odometry), supervision (TPDO/heartbeat timeouts, drive states,
following error). The stub's own cost (a python-can bus that appends to and pops from a
deque) is inside send and receive; real interfaces cost more there (a system call per
frame on SocketCAN).

The command is a slow sine on every joint (counts change every cycle). Reported [µs]: the
whole cycle (``read()`` + ``write()``, as the control loop calls them) p50/p99/max/mean, and
the median (and mean) of each phase from a second, instrumented pass. Usage::

    python tools/bench_can_master.py [--robot smartpal5] [--rate 500] [--cycles 20000] [--paced]
                                     [--messages]
    python tools/bench_can_master.py --hil [--seconds 10] [--drives PATH]

The stubs take and answer whole ``unix`` records (:class:`StubRecordBus`, the master's
compiled record path of ``--hal hil``); ``--messages``: python-can frames one by one
(:class:`StubDrivesBus`, the path of SocketCAN; also what runs without numba).

``--paced``: one cycle per period, sleeping in between as a control loop does (back to back
by default): on this VM a cycle after a sleep costs more (caches cold; SmartPal V 171 µs
against 136 back to back in the same minutes, docs/emulator.md "Cost").

``--hil``: the same backend on ``unix`` buses against the drive emulator process, as
``--hal hil`` builds it (:mod:`hal.hil`), paced at the rate (the emulator needs its period),
emulator SCHED_FIFO 70 and this thread 80 where allowed. Reported: the thread CPU time
[µs] of ``read()``, ``write()`` and both per cycle (the transport's system calls included,
the waits not), and the same per phase on every other cycle: what the master costs on a
transport between processes, beside the stub's figure. Prints figures and a final JSON
line. :func:`measure_master` and :func:`measure_master_hil` are the measurements as
functions (e.g. for tools/bench_hil.py).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from controller.model import jit  # noqa: E402
from controller.model.robot import load_robot  # noqa: E402
from hal.can.backend import CanBackend  # noqa: E402
from hal.can.drive_profile import drives_path, load_drive_profile  # noqa: E402
from hal.can.stub_bus import StubDrivesBus, StubRecordBus  # noqa: E402
from hal.interface import HardwareState, JointCommand  # noqa: E402

#: Amplitude [rad] or [m] of the commanded sine (within the following window of every drive).
AMPLITUDE = 0.002
PHASES = ("encode", "send", "receive", "decode", "supervision")


def _stats(ns: list[int]) -> dict[str, float]:
    us = np.array(ns, dtype=float) / 1e3
    return {
        "p50_us": round(float(np.percentile(us, 50)), 1),
        "p99_us": round(float(np.percentile(us, 99)), 1),
        "max_us": round(float(us.max()), 1),
        "mean_us": round(float(us.mean()), 1),
    }


class CycleClock:
    """The backend's clock [s]: moves one period per cycle (:meth:`step`), so heartbeat and
    TPDO supervision see the loop's time however the host stalls the benchmark."""

    def __init__(self, dt: float):
        self.dt = dt
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t

    def step(self) -> None:
        self.t += self.dt


def stub_backend(
    robot_id: str = "smartpal5", rate: float = 500.0, records: bool = True
) -> CanBackend:
    """A configured, active CanBackend of ``robot_id`` on stub buses (module doc); its clock
    is a :class:`CycleClock` (``backend._clock``). ``records``: the stubs take and answer
    whole ``unix`` records (:class:`StubRecordBus`, the path of ``unix`` buses), else
    python-can messages frame by frame (:class:`StubDrivesBus`, the path of SocketCAN);
    records need the compiled kernels (without them the master reads frames)."""
    records = records and jit.available()
    robot = load_robot(robot_id)
    profile = load_drive_profile(drives_path(robot), robot)
    dt = 1.0 / rate
    every = max(1, round(profile.heartbeat.drive_producer_ms / 1e3 / dt))
    buses = {}
    for name in profile.buses:
        drives = list(profile.drives_on(name).values())
        buses[name] = (StubRecordBus if records else StubDrivesBus)(
            name,
            [d.node_id for d in drives],
            [d.velocity_feedback for d in drives],
            heartbeat_every=every,
        )
    clock = CycleClock(dt)

    def sleep(_seconds: float) -> None:
        clock.step()

    backend = CanBackend(
        robot, dt, profile, bus_factory=lambda name, _kw: buses[name], clock=clock, sleep=sleep
    )
    backend.configure()
    backend.read()
    backend.activate()
    return backend


def _phases(
    backend: CanBackend,
    command: np.ndarray,
    ns: dict[str, list[int]],
    clock: Callable[[], int] = time.perf_counter_ns,
) -> None:
    """One cycle as read() + write() do it, each phase timed with ``clock`` [ns] (the
    backend's own steps; ``receive`` waits up to the backend's ``feedback_wait``)."""
    io, joints = backend.io, backend.joints
    t0 = clock()
    io.clear_fresh()
    now = backend._clock()
    io.receive(now + backend.feedback_wait if backend.feedback_wait > 0 else None)
    t1 = clock()
    io.decode_states()
    joints.update(io.position, io.velocity, io.fresh, io.seen)
    backend._pending = False
    t2 = clock()
    backend._check(now)
    t3 = clock()
    joints.command(command, io.target)
    backend._checked[:] = joints.target
    t4 = clock()
    io.send()
    io.send_heartbeat(backend._clock())
    backend._pending = True
    t5 = clock()
    for name, a, b in (
        ("receive", t0, t1), ("decode", t1, t2), ("supervision", t2, t3),
        ("encode", t3, t4), ("send", t4, t5),
    ):  # fmt: skip
        ns[name].append(b - a)


def measure_master(
    robot_id: str = "smartpal5",
    rate: float = 500.0,
    cycles: int = 20000,
    warmup: int = 500,
    paced: bool = False,
    records: bool = True,
) -> dict[str, object]:
    """The CAN master's per-cycle cost [µs] for ``robot_id`` at ``rate`` [Hz], measured alone
    on stub buses (module doc): ``cycle`` (read + write) statistics, per-phase p50 and mean, drive
    and bus counts, load average. Runs ``warmup`` + ``cycles`` cycles twice, back to back
    (no sleeping: the cost, not the rate; the backend's clock moves one period per cycle), or
    with ``paced`` one cycle per period as a control loop runs them (sleeping in between:
    what a cycle costs with the caches as the sleep left them). ``records``: as
    :func:`stub_backend`."""
    backend = stub_backend(robot_id, rate, records)
    tick = backend._clock.step  # type: ignore[attr-defined]
    deadline = [time.monotonic()]

    def step() -> None:
        tick()
        if paced:
            deadline[0] += backend.dt
            left = deadline[0] - time.monotonic()
            if left > 0:
                time.sleep(left)

    try:
        base = backend.read().position.copy()
        phase = np.linspace(0.0, 2.0 * np.pi, len(base), endpoint=False)
        dt = backend.dt
        total: list[int] = []
        clock = time.perf_counter_ns
        for k in range(warmup + cycles):
            command = JointCommand(base + AMPLITUDE * np.sin(2.0 * np.pi * 0.5 * k * dt + phase))
            t0 = clock()
            backend.read()
            backend.write(command)
            t1 = clock()
            step()
            if k >= warmup:
                total.append(t1 - t0)
        ns: dict[str, list[int]] = {name: [] for name in PHASES}
        for k in range(warmup + cycles):
            command_array = base + AMPLITUDE * np.sin(2.0 * np.pi * 0.5 * k * dt + phase)
            with backend._lock:
                _phases(backend, command_array, ns)
            step()
            if k < warmup:
                for values in ns.values():
                    values.clear()
        if backend.state is not HardwareState.ACTIVE or backend.faults():
            raise RuntimeError(f"the master left ACTIVE: {backend.faults()}")
        return {
            "robot": robot_id,
            "rate_hz": rate,
            "drives": len(backend.drive_names),
            "buses": len(backend.profile.buses),
            "cycles": cycles,
            "paced": paced,
            "path": "records" if records and backend.io.compiled else "messages",
            "compiled": backend.io.compiled,
            "cycle": _stats(total),
            "phases_p50_us": {
                name: round(float(np.percentile(v, 50)) / 1e3, 1) for name, v in ns.items()
            },
            "phases_mean_us": {name: round(float(np.mean(v)) / 1e3, 1) for name, v in ns.items()},
            "frames_per_cycle": round(
                (sum(backend.frames_sent.values()) + sum(backend.frames_received.values()))
                / max(1, sum(backend.syncs_sent.values()) / len(backend.profile.buses)),
                1,
            ),
            "loadavg": [round(x, 2) for x in os.getloadavg()],
        }
    finally:
        backend.shutdown()


def measure_master_hil(
    robot_id: str = "smartpal5",
    rate: float = 500.0,
    seconds: float = 10.0,
    drives: str | None = None,
    warmup: float = 1.0,
) -> dict[str, object]:
    """The master's thread CPU time per cycle [µs] on ``unix`` buses against the emulator
    process (module doc), over ``seconds`` after ``warmup`` [s]; read, write, cycle stats."""
    from hal.factory import make_hardware

    robot = load_robot(robot_id)
    dt = 1.0 / rate
    options: dict[str, object] = {"emulator": "process", "emulator_priority": 70}
    if drives:
        options["drives"] = drives
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(80))
        realtime = True
    except (AttributeError, OSError):
        options["emulator_priority"] = 0
        realtime = False
    backend = make_hardware("hil", robot, dt, options)
    assert isinstance(backend, CanBackend)
    reads: list[int] = []
    writes: list[int] = []
    ns: dict[str, list[int]] = {name: [] for name in PHASES}
    try:
        backend.configure()
        backend.read()
        backend.activate()
        base = backend.read().position.copy()
        phase = np.linspace(0.0, 2.0 * np.pi, len(base), endpoint=False)
        clock = time.thread_time_ns
        skip = int(warmup * rate)
        deadline = time.monotonic()
        for k in range(skip + int(seconds * rate)):
            deadline += dt
            left = deadline - time.monotonic()
            if left > 0:
                time.sleep(left)
            command_array = base + AMPLITUDE * np.sin(2.0 * np.pi * 0.5 * k * dt + phase)
            if k % 2:  # every other cycle: phase by phase (the same steps)
                with backend._lock:
                    _phases(backend, command_array, ns, clock)
                if k < skip:
                    for values in ns.values():
                        values.clear()
                continue
            command = JointCommand(command_array)
            t0 = clock()
            backend.read()
            t1 = clock()
            backend.write(command)
            t2 = clock()
            if k >= skip:
                reads.append(t1 - t0)
                writes.append(t2 - t1)
        state, faults = backend.state, backend.faults()
    finally:
        backend.shutdown()
        if realtime:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    if state is not HardwareState.ACTIVE or faults:
        raise RuntimeError(f"the master left ACTIVE: {faults}")
    return {
        "robot": robot_id,
        "rate_hz": rate,
        "transport": "unix",
        "drives": len(backend.drive_names),
        "buses": len(backend.profile.buses),
        "cycles": len(reads),
        "realtime": realtime,
        "cpu_cycle": _stats([r + w for r, w in zip(reads, writes, strict=True)]),
        "cpu_read": _stats(reads),
        "cpu_write": _stats(writes),
        "cpu_phases_p50_us": {
            name: round(float(np.percentile(v, 50)) / 1e3, 1) for name, v in ns.items()
        },
        "cpu_phases_mean_us": {name: round(float(np.mean(v)) / 1e3, 1) for name, v in ns.items()},
        "loadavg": [round(x, 2) for x in os.getloadavg()],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="smartpal5")
    parser.add_argument("--rate", type=float, default=500.0, help="[Hz] loop rate (the period)")
    parser.add_argument("--cycles", type=int, default=20000)
    parser.add_argument("--hil", action="store_true", help="unix buses, emulator process")
    parser.add_argument("--paced", action="store_true",
                        help="stub buses: one cycle per period (sleeping in between)")  # fmt: skip
    parser.add_argument("--messages", action="store_true",
                        help="stub buses: python-can messages frame by frame (SocketCAN's "
                        "path), not unix records")  # fmt: skip
    parser.add_argument("--seconds", type=float, default=10.0, help="--hil: run time [s]")
    parser.add_argument("--drives", help="--hil: another drive profile")
    args = parser.parse_args()
    if args.hil:
        hil = measure_master_hil(args.robot, args.rate, args.seconds, args.drives)
        print(
            f"CAN master on unix buses against the emulator process: {args.robot}, "
            f"{hil['drives']} drives on {hil['buses']} buses, {args.rate:g} Hz, "
            f"{hil['cycles']} cycles, SCHED_FIFO {'on' if hil['realtime'] else 'off'}"
        )
        for name in ("cpu_cycle", "cpu_read", "cpu_write"):
            figures = hil[name]
            assert isinstance(figures, dict)
            print(f"{name:9s} thread CPU [µs]: p50 {figures['p50_us']:.1f}  "
                  f"p99 {figures['p99_us']:.1f}  mean {figures['mean_us']:.1f}")  # fmt: skip
        phases = hil["cpu_phases_p50_us"]
        assert isinstance(phases, dict)
        print("phases, thread CPU p50 [µs]: "
              + "  ".join(f"{k} {v:.1f}" for k, v in phases.items()))  # fmt: skip
        print(f"load average {hil['loadavg']} (2 cores, shared)")
        print(json.dumps(hil))
        return 0
    result = measure_master(
        args.robot, args.rate, args.cycles, paced=args.paced, records=not args.messages
    )
    cycle = result["cycle"]
    phases = result["phases_p50_us"]
    assert isinstance(cycle, dict) and isinstance(phases, dict)
    print(
        f"CAN master alone: {args.robot}, {result['drives']} drives on {result['buses']} buses, "
        f"{args.rate:g} Hz period, {args.cycles} cycles "
        f"{'paced (one per period)' if args.paced else 'back to back'}, stub buses "
        f"({result['frames_per_cycle']} frames per cycle, {result['path']}, "
        f"{'compiled' if result['compiled'] else 'NumPy'})"
    )
    print(
        f"cycle (read + write) [µs]: p50 {cycle['p50_us']:.1f}  p99 {cycle['p99_us']:.1f}  "
        f"max {cycle['max_us']:.1f}  mean {cycle['mean_us']:.1f}"
    )
    print("phases, p50 [µs]: " + "  ".join(f"{k} {v:.1f}" for k, v in phases.items()))
    print(f"load average {result['loadavg']} (2 cores, shared)")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
