#!/usr/bin/env python3
"""CPU time of the control cycle's pieces outside the IK, measured in one process.

Usage: python tools/bench_cycle_cpu.py [--robot smartpal5] [--number 3000] [--repeat 7]

Runs the motion core on MuJoCo at 1 kHz into a CP-hold motion of the benchmark mix (the
elbow swing of tools/loop_mix.py, or its first segment), then times each piece with
``timeit`` on ``time.thread_time`` (CPU time of this thread: robust on a shared machine,
unlike the wall-clock figures of tools/bench_loop.py): hardware read, hardware write with
the physics step it leaves (``write`` + ``advance``: one cycle of simulation), ``mj_step``
alone, the snapshot publish, the kinematics update, and the core's own glue (a whole
``MotionCore.cycle`` with read, write, kinematics, collision distances, motion and IK
replaced by stubs). Prints the minimum and median over the repeats
[µs per call]; the last line is a JSON object.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

import mujoco  # noqa: E402
from loop_mix import segments  # noqa: E402

from controller.control.core import MotionCore  # noqa: E402
from controller.control.loop import FixedRateLoop  # noqa: E402
from controller.control.publisher import SnapshotPublisher  # noqa: E402
from controller.model.robot import load_robot  # noqa: E402
from controller.vocabulary import CoreState  # noqa: E402
from hal.interface import JointCommand, JointState  # noqa: E402
from hal.mujoco_backend import MujocoBackend  # noqa: E402


def measure(fn: Callable[[], Any], number: int, repeat: int) -> dict[str, float]:
    """CPU time per call [µs]: minimum and median over ``repeat`` rounds of ``number``."""
    rounds = timeit.repeat(fn, timer=time.thread_time, number=number, repeat=repeat)
    return {
        "min": round(1e6 * min(rounds) / number, 2),
        "median": round(1e6 * statistics.median(rounds) / number, 2),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="smartpal5")
    parser.add_argument("--number", type=int, default=3000, help="calls per round")
    parser.add_argument("--repeat", type=int, default=7, help="rounds")
    args = parser.parse_args()
    n, r = args.number, args.repeat

    robot = load_robot(args.robot)
    dt = 1e-3
    core = MotionCore(robot, MujocoBackend(robot, dt), dt)
    core.servo_on()
    mix = segments(core)
    name, make = next(((s, m) for s, m in mix if s == "elbow swing"), mix[0])
    core.planning_kinematics()
    motion = make(core)
    assert motion is not None
    core.start(motion)
    for _ in range(300):
        core.cycle()
    if core.state != CoreState.BUSY:
        raise SystemExit(f"the {name!r} motion ended within 300 cycles: nothing to measure")
    runtime = tempfile.TemporaryDirectory(prefix="bench-cycle-cpu-")
    loop = FixedRateLoop(1000.0, lambda cycle, t: True, realtime=False)
    publisher = SnapshotPublisher(Path(runtime.name) / "snapshot", core, core.hw, loop, 1e3, 1)
    hw = core.hw
    assert isinstance(hw, MujocoBackend)
    command = JointCommand(core.hw_command.copy(), core._hw_vel.copy())
    q = core.q.copy()

    def write() -> None:
        hw.write(command)
        hw.advance()

    pieces = {
        "read": measure(hw.read, n, r),
        "write": measure(write, n, r),
        "mj_step": measure(lambda: mujoco.mj_step(hw.model, hw.data), n, r),
        "publish": measure(lambda: publisher.publish(0, False, 0, 0), n, r),
        "kinematics": measure(lambda: core.kin.update(q), n, r),
    }
    # The glue: the cycle with every piece above (and the IK) stubbed out.
    measured = hw.read()
    state = JointState(measured.position.copy(), measured.velocity.copy(), measured.stamp)
    result = core.ik.solve(core.q_cmd, core.v_cmd)
    stubs: list[tuple[Any, str, Any]] = [
        (hw, "read", lambda: state),
        (hw, "write", lambda c: None),
        (core.kin, "update", lambda q: None),
        (core.ik, "solve", lambda q, v: result),
        (motion, "advance", lambda step=None: None),
    ]
    if core.collision is not None:
        stubs.append((core.collision.distances, "update", lambda *args: None))
    for obj, attr, stub in stubs:
        setattr(obj, attr, stub)
    pieces["cycle_glue"] = measure(core.cycle, n, r)
    for obj, attr, _ in stubs:
        delattr(obj, attr)
    publisher.close()
    runtime.cleanup()

    print(f"robot {args.robot}, during {name!r}; CPU time per call [us], min / median:")
    for piece, t in pieces.items():
        print(f"  {piece:12s} {t['min']:8.2f} {t['median']:8.2f}")
    print(json.dumps({"robot": args.robot, "motion": name, "pieces_us": pieces}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
