#!/usr/bin/env python3
"""Closed-loop benchmark: the motion core on MuJoCo at a fixed rate, running a scripted mix.

Usage: python tools/bench_loop.py [--robot smartpal5] [--rate 1000] [--seconds 20]
                                  [--no-realtime]

The mix repeats: hand line out and back, elbow swing with the hand held, joint PTP out and
back, waist bend with the hands held, vehicle out and back (each where the robot has it).
Motions are built and reachability-checked in a planner thread on the core's planning copy
of the kinematics, as the daemon's service thread does; the loop only starts them. Each cycle
also publishes the snapshot, as the control process does. Prints cycle compute time and wake
latency (p50/p99/max), overruns and late cycles, the per-piece breakdown of the compute time
(median and p99 per cycle [µs]: read, kinematics, motion, QP build, QP solve, write, publish,
other), and as the last line a JSON object.

The breakdown wraps the pieces with timers from outside (nothing in the core knows): about
1 µs of overhead per piece, included in the compute time.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np
import pinocchio as pin

from controller.control.core import MotionCore
from controller.control.loop import FixedRateLoop
from controller.control.publisher import SnapshotPublisher
from controller.model.redundant_axes import axis_value, elbow_axis
from controller.model.robot import load_robot
from controller.motion.motions import (
    CartesianMotion,
    CPHoldMotion,
    JointMotion,
    Motion,
    VehicleMotion,
)
from controller.motion.paths import LinePath
from controller.motion.reachability import ReachabilityChecker
from controller.vocabulary import CoreState, RightLeft, UnitType
from hal.mujoco_backend import MujocoBackend

RIGHT = RightLeft.RIGHT
Factory = Callable[[MotionCore], Motion | None]


def script(core: MotionCore) -> list[Factory]:
    """The motion mix for this robot: factories building each motion on the planning copy."""
    kin, dt = core.planning_kinematics(), core.dt
    checker = ReachabilityChecker(kin)

    def line(sign: float) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            start = kin.pose(RIGHT)
            end = pin.SE3(start.rotation, start.translation + sign * np.array([0.05, 0, 0.05]))
            m = CartesianMotion(kin, dt, RIGHT, LinePath(start, end), (0.2, 1.0), (0.5, 2.0), {})
            return m if checker.check(kin, RIGHT, m.path, m.setup()) is None else None

        return make

    def hold(axis_of: Callable[[], object], delta: float, held: tuple[RightLeft, ...]) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            axis = axis_of()
            goal = axis_value(kin, axis) + delta  # type: ignore[arg-type]
            speed = np.array([math.radians(20)])
            return CPHoldMotion(kin, dt, held, {axis: goal}, speed, 2 * speed)  # type: ignore[dict-item]

        return make

    def ptp(delta: float) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            joints = kin.unit_indices(UnitType.RIGHT_ARM)
            box = c.ik.box
            return JointMotion(
                kin,
                dt,
                joints,
                c.q_cmd[joints] + delta,
                0.5 * box.v_max[joints],
                0.5 * box.a_max[joints],
            )

        return make

    def drive(x: float) -> Factory:
        def make(c: MotionCore) -> Motion | None:
            pose = kin.vehicle_pose()
            return VehicleMotion(kin, dt, np.array([x, pose[1], pose[2]]), (0.2, 0.5), (0.4, 1.0))

        return make

    mix: list[Factory] = [line(1.0), line(-1.0)]
    if kin.has_elbow(RIGHT):
        mix += [
            hold(lambda: elbow_axis(RIGHT), math.radians(10), (RIGHT,)),
            hold(lambda: elbow_axis(RIGHT), -math.radians(10), (RIGHT,)),
        ]
    mix += [ptp(0.2), ptp(-0.2)]
    lumbar = [a for a in core.ik.axes if a.is_lumbar]
    if lumbar:
        arms = tuple(kin.arms)
        mix += [
            hold(lambda: lumbar[0], math.radians(5), arms),
            hold(lambda: lumbar[0], -math.radians(5), arms),
        ]
    if kin.has_vehicle:
        mix += [drive(0.2), drive(0.0)]
    return mix


def _patch(obj: Any, name: str, value: Any) -> None:
    """Replace ``obj.name`` on this instance (the benchmark's timers)."""
    setattr(obj, name, value)


PIECES = ("read", "kinematics", "motion", "qp_build", "qp_solve", "write", "publish")


class Breakdown:
    """Per-cycle time of each piece of the control cycle [ns], by wrapping the pieces."""

    def __init__(self, core: MotionCore, capacity: int):
        self.now = dict.fromkeys(PIECES, 0)
        self.rows = np.zeros((capacity, len(PIECES) + 1))
        self.n = 0
        hw, kin, ik = core.hw, core.kin, core.ik
        _patch(hw, "read", self._timed("read", hw.read))
        _patch(hw, "write", self._timed("write", hw.write))
        _patch(kin, "update", self._timed("kinematics", kin.update))
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

    def end_cycle(self, compute_ns: int) -> None:
        if self.n < len(self.rows):
            row = self.rows[self.n]
            for i, name in enumerate(PIECES):
                row[i] = self.now[name]
            row[-1] = compute_ns - sum(self.now.values())
            self.n += 1
        for name in PIECES:
            self.now[name] = 0

    def summary(self) -> dict[str, dict[str, float]]:
        rows = self.rows[: self.n] / 1e3
        return {
            name: {
                "p50": round(float(np.percentile(rows[:, i], 50)), 1),
                "p99": round(float(np.percentile(rows[:, i], 99)), 1),
            }
            for i, name in enumerate((*PIECES, "other"))
        }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="smartpal5")
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--no-realtime", action="store_true", help="skip SCHED_FIFO etc.")
    parser.add_argument(
        "--switch-interval",
        type=float,
        default=1e-4,
        help="sys.setswitchinterval [s]: how long another Python thread may hold the GIL "
        "(CPython's default 5 ms shows up as late cycles)",
    )
    args = parser.parse_args()
    sys.setswitchinterval(args.switch_interval)

    robot = load_robot(args.robot)
    dt = 1.0 / args.rate
    core = MotionCore(robot, MujocoBackend(robot, dt), dt)
    core.servo_on()
    mix = script(core)
    done = {"motions": 0, "skipped": 0, "next": 0}
    ready: list[Motion] = []
    finished = threading.Event()

    def planner() -> None:
        while not finished.is_set():
            if not ready and core.state == CoreState.READY and core.motion is None:
                core.planning_kinematics()  # refresh the copy the factories use
                motion = mix[done["next"] % len(mix)](core)
                done["next"] += 1
                if motion is None:
                    done["skipped"] += 1
                else:
                    ready.append(motion)
            time.sleep(0.001)

    capacity = int(args.rate * args.seconds) + 10
    breakdown = Breakdown(core, capacity)
    publish = breakdown._timed("publish", lambda: publisher.publish(len(ready), False, 0, 0))

    def step(cycle: int, t: float) -> bool:
        t0 = time.perf_counter_ns()
        core.cycle()
        if ready and core.state == CoreState.READY and core.motion is None:
            core.start(ready.pop())
            done["motions"] += 1
        publish()
        breakdown.end_cycle(time.perf_counter_ns() - t0)
        return core.state != CoreState.ALARM

    thread = threading.Thread(target=planner, daemon=True)
    thread.start()

    loop = FixedRateLoop(args.rate, step, realtime=not args.no_realtime, stats_capacity=capacity)
    runtime = tempfile.TemporaryDirectory(prefix="bench-loop-")
    publisher = SnapshotPublisher(
        Path(runtime.name) / "snapshot", core, core.hw, loop, args.rate, queue_depth=1
    )
    loop.run(max_cycles=int(args.rate * args.seconds))
    finished.set()
    thread.join()
    publisher.close()
    runtime.cleanup()
    pieces = breakdown.summary()
    stats = loop.stats.summary()
    report = loop.realtime_report
    print(
        f"robot {args.robot}, {args.rate:g} Hz, {args.seconds:g} s, "
        f"{done['motions']} motions ({done['skipped']} skipped), state {core.state.value}"
    )
    if report is not None:
        print(f"real-time: {report}")
    for name in ("compute_us", "wake_latency_us"):
        print(
            f"{name:16s} p50 {stats[f'{name}_p50']:8.1f}  p99 {stats[f'{name}_p99']:8.1f}  "
            f"max {stats[f'{name}_max']:8.1f}"
        )
    print(
        f"cycles {stats['cycles']}, overruns {stats['overruns']}, "
        f"late by > half a period {stats['late_by_more_than_half_period']}"
    )
    print(
        "per cycle [us]  "
        + "  ".join(f"{k} {v['p50']:.1f}/{v['p99']:.1f}" for k, v in pieces.items())
    )
    print("                (median/p99 of each piece; 'other': the rest of the compute time)")
    if core.alarms:
        print(f"alarms: {core.alarms}")
    result = {
        "robot": args.robot,
        "rate_hz": args.rate,
        "seconds": args.seconds,
        "motions": done["motions"],
        "alarms": len(core.alarms),
        **stats,
        "pieces_us": pieces,
    }
    print(json.dumps(result))
    return 0 if not core.alarms else 1


if __name__ == "__main__":
    sys.exit(main())
