"""tools/loop_mix.py: the benchmark's motion mix brings the two arms within the collision
rows' range of each other (issue 14)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from loop_mix import ARMS_CLOSE, arm_pairs, segments

from controller.control.core import MotionCore
from controller.model.robot import load_robot
from controller.vocabulary import CoreState
from hal.mujoco_backend import MujocoBackend


def test_arms_close_puts_collision_rows_between_the_two_arms_and_comes_back():
    robot = load_robot("smartpal5")
    dt = 1e-3
    core = MotionCore(robot, MujocoBackend(robot, dt), dt)
    core.servo_on()
    mix = [(name, make) for name, make in segments(core) if name == ARMS_CLOSE]
    assert len(mix) == 2  # in and back out
    assert core.collision is not None
    between = arm_pairs(core.kin, core.collision.distances.pair_links)
    assert between.any()
    start = {side: core.kin.pose(side).translation.copy() for side in core.kin.arms}
    rows_between = 0
    for _, make in mix:
        core.planning_kinematics()
        core.start(make(core))
        for _ in range(20000):
            core.cycle()
            pairs = core.collision.pairs
            rows_between += bool(len(pairs) and between[pairs].any())
            if core.motion is None:
                break
        assert core.state == CoreState.READY and not core.alarms
    assert rows_between > 0
    for side, p in start.items():  # back where they started
        assert np.linalg.norm(core.kin.pose(side).translation - p) < 1e-3


def test_the_hand_line_is_planned_and_built_as_the_daemon_does():
    """The mix's hand line is the gateway's checked move (the checked joint path its null
    space follows), built at the configuration it was planned from; a move the planning
    refuses is skipped, saying why."""
    from loop_mix import MixPlanner

    from controller.motion.motions import CartesianMotion

    robot = load_robot("smartpal5")
    dt = 2e-3
    core = MotionCore(robot, MujocoBackend(robot, dt), dt)
    core.servo_on()
    refused: list[str] = []
    mix = dict(segments(core, MixPlanner("smartpal5", dt), refused))
    core.planning_kinematics()
    motion = mix["hand line"](core)
    assert isinstance(motion, CartesianMotion) and motion.posture_path is not None
    assert refused == []

    class Refusing:
        def line(self, *_args: object) -> tuple[None, str]:
            return None, "out of reach"

        arms = line

    mix = dict(segments(core, Refusing(), refused))
    assert mix["hand line"](core) is None and mix[ARMS_CLOSE](core) is None
    assert refused == ["hand line: out of reach", "arms close: out of reach"]


def test_the_planned_mix_is_the_specs_the_gateway_would_send():
    """bench_loop plans the mix as specs (planned in another thread, built in the loop as the
    control process builds a command's motion): every segment's spec carries the
    configuration it was planned from and builds the motion ``segments`` builds."""
    from loop_mix import MixPlanner, planned_segments

    from controller.contract.motion_specs import MotionSpec

    robot = load_robot("smartpal5")
    dt = 2e-3
    core = MotionCore(robot, MujocoBackend(robot, dt), dt)
    core.servo_on()
    planning = MixPlanner("smartpal5", dt)
    planned = planned_segments(core, planning)
    built = segments(core, planning)
    assert [name for name, _ in planned] == [name for name, _ in built]
    seen = set()
    for (name, plan), (_, make) in zip(planned, built, strict=True):
        core.planning_kinematics()
        spec = plan(core)
        assert isinstance(spec, MotionSpec), name
        assert spec.planned_from is not None
        np.testing.assert_array_equal(spec.planned_from, core.kin.q)
        q = core.kin.q.copy()
        motion = spec.build_as_planned(core.kin, dt)
        np.testing.assert_array_equal(core.kin.q, q)  # the live kinematics back where they were
        core.planning_kinematics()
        reference = make(core)
        assert type(motion) is type(reference), name
        assert motion.profile.a_max == pytest.approx(reference.profile.a_max, rel=1e-9), name
        seen.add(name)
    assert seen == {"hand line", "elbow swing", "joint ptp", "waist bend", "vehicle", ARMS_CLOSE}


def run_the_mix_counting_compiles(
    robot_id: str = "smartpal5", hal: str = "sim"
) -> dict[str, dict[str, list[int]]]:
    """The planned mix run as the daemon runs it, on ``hal`` ("sim": the MuJoCo stand-in;
    "hil": the CAN master and the drive emulator in this process, in lockstep): the hand
    line and "arms close" planned in a worker process (as the gateway plans in its own)
    while the cycles go on, every spec accepted, built and started as the control process
    does (:class:`~controller.control.pending_start.PendingStart`), then cycled to its end.
    Per segment, the kernels that gained a signature while it was built, started and run,
    with their counts before and after ("servo on" for the drives' enabling)."""
    from concurrent.futures import ThreadPoolExecutor

    from loop_mix import WorkerLineCheck, planned_segments

    from controller.control.pending_start import PendingStart
    from hal.factory import make_hardware
    from tests.support import kernel_signatures, kernels_gained

    robot = load_robot(robot_id)
    dt = 2e-3
    hw = make_hardware(hal, robot, dt, {"emulator": "thread"} if hal == "hil" else None)
    core = MotionCore(robot, hw, dt)
    planning = WorkerLineCheck(robot_id, dt)  # started before the drives expect cycles
    compiled: dict[str, dict[str, list[int]]] = {}
    try:
        hw.configure()
        before = kernel_signatures()
        core.servo_on()
        compiled["servo on"] = kernels_gained(before)
        with ThreadPoolExecutor(1) as pool:
            for name, plan in planned_segments(core, planning):
                core.planning_kinematics()
                planned = pool.submit(plan, core)
                while not planned.done():  # enabled drives expect the cycles meanwhile
                    core.cycle()
                spec = planned.result()
                assert spec is not None, name
                before = kernel_signatures()
                pending = PendingStart(spec)
                pending.build(core.kin, dt)
                core.start(pending.take(core.kin, dt))
                for _ in range(int(20 / dt)):
                    core.cycle()
                    if core.motion is None:
                        break
                assert core.state == CoreState.READY and not core.alarms, (name, core.alarms)
                compiled[name] = compiled.get(name, {}) | kernels_gained(before)
    finally:
        hw.shutdown()
        planning.close()
    return compiled


def test_no_kernel_compiles_while_the_mix_is_built_started_and_run():
    """Every motion of the mix, built from its spec and started as the control process
    does, then run to its end, on the MuJoCo stand-in (SmartPal V) and through the CAN
    master and the drive emulator (PA10), adds no signature to any compiled kernel: no step
    waits for the compiler. In a fresh process (in this one, earlier tests may have compiled
    what the control process would compile in a step): a fresh install compiled the line's
    kernel for the task's column-major target in the first hand line's step, a second with
    no cycle, and the drives lost the master's heartbeat."""
    from controller.model import jit

    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    root = Path(__file__).resolve().parents[1]
    code = (
        "import json; from tests.test_loop_mix import run_the_mix_counting_compiles as run; "
        "print(json.dumps({'sim': run('smartpal5', 'sim'), 'hil': run('pa10', 'hil')}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=root
    )
    assert done.returncode == 0, done.stderr[-3000:]
    runs = json.loads(done.stdout.strip().splitlines()[-1])
    assert set(runs["sim"]) >= {"hand line", "elbow swing", "joint ptp", "waist bend", ARMS_CLOSE}
    assert set(runs["hil"]) >= {"servo on", "hand line", "elbow swing", "joint ptp"}
    for hal, compiled in runs.items():
        assert {name: new for name, new in compiled.items() if new} == {}, hal
