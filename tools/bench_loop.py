#!/usr/bin/env python3
"""Closed-loop benchmark: the motion core on MuJoCo at a fixed rate, running a scripted mix.

Usage: python tools/bench_loop.py [--robot smartpal5] [--rate 1000] [--seconds 60]
                                  [--runs 1] [--no-realtime] [--no-breakdown]
                                  [--planner process|thread] [--gc slack|automatic]
                                  [--spread-seconds 5] [--loop-cpus 1] [--floor-seconds S]
                                  [--spin-us US]

The mix repeats: hand line out and back, elbow swing with the hand held, joint PTP out and
back, waist bend with the hands held, vehicle out and back, both hands towards each other
and back ("arms close": each hand to a quarter of its distance from the point between them,
close enough for the collision rows between the two arms), each where the robot has it.
Motions are planned as the daemon's gateway plans them, outside the loop: a planner thread
makes each segment's spec (:func:`loop_mix.planned_segments`: what the gateway sends the
control process, with the configuration it was planned from) on the core's planning copy of
the kinematics, the hand line's and arms close's reachability checks (the only planning that
costs milliseconds) in a worker process, as the gateway plans in its own process
(``--planner thread``: in the planner thread, sharing the loop's GIL). The loop starts each
spec as the control process starts a command (:mod:`controller.control.pending_start`):
accepted after a step's cycle, its motion built in that step's slack
(``MotionSpec.build_as_planned``), started after the next step's cycle (``core.start``),
its first cycle in the step after. Each cycle also publishes the
snapshot, as the control process does. The garbage collector runs in the
loop's slack as in the daemon (``--gc automatic``: CPython's own collection).

Prints per run: the machine load at its start (``os.getloadavg``), cycle compute time and wake
latency (p50/p99/max), the step's thread CPU time (p50/p99, overall and by segment: the
cycle's cost without the time it spent off the CPU, steadier than the wall clock on a shared
machine), overruns (a cycle ending after the next deadline) and cycles woken
late by more than half a period, the per-piece breakdown of the compute time (median and p99
per cycle [µs]: read, kinematics, motion, collision (distances and rows), QP build, QP solve,
write, publish, other; and each piece's median per segment), the share of cycles with
collision rows active (in the whole run and during "arms close", where also the share with
rows between the two arms), the compute time of the cycles with rows active, and what a
motion start costs: the build in the slack (wall clock), the thread CPU time of the start
(``core.start``, and the build where no slack did it) plus the first cycle of the new
motion, p50/max per kind of motion next to the later cycles of the same kind, the starts
with one of their three periods (accepting step and slack with the build, start step,
first cycle) over the period, and the first cycle's pieces against the later cycles'. With
``--runs N`` the run repeats N times and the medians of their compute p50/p99, start costs
and late counts follow. The last line is a JSON object.

After each run, the last cycle's kinematics update and IK solve run again with the same
inputs for ``--spread-seconds`` in the same kind of loop: their thread CPU time p50/p99
is the machine's own spread for identical work (on this shared 2-core VM p99/p50 was
1.2-1.3 at load 1, 1.7-3.0 at load 5), the peer the mix's p99/p50 is compared with.

The breakdown wraps the pieces with timers from outside (nothing in the core knows): about
1 µs of overhead per piece, included in the compute time; ``--no-breakdown`` leaves them out
(the compute time as the daemon has it, no per-piece figures). The benchmark's own booking
of each cycle (its row of figures, the collision shares) runs in the loop's slack, after the
loop measured the step, as the garbage collector does: it is not the controller's work.
So does the MuJoCo stand-in's physics step (``hw.advance()``, as in the daemon: the plant
moves while the controller sleeps): ``plant_us`` is its time, outside the compute time, and
``compute_plus_plant_us`` the compute time with it added, the figure comparable with runs
from before the step moved out of ``hw.write()`` (late cycles and overruns count it either
way: it runs before the next deadline).

Last, the machine's floor (:mod:`machine_floor`, ``--floor-seconds``, default as long as a
run): a bare SCHED_FIFO thread sleeping to the same deadlines, nothing else. On shared
virtual cores even it wakes late by more than half a period now and then (the host runs
something else on the core): the loop's late cycles are read against it. Each run and the
floor also print the steal time of each CPU over their time (``/proc/stat``: the host ran
something else while the VM's CPU had work; ``steal_ms_per_cpu`` in the JSON line).

``--spin-us US`` busy-waits the last ``US`` µs before each deadline, in the loop, the
identical-work loop and the floor's bare thread, as the daemon's ``realtime.spin_us`` does
(docs/daemon.md, "A core for the loop").
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

import machine_floor  # noqa: E402
import numpy as np  # noqa: E402
import overrun_trace  # noqa: E402
from loop_mix import ARMS_CLOSE, WorkerLineCheck, arm_pairs, planned_segments, script  # noqa: E402

from controller.contract.motion_specs import MotionSpec  # noqa: E402
from controller.control.collector import SlackCollector  # noqa: E402
from controller.control.core import MotionCore  # noqa: E402
from controller.control.loop import FixedRateLoop  # noqa: E402
from controller.control.pending_start import PendingStart  # noqa: E402
from controller.control.publisher import SnapshotPublisher  # noqa: E402
from controller.model import jit  # noqa: E402
from controller.model.robot import load_robot  # noqa: E402
from controller.motion.motions import Motion  # noqa: E402
from controller.vocabulary import CoreState  # noqa: E402
from hal.mujoco_backend import MujocoBackend  # noqa: E402

__all__ = ["main", "planned_segments", "script"]


def _patch(obj: Any, name: str, value: Any) -> None:
    """Replace ``obj.name`` on this instance (the benchmark's timers)."""
    setattr(obj, name, value)


PIECES = ("read", "kinematics", "motion", "collision", "qp_build", "qp_solve", "write", "publish")
#: Extra columns of :attr:`Breakdown.rows` after the pieces and "other".
COMPUTE, ROWS, ARM_ROWS, SEGMENT, CPU, START, PLANT, BUILD = range(len(PIECES) + 1, len(PIECES) + 9)


class Breakdown:
    """Per-cycle time of each piece of the control cycle [ns], by wrapping the pieces, and
    the cycle's collision rows."""

    def __init__(self, core: MotionCore, capacity: int, wrap: bool = True):
        """``wrap=False``: no timers (the pieces stay 0), only the compute time and rows."""
        self.now = dict.fromkeys(PIECES, 0)
        self.rows = np.zeros((capacity, BUILD + 1))
        self.n = 0
        self.wrap = wrap
        if wrap:
            self._wrap(core)

    def _wrap(self, core: MotionCore) -> None:
        hw, kin, ik = core.hw, core.kin, core.ik
        _patch(hw, "read", self._timed("read", hw.read))
        _patch(hw, "write", self._timed("write", hw.write))
        _patch(kin, "update", self._timed("kinematics", kin.update))
        collision = core.collision
        if collision is not None:  # distances in the core, rows inside the QP build
            distances = collision.distances
            _patch(distances, "update", self._timed("collision", distances.update))
            rows = collision.compute_qp_inequalities
            _patch(
                collision,
                "compute_qp_inequalities",
                self._timed("collision", rows, inside="qp_build"),
            )
        solve = self._timed("qp_build", ik.solve)

        def solve_with_solvers(*args: Any) -> Any:
            for solver in (ik.solver, *ik._solvers.values()):
                if not getattr(solver, "_bench_timed", False):
                    timed = self._timed("qp_solve", solver.solve, inside="qp_build")
                    _patch(solver, "solve", timed)
                    _patch(solver, "_bench_timed", True)
            return solve(*args)

        _patch(ik, "solve", solve_with_solvers)
        start = core.start

        def start_timed(motion: Motion) -> None:
            _patch(motion, "advance", self._timed("motion", motion.advance))
            start(motion)

        _patch(core, "start", start_timed)

    def _timed(self, name: str, fn: Callable[..., Any], inside: str | None = None):
        now, clock = self.now, time.perf_counter_ns

        def wrapped(*args: Any, **kwargs: Any) -> Any:
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                spent = clock() - t0
                now[name] += spent
                if inside is not None:  # the solver runs inside the QP build's timer
                    now[inside] -= spent

        return wrapped

    def end_cycle(
        self,
        compute_ns: int,
        cpu_ns: int,
        rows: int,
        arm_rows: bool,
        segment: int,
        start_ns: int = 0,
        plant_ns: int = 0,
        build_ns: int = 0,
    ) -> None:
        """Close the cycle: wall-clock ``compute_ns`` and thread CPU ``cpu_ns`` of the step,
        ``rows`` collision rows, ``arm_rows`` some between the two arms, ``segment``: index
        of the running motion's segment (-1: none), ``start_ns``: thread CPU of the
        motion start this step made (``core.start``; 0: none; part of ``cpu_ns``),
        ``plant_ns``: the stand-in's physics step after it, in the slack (``hw.advance()``,
        wall clock), ``build_ns``: the build of the motion it accepted, in the slack after
        the physics step (wall clock; 0: none)."""
        if self.n < len(self.rows):
            row = self.rows[self.n]
            for i, name in enumerate(PIECES):
                row[i] = self.now[name]
            row[len(PIECES)] = compute_ns - sum(self.now.values())
            row[COMPUTE:] = (
                compute_ns, rows, arm_rows, segment, cpu_ns, start_ns, plant_ns, build_ns
            )  # fmt: skip
            self.n += 1
        for name in PIECES:
            self.now[name] = 0

    def summary(self) -> dict[str, dict[str, float]]:
        rows = self.rows[: self.n] / 1e3
        if not self.wrap:
            return {}
        return {name: _percentiles(rows[:, i]) for i, name in enumerate((*PIECES, "other"))}

    def segment_summary(self, names: list[str]) -> dict[str, dict[str, Any]]:
        """Compute time [µs] p50/p99, the step's thread CPU time p50/p99 (``cpu_p50``,
        ``cpu_p99``), cycles and (with the timers) each piece's median (``pieces_p50``) per
        segment of the mix ("idle": no motion)."""
        rows = self.rows[: self.n]
        out: dict[str, dict[str, Any]] = {}
        for k, name in [(-1, "idle"), *((names.index(n), n) for n in dict.fromkeys(names))]:
            mine = rows[rows[:, SEGMENT] == k]
            cpu = {f"cpu_{key}": v for key, v in _percentiles(mine[:, CPU] / 1e3).items()}
            out[name] = {**_percentiles(mine[:, COMPUTE] / 1e3), **cpu, "cycles": len(mine)}
            if self.wrap and len(mine):
                medians = np.median(mine[:, : len(PIECES) + 1], axis=0) / 1e3
                out[name]["pieces_p50"] = {
                    piece: round(float(m), 1)
                    for piece, m in zip((*PIECES, "other"), medians, strict=True)
                }
        return out

    def start_summary(self, names: list[str], period_us: float) -> dict[str, Any]:
        """What a motion start costs, per segment and over all starts: the build in the
        slack after the accepting step (``build``: p50, wall clock [µs]), thread CPU [µs] of
        the start (``core.start``) plus the first cycle of the new motion (``start_first``:
        p50, max), each alone (``start``, ``first``: p50), against the segment's later
        cycles (``steady``: p50); ``over_period``: starts with a period over the period on
        the wall clock (the accepting step with its slack's physics step and build, the
        start step, or the first cycle)."""
        rows = self.rows[: self.n]
        at = np.flatnonzero(rows[:, START] > 0)
        at = at[(at >= 1) & (at + 1 < len(rows))]  # accepted a step before, run the next
        start, first = rows[at, START] / 1e3, rows[at + 1, CPU] / 1e3
        build = rows[at - 1, BUILD] / 1e3
        period_ns = period_us * 1e3
        accepting = rows[at - 1, COMPUTE] + rows[at - 1, PLANT] + rows[at - 1, BUILD]
        late = (
            (accepting > period_ns)
            | (rows[at, COMPUTE] > period_ns)
            | (rows[at + 1, COMPUTE] > period_ns)
        )
        steady = np.ones(len(rows), dtype=bool)
        steady[at] = steady[at + 1] = False

        def figures(pick: np.ndarray, cycles: np.ndarray) -> dict[str, float]:
            both = start[pick] + first[pick]
            if not len(both):
                return {"starts": 0}
            return {
                "starts": len(both),
                "start_first_p50": round(float(np.median(both)), 1),
                "start_first_max": round(float(both.max()), 1),
                "build_p50": round(float(np.median(build[pick])), 1),
                "start_p50": round(float(np.median(start[pick])), 1),
                "first_p50": round(float(np.median(first[pick])), 1),
                "steady_p50": _percentiles(rows[cycles, CPU] / 1e3)["p50"],
                "over_period": int(late[pick].sum()),
            }

        segment = rows[at, SEGMENT]
        out: dict[str, Any] = {
            "all": figures(np.ones(len(at), dtype=bool), steady & (rows[:, SEGMENT] >= 0))
        }
        if self.wrap and len(at):  # where the first cycle's extra goes: p50 per piece
            moving = steady & (rows[:, SEGMENT] >= 0)
            out["all"]["pieces_first_vs_steady"] = {
                name: [
                    round(float(np.median(rows[at + 1, i])) / 1e3, 1),
                    round(float(np.median(rows[moving, i])) / 1e3, 1),
                ]
                for i, name in enumerate((*PIECES, "other"))
            }
        for k, name in ((names.index(n), n) for n in dict.fromkeys(names)):
            out[name] = figures(segment == k, steady & (rows[:, SEGMENT] == k))
        return out

    def plant_summary(self) -> dict[str, dict[str, float]]:
        """The stand-in's physics step in the slack [µs] p50/p99 (``plant_us``; not the
        controller's work: on drives the plant moves by itself), and the compute time with it
        added (``compute_plus_plant_us``: the cycle as measured while the step was part of
        ``hw.write()``)."""
        rows = self.rows[: self.n]
        return {
            "plant_us": _percentiles(rows[:, PLANT] / 1e3),
            "compute_plus_plant_us": _percentiles((rows[:, COMPUTE] + rows[:, PLANT]) / 1e3),
        }

    def cpu_summary(self) -> dict[str, float]:
        """The step's thread CPU time [µs] p50/p99 over the run: what the cycle costs with
        the time it spent off the CPU left out (robust to other work on the machine, not
        to what that work does to the caches)."""
        return _percentiles(self.rows[: self.n, CPU] / 1e3)

    def collision_summary(self, close: int) -> dict[str, Any]:
        """Shares [%] of cycles with collision rows, in the run and in segment ``close``."""
        rows = self.rows[: self.n]
        active = rows[:, ROWS] > 0
        in_close = rows[:, SEGMENT] == close
        n_close = int(in_close.sum())
        return {
            "rows_active_pct": _pct(int(active.sum()), len(rows)),
            "arms_close_cycles": n_close,
            "arms_close_rows_active_pct": _pct(int((active & in_close).sum()), n_close),
            "arms_close_arm_rows_pct": _pct(int((rows[:, ARM_ROWS] > 0).sum()), n_close),
            "max_rows": int(rows[:, ROWS].max(initial=0)),
            "compute_us_rows_active": _percentiles(rows[active, COMPUTE] / 1e3),
            "compute_us_arm_rows": _percentiles(rows[rows[:, ARM_ROWS] > 0, COMPUTE] / 1e3),
        }


def _percentiles(values: np.ndarray) -> dict[str, float]:
    if not len(values):
        return {"p50": 0.0, "p99": 0.0}
    return {
        "p50": round(float(np.percentile(values, 50)), 1),
        "p99": round(float(np.percentile(values, 99)), 1),
    }


def _pct(part: int, whole: int) -> float:
    return round(100.0 * part / whole, 1) if whole else 0.0


def identical_work(core: MotionCore, args: argparse.Namespace) -> dict[str, float]:
    """The machine's own spread: the same kinematics update and IK solve (the cycle where the
    mix ended, the same inputs every time) repeated in a loop like the mix's, for
    ``args.spread_seconds``. Thread CPU time per repeat [µs] p50/p99 and their ratio: on a
    quiet dedicated core the ratio is near 1; what it is here, the mix's p99 carries too."""
    q, q_cmd, v_cmd = core.q.copy(), core.q_cmd.copy(), core.v_cmd.copy()
    kin, ik = core.kin, core.ik
    cycles = int(args.rate * args.spread_seconds)
    spent = np.zeros(cycles)
    clock = time.thread_time_ns

    def step(cycle: int, t: float) -> bool:
        c0 = clock()
        kin.update(q)
        ik.solve(q_cmd, v_cmd)
        spent[cycle % cycles] = clock() - c0
        return True

    collector = SlackCollector() if args.gc == "slack" else None
    loop = FixedRateLoop(
        args.rate,
        step,
        realtime=not args.no_realtime,
        slack=collector,
        cpus=args.loop_cpus,
        spin_us=args.spin_us,
    )
    if collector is not None:
        collector.start()
    try:
        loop.run(max_cycles=cycles)
    finally:
        if collector is not None:
            collector.stop()
    out = _percentiles(spent / 1e3)
    out["p99_over_p50"] = round(out["p99"] / out["p50"], 2) if out["p50"] else 0.0
    return out


def steal_now() -> np.ndarray:
    """Each CPU's steal time so far [s] (``/proc/stat``: the time the host ran something
    else while this VM's CPU had work; 10 ms steps; zeros where it cannot be read)."""
    out = np.zeros(os.cpu_count() or 1)
    try:
        fd = os.open("/proc/stat", os.O_RDONLY)
    except OSError:
        return out
    try:
        overrun_trace.read_steal(fd, out)
    finally:
        os.close(fd)
    return out


def steal_ms_since(before: np.ndarray) -> list[float]:
    """Each CPU's steal time [ms] since ``before`` (a :func:`steal_now`)."""
    return [round(1e3 * float(x), 1) for x in steal_now() - before]


def run(args: argparse.Namespace) -> dict[str, Any]:
    """One run of the mix; prints its figures, returns them."""
    load = os.getloadavg()
    robot = load_robot(args.robot)
    dt = 1.0 / args.rate
    core = MotionCore(robot, MujocoBackend(robot, dt), dt)
    core.servo_on()
    line_check = WorkerLineCheck(args.robot, dt) if args.planner == "process" else None
    mix = planned_segments(core, line_check)
    names = [name for name, _ in mix]
    close = names.index(ARMS_CLOSE) if ARMS_CLOSE in names else -2
    done = {"motions": 0, "skipped": 0, "next": 0}
    ready: list[tuple[int, MotionSpec]] = []
    pending: list[tuple[int, PendingStart]] = []  # accepted, built in the slack, started next
    finished = threading.Event()
    collision = core.collision
    arm_rows = (
        arm_pairs(core.kin, collision.distances.pair_links) if collision is not None else None
    )
    # Closest distance between the two arms during "arms close" [m].
    closest = {"arms": math.inf}

    idle = threading.Event()  # set by the loop when the robot is idle with nothing ready

    def plan_next() -> None:
        core.planning_kinematics()  # refresh the copy the factories use
        k = done["next"] % len(mix)
        spec = mix[k][1](core)
        done["next"] += 1
        if spec is None:
            done["skipped"] += 1
        else:
            ready.append((k, spec))

    def planner() -> None:
        # Woken by the loop (a thread polling every millisecond would take the loop's GIL).
        while not finished.is_set():
            if not idle.wait(0.1):
                continue
            idle.clear()
            if not ready and core.state == CoreState.READY and core.motion is None:
                plan_next()

    # The first motion is ready before the first cycle: the mix starts moving at once,
    # however long the first plan takes on a busy machine (a short run was all idle).
    plan_next()

    capacity = int(args.rate * args.seconds) + 10
    breakdown = Breakdown(core, capacity, wrap=not args.no_breakdown)

    def publish() -> None:
        publisher.publish(len(ready), False, 0, 0, bool(pending))

    if not args.no_breakdown:
        publish = breakdown._timed("publish", publish)
    segment = {"now": -1}

    def step(cycle: int, t: float) -> bool:
        t0, c0 = time.perf_counter_ns(), time.thread_time_ns()
        start_cpu = 0
        core.cycle()
        if core.motion is None:
            segment["now"] = -1
        # As the control process starts a command's motion: accepted after a step's cycle,
        # built from its spec in that step's slack, started after the next step's cycle.
        if pending:
            k, accepted = pending.pop()
            s0 = time.thread_time_ns()
            core.start(accepted.take(core.kin, core.dt))
            start_cpu = max(1, time.thread_time_ns() - s0)
            segment["now"] = names.index(names[k])  # the segment's first entry
            done["motions"] += 1
        elif ready and core.state == CoreState.READY and core.motion is None:
            k, spec = ready.pop()
            pending.append((k, PendingStart(spec)))
        elif not ready and core.motion is None and not idle.is_set():
            idle.set()
        publish()
        compute, cpu = time.perf_counter_ns() - t0, time.thread_time_ns() - c0
        last[:] = (compute, cpu, start_cpu, segment["now"])
        return core.state != CoreState.ALARM

    last: list[int] = []  # the step's figures, booked after it (outside its compute time)

    def book(plant_ns: int = 0, build_ns: int = 0) -> None:
        """The last step's row of the breakdown and the collision figures: the benchmark's
        own work, after the loop measured the step (the daemon has none of it);
        ``plant_ns``: the physics step after it, ``build_ns``: the build of the motion it
        accepted [ns]."""
        if not last:
            return
        compute, cpu, start_cpu, now = last
        last.clear()
        n_rows, between = 0, False
        if collision is not None and arm_rows is not None:
            n_rows = len(collision.pairs)
            if now == close:
                between = bool(n_rows and arm_rows[collision.pairs].any())
                d = collision.distances.distances[arm_rows]
                closest["arms"] = min(closest["arms"], float(d.min(initial=math.inf)))
        breakdown.end_cycle(compute, cpu, n_rows, between, now, start_cpu, plant_ns, build_ns)

    def slack(left_ns: int) -> None:
        t0 = time.perf_counter_ns()
        core.hw.advance()  # the physics step, as the daemon's slack takes it
        t1 = time.perf_counter_ns()
        if pending:  # then the motion accepted in the step, as the daemon's slack builds it
            pending[0][1].build(core.kin, core.dt)
        t2 = time.perf_counter_ns()
        book(t1 - t0, t2 - t1)
        if collector is not None:  # the garbage collector gets what the booking left
            collector(left_ns - (time.perf_counter_ns() - t0))

    thread = threading.Thread(target=planner, daemon=True)
    thread.start()

    collector = SlackCollector() if args.gc == "slack" else None
    loop = FixedRateLoop(
        args.rate,
        step,
        realtime=not args.no_realtime,
        stats_capacity=capacity,
        slack=slack,
        cpus=args.loop_cpus,
        spin_us=args.spin_us,
    )
    runtime = tempfile.TemporaryDirectory(prefix="bench-loop-")
    publisher = SnapshotPublisher(
        Path(runtime.name) / "snapshot", core, core.hw, loop, args.rate, queue_depth=1
    )
    if collector is not None:
        collector.start()
    steal0 = steal_now()
    try:
        with jit.compiled_meanwhile() as compiled:  # kernels compiled in the loop: none due
            loop.run(max_cycles=int(args.rate * args.seconds))
    finally:
        if collector is not None:
            collector.stop()
    steal_ms = steal_ms_since(steal0)
    if compiled:
        print(f"kernels compiled while the loop ran (their cycles waited): {compiled}")
    book()  # the last step's (the loop ended before its slack)
    finished.set()
    thread.join()
    publisher.close()
    runtime.cleanup()
    if line_check is not None:
        line_check.close()
    spread = identical_work(core, args) if args.spread_seconds > 0 else None
    pieces = breakdown.summary()
    rows = breakdown.collision_summary(close)
    by_segment = breakdown.segment_summary(names)
    starts = breakdown.start_summary(names, 1e6 / args.rate)
    rows["arms_closest_mm"] = round(closest["arms"] * 1e3, 1) if closest["arms"] < 1e9 else None
    stats = loop.stats.summary()
    report = loop.realtime_report
    print(
        f"robot {args.robot}, {args.rate:g} Hz, {args.seconds:g} s, load "
        f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (1/5/15 min, at the start), "
        f"{done['motions']} motions ({done['skipped']} skipped), state {core.state.value}"
    )
    if report is not None:
        print(f"real-time: {report}")
    for name in ("compute_us", "wake_latency_us"):
        print(
            f"{name:16s} p50 {stats[f'{name}_p50']:8.1f}  p99 {stats[f'{name}_p99']:8.1f}  "
            f"max {stats[f'{name}_max']:8.1f}"
        )
    cpu = breakdown.cpu_summary()
    plant = breakdown.plant_summary()
    print(
        f"{'plant_us':16s} p50 {plant['plant_us']['p50']:8.1f}  p99 "
        f"{plant['plant_us']['p99']:8.1f}  (the stand-in's physics step, in the slack; compute "
        f"+ it p50/p99 {plant['compute_plus_plant_us']['p50']:.1f}/"
        f"{plant['compute_plus_plant_us']['p99']:.1f})"
    )
    print(
        f"{'cpu_us':16s} p50 {cpu['p50']:8.1f}  p99 {cpu['p99']:8.1f}  "
        "(the step's thread CPU time: its cost without the time off the CPU)"
    )
    print(
        f"cycles {stats['cycles']}, overruns {stats['overruns']}, "
        f"late by > half a period {stats['late_by_more_than_half_period']}; steal time per "
        f"CPU {steal_ms} ms (the host ran something else on this VM's CPUs that long)"
    )
    if pieces:
        print(
            "per cycle [us]  "
            + "  ".join(f"{k} {v['p50']:.1f}/{v['p99']:.1f}" for k, v in pieces.items())
        )
        print("                (median/p99 of each piece; 'other': the rest of the compute time)")
    active, between = rows["compute_us_rows_active"], rows["compute_us_arm_rows"]
    print(
        f"collision rows active in {rows['rows_active_pct']:.1f} % of cycles (up to "
        f"{rows['max_rows']} rows; compute p50/p99 {active['p50']:.1f}/{active['p99']:.1f} us); "
        f"arms close: {rows['arms_close_cycles']} cycles, rows active in "
        f"{rows['arms_close_rows_active_pct']:.1f} %, rows between the arms in "
        f"{rows['arms_close_arm_rows_pct']:.1f} % (compute p50/p99 "
        f"{between['p50']:.1f}/{between['p99']:.1f} us), closest {rows['arms_closest_mm']} mm"
    )
    print(
        "compute p50/p99 [us] by segment: "
        + ", ".join(
            f"{name} {v['p50']:.0f}/{v['p99']:.0f} ({v['cycles']:g})"
            for name, v in by_segment.items()
        )
    )
    print(
        "cpu p50/p99 [us] by segment: "
        + ", ".join(
            f"{name} {v['cpu_p50']:.0f}/{v['cpu_p99']:.0f}" for name, v in by_segment.items()
        )
    )
    if pieces:
        names = [n for n, v in by_segment.items() if "pieces_p50" in v]
        print("piece medians by segment [us]: " + " ".join(f"{n[:11]:>11s}" for n in names))
        for piece in (*PIECES, "other"):
            values = (by_segment[n]["pieces_p50"][piece] for n in names)
            print(f"  {piece:28s}" + " ".join(f"{v:11.1f}" for v in values))
    if spread is not None:
        print(
            f"identical work (the last cycle's kinematics + IK again with the same inputs, "
            f"{args.spread_seconds:g} s in the same kind of loop): cpu p50/p99 "
            f"{spread['p50']:.1f}/{spread['p99']:.1f} us, p99/p50 {spread['p99_over_p50']:.2f} "
            f"(the mix: {cpu['p99'] / cpu['p50']:.2f}): the machine's spread"
        )
    print(
        "motion start: build in the slack p50 [us, wall]; thread CPU [us] of the start "
        "(core.start) + the first cycle p50/max (start, first cycle p50; the segment's later "
        "cycles p50; starts with a period over the period): "
        + ", ".join(
            f"{name} {v['build_p50']:.0f}; {v['start_first_p50']:.0f}/"
            f"{v['start_first_max']:.0f} ({v['start_p50']:.0f} + {v['first_p50']:.0f}; "
            f"{v['steady_p50']:.0f}; {v['over_period']}/{v['starts']})"
            for name, v in starts.items()
            if v["starts"]
        )
    )
    first = starts["all"].get("pieces_first_vs_steady")
    if first:
        print(
            "first cycle of a motion / later cycles, p50 per piece [us]: "
            + "  ".join(f"{k} {a:.1f}/{b:.1f}" for k, (a, b) in first.items())
        )
    gc_figures = None
    if collector is not None:
        gc_figures = {
            "young": collector.collections[0],
            "middle": collector.collections[1],
            "frozen_instead": collector.freezes,
            "forced": collector.forced,
            "cost_us": [round(c / 1e3, 1) for c in collector.cost_ns],
        }
        print(
            f"garbage collection in the slack: {gc_figures['young']} young, "
            f"{gc_figures['middle']} middle, {gc_figures['frozen_instead']} frozen instead, "
            f"{gc_figures['forced']} forced; last cost {gc_figures['cost_us']} us"
        )
    if core.alarms:
        print(f"alarms: {core.alarms}")
    return {
        "gc": gc_figures,
        "load": [round(x, 2) for x in load],
        "motions": done["motions"],
        "alarms": len(core.alarms),
        **stats,
        "cpu_us_p50": cpu["p50"],
        "cpu_us_p99": cpu["p99"],
        "steal_ms_per_cpu": steal_ms,
        **plant,
        "identical_work_cpu_us": spread,
        "start_cpu_us_p50": starts["all"].get("start_first_p50", 0.0),
        "start_cpu_us_max": starts["all"].get("start_first_max", 0.0),
        "start_build_us_p50": starts["all"].get("build_p50", 0.0),
        "compiled_in_loop": compiled,
        "starts_over_period": starts["all"].get("over_period", 0),
        "starts": starts,
        "pieces_us": pieces,
        "collision": rows,
        "segments": by_segment,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="smartpal5")
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--runs", type=int, default=1, help="repeat the run, print medians")
    parser.add_argument("--no-realtime", action="store_true", help="skip SCHED_FIFO etc.")
    parser.add_argument(
        "--no-breakdown",
        action="store_true",
        help="no timers around the pieces (their overhead, ~1 us each, leaves the compute time)",
    )
    parser.add_argument(
        "--switch-interval",
        type=float,
        default=1e-4,
        help="sys.setswitchinterval [s]: how long another Python thread may hold the GIL "
        "(CPython's default 5 ms shows up as late cycles)",
    )
    parser.add_argument(
        "--planner",
        choices=("process", "thread"),
        default="process",
        help="where the hand line's reachability check runs: a worker process, as the "
        "daemon's gateway plans in its own process (default), or the planner thread",
    )
    parser.add_argument(
        "--gc",
        choices=("slack", "automatic"),
        default="slack",
        help="garbage collection: in the loop's slack as the daemon does (default), or "
        "CPython's automatic collection",
    )
    parser.add_argument(
        "--spread-seconds",
        type=float,
        default=5.0,
        help="after each run, repeat one identical kinematics + IK step this long to show "
        "the machine's own spread of CPU time for the same work (0: skip)",
    )
    parser.add_argument(
        "--loop-cpus",
        type=lambda text: [int(c) for c in text.split(",")],
        default=None,
        help="pin the loop thread to these CPUs (comma-separated), as realtime.loop_cpus "
        "does in the daemon",
    )
    parser.add_argument(
        "--spin-us",
        type=float,
        default=0.0,
        help="busy-wait the last microseconds before each deadline, as realtime.spin_us does "
        "in the daemon (the floor's bare thread too)",
    )
    parser.add_argument(
        "--floor-seconds",
        type=float,
        default=None,
        help="after the runs, the machine's floor (tools/machine_floor.py: a bare SCHED_FIFO "
        "thread sleeping to the same deadlines) this long [s] (default: --seconds; 0: skip)",
    )
    args = parser.parse_args()
    if args.runs < 1:
        parser.error("--runs must be >= 1")
    sys.setswitchinterval(args.switch_interval)
    runs = []
    for i in range(args.runs):
        if args.runs > 1:
            print(f"--- run {i + 1}/{args.runs}")
        runs.append(run(args))
    keys = (
        "compute_us_p50",
        "compute_us_p99",
        "cpu_us_p50",
        "cpu_us_p99",
        "late_by_more_than_half_period",
        "overruns",
        "start_cpu_us_p50",
        "start_cpu_us_max",
        "start_build_us_p50",
        "starts_over_period",
    )
    median = {k: statistics.median(r[k] for r in runs) for k in keys}
    for k in ("plant_us", "compute_plus_plant_us"):
        median[f"{k}_p99"] = statistics.median(r[k]["p99"] for r in runs)
    if args.runs > 1:
        print(
            f"median of {args.runs} runs: compute p50 {median['compute_us_p50']:.1f} us, "
            f"p99 {median['compute_us_p99']:.1f} us (CPU p50 {median['cpu_us_p50']:.1f}, "
            f"p99 {median['cpu_us_p99']:.1f} us; a motion's build in the slack p50 "
            f"{median['start_build_us_p50']:.1f} us, its start + first cycle CPU p50 "
            f"{median['start_cpu_us_p50']:.1f}, max {median['start_cpu_us_max']:.1f} us, starts "
            f"with a period over the period {median['starts_over_period']:g}; the "
            f"physics step in the slack p99 {median['plant_us_p99']:.1f} us, compute + it p99 "
            f"{median['compute_plus_plant_us_p99']:.1f} us), late by > half a period "
            f"{median['late_by_more_than_half_period']:g}, overruns {median['overruns']:g}; "
            f"load at the starts {[r['load'][0] for r in runs]}"
        )
    floor_seconds = args.seconds if args.floor_seconds is None else args.floor_seconds
    floor = None
    if floor_seconds > 0:
        steal0 = steal_now()
        floor = machine_floor.measure(args.rate, floor_seconds, spin_us=args.spin_us)
        floor["steal_ms_per_cpu"] = steal_ms_since(steal0)
        print(
            f"machine floor: a bare SCHED_FIFO sleep{' + spin' if args.spin_us else ''} loop "
            f"at {args.rate:g} Hz for "
            f"{floor_seconds:g} s (fifo {floor.get('fifo')}): late by > half a period "
            f"{floor.get('late')}, wake p99 {floor.get('wake_p99_us')} us, max "
            f"{floor.get('wake_max_us')} us, steal time per CPU {floor['steal_ms_per_cpu']} "
            f"ms (the loop's late cycles: "
            f"{[r['late_by_more_than_half_period'] for r in runs]} per {args.seconds:g} s; "
            f"steal per CPU {[r['steal_ms_per_cpu'] for r in runs]} ms)"
        )
    result = {
        "robot": args.robot,
        "rate_hz": args.rate,
        "seconds": args.seconds,
        "runs": args.runs,
        "spin_us": args.spin_us,
        "median": median,
        "machine_floor": floor,
        "alarms": sum(r["alarms"] for r in runs),
        "per_run": runs,
    }
    print(json.dumps(result))
    return 0 if not result["alarms"] else 1


if __name__ == "__main__":
    sys.exit(main())
