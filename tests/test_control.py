"""controller.control.process: the loop-side Controller without gRPC.

Commands are called in the test thread between explicit cycles (``_step``), as the loop
thread would; one test goes through :meth:`Controller.submit` from another thread.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from controller.contract import snapshot as snap
from controller.contract.motion_specs import CartesianBox, JointMoveSpec
from controller.control.core import CoreState
from controller.control.process import Controller, Request
from controller.errors import Refused
from controller.model.alarms import AlarmCode
from controller.model.kinematics import Kinematics
from controller.motion.motions import Motion
from controller.vocabulary import FrameType, ReturnCode, RightLeft
from hal.ideal_backend import IdealBackend
from hal.interface import HardwareFault
from tests.support import robot

RATE = 250.0


@pytest.fixture
def ctl(tmp_path: Path) -> Iterator[Controller]:
    r = robot("pa10")
    hw = IdealBackend(r, 1.0 / RATE)
    hw.configure()
    c = Controller(r, hw, RATE, tmp_path / "snapshot", queue_depth=2)
    try:
        yield c
    finally:
        c.close()


def step(c: Controller, n: int = 1) -> None:
    for _ in range(n):
        c._step(c.core.cycles, 0.0)


def run_until_idle(c: Controller, limit: int = 5000) -> None:
    for _ in range(limit):
        step(c)
        if not c.core.is_moving and not c.queue and c.pending is None:
            return
    raise AssertionError("still moving")


def read(c: Controller) -> snap.Snapshot:
    r = snap.SnapshotReader(c.publisher.writer.path, len(c.hw.joint_names))
    try:
        return r.read()
    finally:
        r.close()


def j1_move(c: Controller, target: float, speed: float = 1.0, planned: bool = True):
    """J1 (kinematic index 0) to ``target`` [rad]."""
    return JointMoveSpec(
        joints=np.array([0]),
        target=np.array([target]),
        speed=np.array([speed]),
        accel=np.array([4.0]),
        planned_from=c.core.kin.q.copy() if planned else None,
        label=f"J1 to {target}",
    )


def refused(fn, *args, **kw) -> Refused:  # type: ignore[no-untyped-def]
    with pytest.raises(Refused) as err:
        fn(*args, **kw)
    assert err.value.comment
    return err.value


def ready(c: Controller) -> Controller:
    c.cmd_servo_on()
    step(c)
    assert c.core.state == CoreState.READY
    return c


# ----------------------------------------------------------------------------- refusals
def test_refusal_codes_by_state(ctl: Controller):
    step(ctl)
    assert refused(ctl.cmd_start, j1_move(ctl, 0.1)).code == ReturnCode.NOT_SV_ON_ERR
    assert refused(ctl.cmd_gripper, RightLeft.RIGHT, 1.0).code == ReturnCode.NOT_SV_ON_ERR
    ready(ctl)
    assert ctl.cmd_start(j1_move(ctl, 0.5, speed=0.2)) == "started"
    step(ctl)
    # Spec A never queues: busy is STATUS_ERR
    assert refused(ctl.cmd_start, j1_move(ctl, 0.1)).code == ReturnCode.STATUS_ERR
    ctl.cmd_pause()
    step(ctl, 100)
    assert ctl.core.state == CoreState.PAUSED
    assert refused(ctl.cmd_start, j1_move(ctl, 0.1)).code == ReturnCode.STATUS_ERR
    assert refused(ctl.cmd_gripper, RightLeft.RIGHT, 1.0).code == ReturnCode.STATUS_ERR
    ctl.cmd_abort()
    ctl.hw.inject_fault(HardwareFault(int(AlarmCode.DRIVE_FAULT), "J3", "test"))  # type: ignore[attr-defined]
    step(ctl)
    assert ctl.core.state == CoreState.ALARM
    assert refused(ctl.cmd_start, j1_move(ctl, 0.1)).code == ReturnCode.STATUS_ERR
    assert refused(ctl.cmd_start, j1_move(ctl, 0.1), queued=True).code == ReturnCode.STATUS_ERR
    assert refused(ctl.cmd_gripper, RightLeft.RIGHT, 1.0).code == ReturnCode.STATUS_ERR
    assert refused(ctl.cmd_servo_on).code == ReturnCode.NG
    ctl.cmd_clear_alarms()
    step(ctl)
    ready(ctl)  # a persisting drive fault does not block recovery after clearAlarms


def test_a_plan_from_an_old_state_is_refused(ctl: Controller):
    ready(ctl)
    stale = j1_move(ctl, 0.3)
    ctl.cmd_start(j1_move(ctl, 0.2, speed=2.0))
    run_until_idle(ctl)
    err = refused(ctl.cmd_start, stale)
    assert err.code == ReturnCode.STATUS_ERR and "send it again" in err.comment


def test_the_checked_plan_is_the_one_executed(ctl: Controller):
    """One plan per motion (issue 9): the loop runs the path planned (and checked) from
    ``planned_from``, not a re-plan from where the robot happens to be; the live kinematics
    are left at the measured configuration."""
    ready(ctl)
    measured = ctl.core.kin.q.copy()
    spec = j1_move(ctl, 0.3)
    planned = measured.copy()
    planned[0] += 1e-3  # within PLAN_TOLERANCE of the measured state
    spec.planned_from = planned
    ctl.cmd_start(spec)
    step(ctl)  # built (no slack here: at the start), started after the cycle
    motion = ctl.core.motion
    assert motion is not None
    np.testing.assert_array_equal(motion.path.start, planned[[0]])  # type: ignore[attr-defined]
    np.testing.assert_array_equal(ctl.core.kin.q, measured)


def test_a_motion_is_prepared_as_planned_and_regularised_from_the_measured_state(
    ctl: Controller,
):
    """Its set-up is made as it is built (issue 14: not in a later cycle); the posture it
    regularises toward is the measured one at the start, not the planned one."""
    ready(ctl)
    measured = ctl.core.kin.q.copy()
    spec = j1_move(ctl, 0.3)
    spec.planned_from = measured + 1e-3
    motion = spec.build_as_planned(ctl.core.kin, ctl.dt)
    assert motion._ik_setup is not None
    ctl.core.start(motion)
    np.testing.assert_array_equal(ctl.core.ik.tasks[-1].reference, measured)  # type: ignore[attr-defined]


def test_unknown_and_failing_commands_answer_ng(ctl: Controller):
    answers = []

    def client() -> None:
        answers.append(ctl.submit("no_such_command", timeout=10.0))
        answers.append(ctl.submit("gripper", timeout=10.0, side=RightLeft.RIGHT))  # arg missing
        answers.append(ctl.submit("status", timeout=10.0))

    thread = threading.Thread(target=client)
    thread.start()
    while thread.is_alive():
        step(ctl)
    unknown, failing, status = answers
    assert not unknown.ok and unknown.code == ReturnCode.NG and "no_such_command" in unknown.message
    assert not failing.ok and failing.code == ReturnCode.NG and "gripper failed" in failing.message
    assert status.ok and status.value == {"state": CoreState.SERVO_OFF, "queue": 0}


def test_an_answer_comes_after_the_snapshot_shows_it(ctl: Controller):
    """A client that reads the snapshot right after an OK start sees the motion: the answer
    is given only once the cycle that ran the command has published."""
    ready(ctl)
    request = Request("start", {"spec": j1_move(ctl, 0.4)})
    ctl.inbox.put(request)
    answered_at_publish = []
    publish = ctl.publish

    def spy() -> None:
        publish()
        answered_at_publish.append(request.done.is_set())

    ctl.publish = spy  # type: ignore[method-assign]
    step(ctl)  # accepted: shown running already (a queue never shows ready in between)
    assert not request.done.is_set() and read(ctl).moving and ctl.core.motion is None
    assert read(ctl).core_state == CoreState.BUSY
    step(ctl)  # started
    assert request.ok and request.done.is_set()
    assert answered_at_publish == [False, False]
    assert read(ctl).moving


def test_a_start_is_spread_over_three_steps_its_motion_built_in_the_slack(ctl: Controller):
    """A motion command is accepted after a step's cycle, its motion built in that step's
    slack, started after the next step's cycle (answered then) and run from the step after:
    no step carries two of the build, the start and the motion's first (dearest) cycle.
    Urgent commands still act before the cycle."""
    ready(ctl)
    order: list[str] = []
    execute, cycle = ctl._execute, ctl.core.cycle

    def spy_execute(request: Request) -> None:
        order.append(request.name)
        execute(request)

    def spy_cycle(elapsed: float | None = None) -> None:
        order.append("cycle with a motion" if ctl.core.motion is not None else "cycle")
        cycle(elapsed)

    ctl._execute = spy_execute  # type: ignore[method-assign]
    ctl.core.cycle = spy_cycle  # type: ignore[method-assign]
    start = Request("start", {"spec": j1_move(ctl, 0.4)})
    ctl.inbox.put(start)
    ctl.urgent.put(Request("stop", {}))
    step(ctl)
    assert order == ["stop", "cycle", "start"]
    assert ctl.pending is not None and not ctl.pending.built and ctl.core.motion is None
    assert not start.done.is_set()
    ctl._slack(10**9)
    assert ctl.pending is not None and ctl.pending.motion is not None  # built in the slack
    motion = ctl.pending.motion
    step(ctl)
    assert order[3:] == ["cycle"] and ctl.core.motion is motion  # started after the cycle
    assert start.ok and start.done.is_set() and read(ctl).moving
    step(ctl)
    assert order[-1] == "cycle with a motion"


def test_commands_behind_an_accepted_start_wait_for_it(ctl: Controller):
    """A command that arrives behind an accepted start acts once the motion started: a
    second start is refused as when busy, a setting as while moving."""
    ready(ctl)
    first = Request("start", {"spec": j1_move(ctl, 0.4)})
    second = Request("start", {"spec": j1_move(ctl, 0.2)})
    ctl.inbox.put(first)
    ctl.inbox.put(second)
    step(ctl)
    assert ctl.pending is not None and not second.done.is_set()
    assert refused(ctl.cmd_start, j1_move(ctl, 0.1)).code == ReturnCode.STATUS_ERR
    assert refused(ctl.cmd_reset_original_frame).code == ReturnCode.STATUS_ERR
    step(ctl)
    assert first.ok and first.done.is_set()
    assert second.done.is_set() and not second.ok and second.code == ReturnCode.STATUS_ERR
    assert ctl.started == 1


@pytest.mark.parametrize("name", ["stop", "abort", "pause", "servo_off"])
def test_an_urgent_command_after_an_accepted_start_acts_on_its_motion(ctl: Controller, name: str):
    """Commands act in the order they were accepted: an urgent command that arrives while a
    start waits for the next step starts its motion first, then acts on it."""
    ready(ctl)
    start = Request("start", {"spec": j1_move(ctl, 0.4)})
    ctl.inbox.put(start)
    step(ctl)
    urgent = Request(name, {})
    ctl.urgent.put(urgent)
    step(ctl)
    assert start.ok and urgent.ok and ctl.started == 1
    run_until_idle(ctl)
    expected = {"pause": CoreState.PAUSED, "servo_off": CoreState.SERVO_OFF}
    assert ctl.core.state == expected.get(name, CoreState.READY)


def test_a_start_whose_motion_cannot_be_built_answers_value_err(ctl: Controller):
    class Broken(JointMoveSpec):
        def build(self, kin: Kinematics, dt: float) -> Motion:
            raise ValueError("no time law")

    ready(ctl)
    q = ctl.core.kin.q.copy()
    broken = Broken(np.array([0]), np.array([0.0]), np.array([1.0]), np.array([1.0]),
                    planned_from=q.copy(), label="broken")  # fmt: skip
    start = Request("start", {"spec": broken})
    ctl.inbox.put(start)
    step(ctl)
    ctl._slack(10**9)
    step(ctl)
    assert start.done.is_set() and not start.ok and start.value is None
    assert start.code == ReturnCode.VALUE_ERR and "no time law" in start.message
    assert ctl.core.state == CoreState.READY and ctl.core.motion is None and not ctl.core.alarms
    np.testing.assert_array_equal(ctl.core.kin.q, q)


def test_an_alarm_before_the_start_refuses_it(ctl: Controller):
    """A fault in the cycle between acceptance and start: the start answers STATUS_ERR."""
    ready(ctl)
    start = Request("start", {"spec": j1_move(ctl, 0.4)})
    ctl.inbox.put(start)
    step(ctl)
    ctl.hw.inject_fault(HardwareFault(int(AlarmCode.DRIVE_FAULT), "J3", "test"))  # type: ignore[attr-defined]
    step(ctl)
    assert start.done.is_set() and not start.ok and start.code == ReturnCode.STATUS_ERR
    assert "not started" in start.message and ctl.started == 0


def test_a_shutdown_answers_an_accepted_start(ctl: Controller):
    ready(ctl)
    start = Request("start", {"spec": j1_move(ctl, 0.4)})
    ctl.inbox.put(start)
    ctl.shutdown_requested.set()
    step(ctl)
    assert start.done.is_set() and not start.ok and start.code == ReturnCode.STATUS_ERR
    assert "stopping" in start.message and ctl.pending is None


def test_submit_times_out_without_a_loop(ctl: Controller):
    request = ctl.submit("status", timeout=0.05)
    assert not request.ok and request.code == ReturnCode.NG and "did not answer" in request.message


# ----------------------------------------------------------------------------- queue
def test_queue_depth_and_order(ctl: Controller):
    ready(ctl)
    targets = [0.1, 0.2, 0.3]
    assert ctl.cmd_start(j1_move(ctl, targets[0], planned=False), queued=True) == "started"
    for t in targets[1:]:
        assert ctl.cmd_start(j1_move(ctl, t, planned=False), queued=True) == "queued"
    step(ctl)
    s = read(ctl)
    assert s.queue == 2 and s.queue_depth == 2 and s.flags & snap.F_QUEUE_FULL
    err = refused(ctl.cmd_start, j1_move(ctl, 0.4, planned=False), queued=True)
    assert err.code == ReturnCode.FULL_MOTION_QUEUE_ERR and "2 waiting" in err.comment
    run_until_idle(ctl)
    assert ctl.core.kin.q[0] == pytest.approx(targets[-1], abs=1e-6)
    s = read(ctl)
    assert s.started == 3 and s.finished == 3 and s.queue == 0
    assert not s.flags & snap.F_QUEUE_FULL
    assert ctl.core.state == CoreState.READY


@pytest.mark.parametrize("how", ["stop", "abort", "servo_off"])
def test_stop_abort_and_servo_off_empty_the_queue(ctl: Controller, how: str):
    ready(ctl)
    ctl.cmd_start(j1_move(ctl, 0.5, speed=0.5, planned=False), queued=True)
    ctl.cmd_start(j1_move(ctl, -0.5, planned=False), queued=True)
    step(ctl, 20)
    assert len(ctl.queue) == 1
    getattr(ctl, f"cmd_{how}")()
    assert not ctl.queue
    if how == "abort":
        assert ctl.core.state == CoreState.READY and not ctl.core.is_moving
    run_until_idle(ctl)
    step(ctl, 10)
    assert ctl.started == 1  # the queued one never started
    assert 0.0 < ctl.core.kin.q[0] < 0.5


def test_a_queued_motion_that_cannot_start_raises_an_alarm(ctl: Controller):
    class Broken(JointMoveSpec):
        def build(self, kin: Kinematics, dt: float) -> Motion:
            raise ValueError("no time law")

    ready(ctl)
    ctl.cmd_start(j1_move(ctl, 0.1, planned=False), queued=True)
    broken = Broken(np.array([0]), np.array([0.0]), np.array([1.0]), np.array([1.0]))
    ctl.cmd_start(broken, queued=True)
    ctl.cmd_start(j1_move(ctl, 0.3, planned=False), queued=True)
    run_until_idle(ctl)
    assert ctl.core.state == CoreState.ALARM and not ctl.queue
    (alarm,) = ctl.core.alarms
    assert alarm.code == AlarmCode.TRAJECTORY_FAILURE and "no time law" in alarm.description


# ----------------------------------------------------------------------------- pause, stop
def test_urgent_commands_overtake_waiting_ones(ctl: Controller):
    """stop/pause/abort/servo off run before every other command waiting for the loop."""
    ready(ctl)
    start = Request("start", {"spec": j1_move(ctl, 0.5)})
    stop = Request("stop", {})
    ctl.inbox.put(start)  # arrived first...
    ctl.urgent.put(stop)  # ...but the stop runs first
    order: list[str] = []
    execute = ctl._execute

    def spy(request: Request) -> None:
        order.append(request.name)
        execute(request)

    ctl._execute = spy  # type: ignore[method-assign]
    step(ctl)
    assert order == ["stop", "start"]
    assert stop.ok and stop.done.is_set() and not start.done.is_set()
    step(ctl)  # the start's motion started, answered
    assert start.ok and start.done.is_set()


@pytest.mark.parametrize("name", ["stop", "pause", "abort", "servo_off"])
def test_submit_routes_urgent_commands_to_their_own_queue(ctl: Controller, name: str):
    ctl.submit(name, timeout=0.0)  # nobody steps: the request stays where submit put it
    assert ctl.inbox.empty() and not ctl.urgent.empty()
    ctl.submit("status", timeout=0.0)
    assert not ctl.inbox.empty()


def test_stop_from_idle_pause_goes_ready(ctl: Controller):
    ready(ctl)
    ctl.cmd_pause()
    step(ctl)
    assert read(ctl).core_state == CoreState.PAUSED and read(ctl).flags & snap.F_PAUSED
    ctl.cmd_stop()
    step(ctl)
    assert ctl.core.state == CoreState.READY


def test_settings_refused_while_moving(ctl: Controller):
    ready(ctl)
    ctl.cmd_start(j1_move(ctl, 0.5, speed=0.5))
    step(ctl)
    assert refused(ctl.cmd_reset_original_frame).code == ReturnCode.STATUS_ERR
    assert refused(ctl.cmd_set_control_point_offset, RightLeft.RIGHT, np.eye(4)).code == (
        ReturnCode.STATUS_ERR
    )
    assert refused(ctl.cmd_set_cartesian_box, RightLeft.RIGHT, None).code == ReturnCode.STATUS_ERR
    idx = np.array([0])
    limits = (np.array([-1.0]), np.array([1.0]))
    assert refused(ctl.cmd_set_joint_limits, idx, *limits).code == ReturnCode.STATUS_ERR


def test_joint_limits(ctl: Controller):
    ready(ctl)
    idx = np.array([0, 1])
    err = refused(ctl.cmd_set_joint_limits, idx, np.array([0.1, -1.0]), np.array([1.0, 1.0]))
    assert err.code == ReturnCode.VALUE_ERR and "J1" in err.comment
    ctl.cmd_set_joint_limits(idx, np.array([-0.2, -1.0]), np.array([0.2, 1.0]))
    box = ctl.core.ik.box
    assert box.q_min[0] == -0.2 and box.q_max[0] == 0.2 and box.q_max[1] == 1.0


# ----------------------------------------------------------------------------- supervision
def test_leaving_the_cartesian_box_raises_alarm_5(ctl: Controller):
    ready(ctl)
    p = ctl.core.kin.pose(RightLeft.RIGHT, FrameType.CURRENT_FRAME).translation
    margin = np.array([0.02, 0.02, 0.02])
    box = CartesianBox(p - margin, p + margin, np.eye(4))
    ctl.cmd_set_cartesian_box(RightLeft.RIGHT, box)
    ctl.cmd_start(j1_move(ctl, 0.5, speed=1.0))  # J1 swings the arm sideways
    for _ in range(2000):
        step(ctl)
        if ctl.core.state != CoreState.BUSY:
            break
    assert ctl.core.state == CoreState.ALARM
    (alarm,) = ctl.core.alarms
    assert alarm.code == AlarmCode.CARTESIAN_SOFT_LIMIT and alarm.module == "right_arm"
    assert "left the Cartesian soft limit" in alarm.description
    q = ctl.core.kin.pose(RightLeft.RIGHT, FrameType.CURRENT_FRAME).translation
    assert np.max(np.abs(q - p)) < 0.03  # stopped just outside the 20 mm margin
    # clearing the box and the alarm recovers
    ctl.cmd_clear_alarms()
    ctl.cmd_set_cartesian_box(RightLeft.RIGHT, None)
    ready(ctl)


def test_box_is_in_the_arm_frame(ctl: Controller):
    """A base offset moves the box with the arm frame: the same pose is inside or outside."""
    ready(ctl)
    p = ctl.core.kin.pose(RightLeft.RIGHT, FrameType.CURRENT_FRAME).translation
    shift = pin.SE3(np.eye(3), np.array([0.5, 0.0, 0.0])).homogeneous
    ctl.cmd_set_cartesian_box(
        RightLeft.RIGHT, CartesianBox(p - 0.01, p + 0.01, shift)
    )  # p sits 0.5 m outside in the arm frame
    ctl.cmd_start(j1_move(ctl, 0.01, speed=1.0))
    step(ctl, 3)
    assert ctl.core.state == CoreState.ALARM


def test_shutdown_decelerates_then_servo_off(ctl: Controller):
    ready(ctl)
    ctl.stop_timeout = 5.0
    ctl.cmd_start(j1_move(ctl, 1.0, speed=1.0))
    ctl.cmd_start(j1_move(ctl, 0.0, planned=False), queued=True)
    step(ctl, 100)
    ctl.shutdown_requested.set()
    cycles = 0
    while ctl._step(ctl.core.cycles, 0.0):  # True: keep running
        cycles += 1
        assert cycles < 2000
    assert cycles > 5  # it decelerated over several cycles
    assert ctl.core.state == CoreState.SERVO_OFF and not ctl.queue
    assert 0.0 < ctl.core.kin.q[0] < 1.0
    assert not read(ctl).servo_on


def test_shutdown_servo_off_after_the_timeout(ctl: Controller):
    ready(ctl)
    ctl.stop_timeout = 1e-6  # no time to decelerate
    ctl.cmd_start(j1_move(ctl, 1.0, speed=1.0))
    step(ctl, 100)
    ctl.shutdown_requested.set()
    ctl._step(ctl.core.cycles, 0.0)  # starts the stop, sets the deadline
    assert ctl._step(ctl.core.cycles, 0.0) is False  # past it: servo off, end
    assert ctl.core.state == CoreState.SERVO_OFF and ctl.core.kin.q[0] < 1.0


def test_a_request_whose_caller_gave_up_is_never_executed():
    from controller.control.process import Request

    request = Request("servo_off", {})
    request.cancelled = True
    calls = []
    handlers = {"servo_off": lambda: calls.append(1)}

    class Stub:
        _handlers = handlers

    from controller.control.process import Controller

    Controller._execute(Stub(), request)  # type: ignore[arg-type]
    assert calls == [] and not request.ok


@pytest.mark.parametrize("in_slack", [True, False])
def test_run_collects_garbage_only_in_the_slack_and_gives_the_collector_back(
    tmp_path: Path, in_slack: bool
):
    import gc

    r = robot("pa10")
    hw = IdealBackend(r, 1.0 / RATE)
    hw.configure()
    c = Controller(r, hw, RATE, tmp_path / "snapshot", collect_in_slack=in_slack)
    seen: list[bool] = []
    step_once = c._step

    def observed(cycle: int, t: float) -> bool:
        seen.append(gc.isenabled())
        return step_once(cycle, t) and cycle < 3

    c.loop.step = observed
    was = gc.isenabled()
    gc.enable()
    try:
        c.run()
        assert seen == [not in_slack] * 4
        assert gc.isenabled()  # as run() found it
        assert (c.collector is not None) == in_slack
    finally:
        (gc.enable if was else gc.disable)()
        c.close()


def test_the_slack_advances_the_hardware_after_each_step(tmp_path: Path):
    """The hardware's deferred work (the MuJoCo stand-in's physics step) runs after each
    step, in the loop's slack, never inside the step."""
    r = robot("pa10")
    hw = IdealBackend(r, 1.0 / RATE)
    hw.configure()
    c = Controller(r, hw, RATE, tmp_path / "snapshot")
    events: list[str] = []
    hw.advance = lambda: events.append("advance")  # type: ignore[method-assign]
    step_once = c._step

    def observed(cycle: int, t: float) -> bool:
        events.append("step")
        return step_once(cycle, t) and cycle < 2

    c.loop.step = observed
    try:
        c.run()
    finally:
        c.close()
    assert events == ["step", "advance", "step", "advance", "step"]


def test_a_kernel_compiled_while_the_loop_runs_is_logged_by_name(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
):
    """Every kernel is compiled or loaded before the loop starts; one that compiles in a
    cycle (a second without cycles on a fresh install: the drives lose the heartbeat) is
    a warning naming it, so the stall is explained."""
    import numba

    from controller.model import jit

    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")

    def late(x):  # type: ignore[no-untyped-def]
        return x + 1.0

    kernel = numba.njit(late)  # (no disk cache: a test's kernel)
    r = robot("pa10")
    hw = IdealBackend(r, 1.0 / RATE)
    hw.configure()
    c = Controller(r, hw, RATE, tmp_path / "snapshot")
    step_once = c._step

    def compiling(cycle: int, t: float) -> bool:
        if cycle == 1:
            kernel(1.0)
        return step_once(cycle, t) and cycle < 3

    c.loop.step = compiling
    try:
        with caplog.at_level("WARNING", logger="imotiond.control"):
            c.run()
        assert c.compiled_while_running == [f"{__name__}.late"]
        (record,) = [m for m in caplog.messages if "compiled" in m]
        assert f"{__name__}.late" in record and "while the control loop ran" in record
        kernel(2.0)  # after run(): no longer watched
        assert c.compiled_while_running == [f"{__name__}.late"]
    finally:
        c.close()
