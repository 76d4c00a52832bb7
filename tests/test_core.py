"""controller.control.core: states, faults becoming alarms, recovery, grippers, threads."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from controller.control.core import CoreError, MotionCore
from controller.model.alarms import AlarmCode
from controller.motion.motions import JointMotion
from controller.qp.ik import IKResult
from controller.vocabulary import CoreState, RightLeft, UnitType
from hal.ideal_backend import IdealBackend
from hal.interface import HardwareFault, HardwareState
from tests.motion_support import DT, make_core
from tests.support import kernel_signatures, kernels_gained, robot


def arm_move(core: MotionCore, delta: float = 0.3) -> JointMotion:
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    box = core.ik.box
    return JointMotion(
        core.kin, DT, joints, core.q_cmd[joints] + delta, box.v_max[joints], box.a_max[joints]
    )


def test_servo_on_and_off():
    core = MotionCore(robot("pa10"), IdealBackend(robot("pa10"), DT), DT)
    assert core.state == CoreState.SERVO_OFF
    core.servo_on()
    assert core.state == CoreState.READY and core.hw.state == HardwareState.ACTIVE
    core.servo_off()
    assert core.state == CoreState.SERVO_OFF and core.hw.state == HardwareState.INACTIVE


@pytest.mark.parametrize("state", ["servo off", "busy", "paused", "alarm"])
def test_motion_starts_only_when_ready(state: str):
    core = make_core("pa10")
    if state == "servo off":
        core.servo_off()
    elif state == "busy":
        core.start(arm_move(core))
    elif state == "paused":
        core.pause()
    else:
        core.raise_alarm(AlarmCode.EMERGENCY_STOP, "test", "e-stop")
    with pytest.raises(CoreError):
        core.start(arm_move(core))


def test_pause_and_resume_while_idle():
    core = make_core("pa10")
    core.pause()
    assert core.state == CoreState.PAUSED
    core.cycle()
    core.resume()
    assert core.state == CoreState.READY


def test_nothing_moves_while_servo_off():
    core = make_core("pa10")
    core.servo_off()
    before = core.hw.read().position
    for _ in range(10):
        core.cycle()
    assert np.array_equal(core.hw.read().position, before)


@pytest.mark.parametrize("when", [0, 100])
def test_hardware_fault_stops_everything_and_is_recoverable(when: int):
    core = make_core("smartpal5")
    core.start(arm_move(core))
    for _ in range(when):
        core.cycle()
    hw = core.hw
    assert isinstance(hw, IdealBackend)
    hw.inject_fault(HardwareFault(int(AlarmCode.DRIVE_FAULT), "r_arm_j3", "overcurrent"))
    held = hw.read().position
    core.cycle()
    assert core.state == CoreState.ALARM
    assert core.motion is None
    assert core.alarms[0].module == "r_arm_j3" and core.alarms[0].code == 0x400
    for _ in range(10):
        core.cycle()
    assert np.array_equal(hw.read().position, held)
    with pytest.raises(CoreError):
        core.servo_on()
    core.clear_alarms()
    assert core.state == CoreState.SERVO_OFF and not core.alarms
    core.servo_on()
    assert core.state == CoreState.READY
    core.start(arm_move(core, -0.1))
    while core.motion is not None:
        core.cycle()
    assert core.state == CoreState.READY


def test_qp_failure_raises_an_alarm_and_holds(monkeypatch: pytest.MonkeyPatch):
    core = make_core("pa10")
    core.start(arm_move(core))
    for _ in range(50):
        core.cycle()
    monkeypatch.setattr(
        core.ik, "solve", lambda q, v: IKResult(np.zeros(core.kin.nv), False, "infeasible")
    )
    before = core.hw.read().position
    core.cycle()
    assert core.state == CoreState.ALARM
    assert core.alarms[-1].code == AlarmCode.QP_FAILURE
    assert np.allclose(core.hw.read().position, before, atol=1e-12)


def test_time_law_failure_raises_an_alarm():
    core = make_core("pa10")
    motion = arm_move(core)
    core.start(motion)

    def broken() -> None:
        raise ValueError("a bug in a motion")  # any exception, not only RuntimeError

    motion.advance = broken  # type: ignore[method-assign]
    core.cycle()
    assert core.state == CoreState.ALARM
    assert core.alarms[-1].code == AlarmCode.TRAJECTORY_FAILURE


def test_an_exception_in_the_ik_is_a_qp_failure(monkeypatch: pytest.MonkeyPatch):
    core = make_core("pa10")
    core.start(arm_move(core))

    def explode(q: np.ndarray, v: np.ndarray) -> IKResult:
        raise FloatingPointError("overflow")

    monkeypatch.setattr(core.ik, "solve", explode)
    core.cycle()
    assert core.state == CoreState.ALARM
    assert core.alarms[-1].code == AlarmCode.QP_FAILURE
    assert "overflow" in core.alarms[-1].description


def test_gripper_moves_to_a_ratio():
    core = make_core("smartpal5")
    assert core.gripper_ratio(RightLeft.LEFT) == pytest.approx(0.0)
    core.move_gripper(RightLeft.LEFT, 0.5)
    assert core.is_moving
    for _ in range(2000):
        core.cycle()
        if not core.is_moving:
            break
    assert not core.is_moving
    assert core.gripper_ratio(RightLeft.LEFT) == pytest.approx(0.5, abs=1e-9)
    assert core.gripper_ratio(RightLeft.RIGHT) == pytest.approx(0.0)


def test_commands_from_another_thread_land_between_cycles():
    core = make_core("pa10")
    stop = threading.Event()

    def loop() -> None:
        while not stop.is_set():
            core.cycle()

    thread = threading.Thread(target=loop)
    thread.start()
    try:
        core.start(arm_move(core, 0.2))
        end = time.monotonic() + 60.0  # a bound, never asserted as a time
        while core.state != CoreState.READY and time.monotonic() < end:
            time.sleep(0.001)  # not a spin: that held the GIL from the loop's thread
        assert core.state == CoreState.READY, core.alarms
        core.start(arm_move(core, -0.2))
        core.abort()
        assert core.motion is None
    finally:
        stop.set()
        thread.join()
    assert core.state == CoreState.READY


def test_a_motion_ends_only_on_target_and_at_rest_or_with_a_warning():
    """Issues 15.2/17.4: Ready means still and on target. An elbow target the joint limits
    forbid (SmartPal V: -130 deg from home) ends ARRIVAL_TIMEOUT after the time law with a
    MOTION_INCOMPLETE warning naming what is off; the state stays usable (no fault)."""
    import math

    from controller.control.core import ARRIVAL_TIMEOUT
    from controller.model.alarms import AlarmType
    from controller.motion.motions import CartesianMotion
    from controller.motion.paths import LinePath

    core = make_core("smartpal5")
    side = RightLeft.RIGHT
    pose = core.kin.pose(side)
    elbow = core.kin.elbow_angle(side) - math.radians(130)
    motion = CartesianMotion(
        core.kin, DT, side, LinePath(pose, pose), (0.1, 1.0), (0.5, 2.0), {}, elbow=elbow
    )
    core.start(motion)
    cycles = 0
    while core.motion is not None and not motion.finished:
        core.cycle()
        cycles += 1
    after = 0
    while core.motion is not None:
        core.cycle()
        after += 1
    assert after * DT >= ARRIVAL_TIMEOUT - DT
    assert core.state == CoreState.READY
    (alarm,) = core.alarms
    assert alarm.code == AlarmCode.MOTION_INCOMPLETE and alarm.type == AlarmType.WARNING
    assert "rightElbow" in alarm.description and "deg from its target" in alarm.description
    np.testing.assert_allclose(core.kin.pose(side).translation, pose.translation, atol=2e-4)


@pytest.mark.parametrize("backend", ["ideal", "mujoco"])
def test_a_waist_bend_and_back_with_both_hands_held_comes_to_rest_without_a_warning(
    backend: str,
):
    """The regularisation (level-0 posture) pulling every joint toward the start posture
    kept trading SmartPal V's two lumbar joints against both held arms after the time law
    (composite angle and hands on target, lower and upper drifting at ~0.0025 rad/s): a
    bend of +5 deg took 1.3 s to come to rest, the bend back ended 2 s after its time law
    with MOTION_INCOMPLETE "still moving". Once the time law has ended the posture is held
    where it is: each comes to rest within SETTLE_TIME (simulated time, not wall clock)."""
    import math

    from controller.control.core import SETTLE_TIME
    from controller.model.redundant_axes import axis_value
    from controller.motion.motions import CPHoldMotion

    core = make_core("smartpal5", backend)
    axis = next(a for a in core.ik.axes if a.is_lumbar)
    arms = tuple(core.kin.arms)
    speed = np.array([math.radians(20)])
    for bend in (5.0, -5.0):
        goal = axis_value(core.kin, axis) + math.radians(bend)
        motion = CPHoldMotion(core.kin, DT, arms, {axis: goal}, speed, 2 * speed)
        core.start(motion)
        while core.motion is not None and not motion.finished:
            core.cycle()
        after = 0
        while core.motion is not None:
            core.cycle()
            after += 1
        assert core.alarms == []
        assert after * DT <= SETTLE_TIME + 10 * DT
        assert core.state == CoreState.READY
        assert float(np.abs(core.v_cmd).max()) < 2e-3
        assert abs(axis_value(core.kin, axis) - goal) < math.radians(0.1)


def test_no_net_allocation_per_cycle_after_warm_up():
    """Issue 14: after warm-up the control cycle allocates nothing it keeps (tracemalloc).
    Temporaries come and go; CPython's free lists (tuples, floats, dicts) keep a bounded
    number of blocks, hence a small tolerance: a leak of one small object per cycle (>= 56
    bytes) would show 45 kB over the window.

    The warm-up is longer than the window: the collision rows' kernel call leaves two 200-byte
    blocks per call alive for its first ~980 calls after the core is built (~390 kB, then
    flat: measured over 10 000 cycles; numba's, not ours), and a window inside them failed
    this test on some runs."""
    import tracemalloc

    import pinocchio as pin

    from controller.motion.motions import CartesianMotion
    from controller.motion.paths import LinePath

    core = make_core("smartpal5", "mujoco")
    side = RightLeft.RIGHT
    start = core.kin.pose(side)
    end = pin.SE3(start.rotation, start.translation + np.array([0.1, 0.0, 0.1]))
    motion = CartesianMotion(core.kin, DT, side, LinePath(start, end), (0.01, 1.0), (0.5, 2.0), {})
    core.start(motion)
    window, warm_up = 800, 1500
    tracemalloc.start(1)
    try:
        for _ in range(warm_up):
            core.cycle()
        before = tracemalloc.take_snapshot()
        for _ in range(window):
            core.cycle()
        after = tracemalloc.take_snapshot()
    finally:
        tracemalloc.stop()
    assert core.motion is motion and not motion.finished  # measured while moving
    grown = sum(d.size_diff for d in after.compare_to(before, "lineno"))
    assert grown < 16 * 1024, after.compare_to(before, "lineno")[:5]


def test_collision_distances_are_updated_once_per_cycle_while_the_ik_solves():
    """Issue 10: the core updates the collision distances once per cycle, after the
    kinematics (the rows read them), and not at all while every joint is held."""
    core = make_core("smartpal5")
    assert core.collision is not None
    dist = core.collision.distances
    seen: list[np.ndarray] = []
    update = dist.update

    def counted(data, q, chain=None):
        np.testing.assert_allclose(core.kin.q, core.q)  # the kinematics are this cycle's
        np.testing.assert_array_equal(q, core.kin.q)
        seen.append(core.kin.q.copy())
        update(data, q, chain)

    dist.update = counted  # type: ignore[method-assign]
    for _ in range(10):
        core.cycle()
    assert not seen  # holding: nothing solved, nothing computed
    j1 = np.array([core.kin.index("r_arm_j1")])
    goal = core.kin.q[j1] + 0.2
    core.start(JointMotion(core.kin, DT, j1, goal, np.array([0.5]), np.array([1.0])))
    for n in range(1, 21):
        core.cycle()
        assert len(seen) == n


def test_a_control_cycle_runs_no_pinocchio_pass_with_the_compiled_kernels(
    monkeypatch: pytest.MonkeyPatch,
):
    """The cycle's kinematic queries (control points, elbows, vehicle rows, collision pairs)
    read the compiled joint chain: no ``computeJointJacobians`` while an elbow swings or a
    hand follows a line with the elbow held and the vehicle's heading ranged (issue 14: the
    Pinocchio pass was ~18 us of every cycle in the loop)."""
    import pinocchio as pin

    from controller.model import jit
    from controller.model.redundant_axes import RedundantAxis, elbow_axis
    from controller.motion import paths
    from controller.motion.motions import CartesianMotion, CPHoldMotion

    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    core = make_core("smartpal5", "mujoco")
    assert core.collision is not None and not core.collision.distances.needs_data
    calls: list[int] = []
    compute = pin.computeJointJacobians

    def counted(*args: object) -> object:
        calls.append(1)
        return compute(*args)

    side = RightLeft.RIGHT
    goal = core.kin.elbow_angle(side) + 0.1
    speed = np.array([0.3])
    swing = CPHoldMotion(core.kin, DT, (side,), {elbow_axis(side): goal}, speed, 2 * speed)
    hand = core.kin.pose(side)
    line = paths.LinePath(hand, pin.SE3(hand.rotation, hand.translation + 0.02))
    held = {elbow_axis(side): False, RedundantAxis.LUMBAR_RY: False}
    span = {RedundantAxis.VEHICLE_THETA: (-0.1, 0.1)}
    monkeypatch.setattr(pin, "computeJointJacobians", counted)
    core.start(swing)
    for _ in range(30):
        core.cycle()
    assert core.motion is not None and not calls  # still swinging, every cycle solved
    core.abort()
    core.clear_alarms()
    for _ in range(5):
        core.cycle()
    calls.clear()
    core.start(CartesianMotion(core.kin, DT, side, line, (0.05, 1.0), (0.5, 2.0), held, span))
    for _ in range(30):
        core.cycle()
    assert core.motion is not None and core.ik.rows.limit.max_rows >= 1
    assert not calls


def test_a_control_cycle_places_the_joints_once(monkeypatch: pytest.MonkeyPatch):
    """The collision distances read the kinematics' joint placements: one pass over the
    joints per cycle (issue 14: every per-cycle kinematic quantity computed once), and the
    same distances as placing them on their own."""
    from controller.model import collision_kernel, jit
    from controller.model.joint_chain import JointChain
    from controller.model.redundant_axes import elbow_axis
    from controller.motion.motions import CPHoldMotion

    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    core = make_core("smartpal5", "mujoco")
    assert core.collision is not None
    distances = core.collision.distances
    passes: list[str] = []
    forward, own = JointChain.forward, collision_kernel.update

    def counted_forward(chain: JointChain, q: np.ndarray) -> None:
        passes.append("kinematics")
        forward(chain, q)

    def counted_own(*args: object) -> None:
        passes.append("collision")
        own(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(JointChain, "forward", counted_forward)
    monkeypatch.setattr(collision_kernel, "update", counted_own)
    side = RightLeft.RIGHT
    speed = np.array([0.3])
    goal = {elbow_axis(side): core.kin.elbow_angle(side) + 0.1}
    core.start(CPHoldMotion(core.kin, DT, (side,), goal, speed, 2 * speed))
    for _ in range(20):
        passes.clear()
        core.cycle()
        assert passes == ["kinematics"]
        shared = distances.distances.copy(), distances.witnesses.copy()
        distances.update(None, core.kin.q)  # the joints placed by the distances themselves
        np.testing.assert_array_equal(shared[0], distances.distances)
        np.testing.assert_array_equal(shared[1], distances.witnesses)
    assert core.motion is not None


def test_the_control_cycle_never_waits_for_a_compiler():
    """Every compiled kernel (collision, elbow, cost, posture path, line, ...) is compiled or
    loaded from numba's cache at import or when the core is built, for the arrays the cycles
    pass: motions built and cycles that solve (an elbow swing: every kernel runs, the cost of
    both levels), a posture path followed, lines followed (a line's pose into the task's
    Pinocchio-owned, column-major target) add no signature to any kernel loaded. A kernel
    compiled in a cycle stalls it for a second (the drives lose the master's heartbeat)."""
    import pinocchio as pin

    from controller.model import elbow, jit
    from controller.model.redundant_axes import RedundantAxis, elbow_axis
    from controller.motion import paths, posture
    from controller.motion.motions import CartesianMotion, CPHoldMotion, follow_posture
    from controller.qp import tasks
    from controller.qp.constraints import damper_kernel

    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    core = make_core("smartpal5", "mujoco")
    assert core.collision is not None and core.collision.distances.compiled
    before = kernel_signatures()
    for kernel in (paths._line_pose, paths._line_follow, posture._follow, elbow.elbows_at,
                   tasks._control_point_task, damper_kernel.collision_rows):  # fmt: skip
        assert before[f"{kernel.__module__}.{kernel.__name__}"] > 0
    side = RightLeft.RIGHT
    goal = core.kin.elbow_angle(side) + 0.1
    speed = np.array([0.3])
    core.start(CPHoldMotion(core.kin, DT, (side,), {elbow_axis(side): goal}, speed, 2 * speed))
    for _ in range(30):
        core.cycle()
    assert core.motion is not None  # still swinging: every cycle solved
    assert core.ik._plan.level2 is not None  # the elbow's level: both costs compiled
    q = core.kin.q
    path = posture.PosturePath(np.array([0.0, 1.0]), np.vstack([q, q + 0.1]))
    follow_posture(tasks.PostureTask(q.copy(), np.arange(len(q))), path, 0.2, 0.3, DT)
    while core.motion is not None:
        core.cycle()
    # A line with the elbow held: the axis rows kernel runs.
    hand = core.kin.pose(side)
    line = paths.LinePath(hand, pin.SE3(hand.rotation, hand.translation + 0.02))
    held = {elbow_axis(side): False, RedundantAxis.LUMBAR_RY: False}
    span = {RedundantAxis.VEHICLE_THETA: (-0.1, 0.1)}
    core.start(CartesianMotion(core.kin, DT, side, line, (0.05, 1.0), (0.5, 2.0), held, span))
    for _ in range(30):
        core.cycle()
    assert core.motion is not None and core.ik.rows.limit.max_rows >= 1  # the held elbow
    core.abort()
    core.clear_alarms()
    for _ in range(5):
        core.cycle()
    # The other hand held too: two control-point tasks in one level, each task's rows a
    # slice of the stack that is contiguous in neither order.
    hand = core.kin.pose(side)
    line = paths.LinePath(hand, pin.SE3(hand.rotation, hand.translation + 0.02))
    both = CartesianMotion(
        core.kin, DT, side, line, (0.05, 1.0), (0.5, 2.0), held, span, hold_other=True
    )
    core.start(both)
    for _ in range(30):
        core.cycle()
    assert core.motion is not None and len(core.ik.tasks) >= 2
    assert kernels_gained(before) == {}
