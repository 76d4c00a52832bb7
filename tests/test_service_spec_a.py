"""Spec A (IntegratedMotion) end to end over real gRPC on 127.0.0.1.

One daemon per robot for the whole module (ideal drives, 250 Hz loop); every test starts from
the start-up pose in Ready (:meth:`Robot.home`). Covered: every RPC at least once, the return
code of every motion operation in every state, invalid arguments (VALUE_ERR naming the
argument, nothing moves), reachability (CANNOT_REACH_TARGET_ERR before motion), unit round
trips, pause/resume/stop/abort, and a linear move watched through Monitor.StreamState.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterator
from typing import Any

import grpc
import numpy as np
import pytest

from controller.model.alarms import AlarmCode
from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode, RightLeft
from controller.vocabulary import SpecAState as S
from hal.interface import HardwareFault
from tests.daemon_support import TestDaemon

RIGHT, LEFT = pb.RIGHT, pb.LEFT
ARM_SPEED, ARM_ACCEL = [30.0], [100.0]  # deg/s, deg/s²
CART_SPEED = pb.CartesianSpeed(translation=100.0, rotation=30.0)  # mm/s, deg/s
CART_ACCEL = pb.CartesianAccel(translation=500.0, rotation=100.0)
RED_SPEED = pb.RedundantSpeed(elbow=60, lumbar_ry=10, vehicle_translation=200, vehicle_rotation=20)
RED_ACCEL = pb.RedundantAccel(elbow=200, lumbar_ry=30, vehicle_translation=400, vehicle_rotation=60)
GRIPPER_OPS = {"OpenGripper", "CloseGripper", "MoveGripper"}
#: Operations whose original lists NOT_SV_ON_ERR (others answer STATUS_ERR when servo off).
SV_ON_LISTED = GRIPPER_OPS | {"MovePTPCartesianAbs", "MovePTPCartesianRel"}


# ----------------------------------------------------------------------------- helpers
def hg(rot: np.ndarray | None = None, p: Any = (0.0, 0.0, 0.0)) -> pb.HgMatrix:
    """HgMatrix of a rotation and a translation [mm]."""
    m = np.zeros((3, 4))
    m[:, :3] = np.eye(3) if rot is None else rot
    m[:, 3] = p
    return pb.HgMatrix(m=m.ravel().tolist())


def hg_of(pose_mm: np.ndarray) -> pb.HgMatrix:
    return pb.HgMatrix(m=pose_mm[:3].ravel().tolist())


def rot_x(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def code(response: Any) -> int:
    return int(response.return_id.id)


def ok(response: Any) -> Any:
    assert response.return_id.id == ReturnCode.OK, response.return_id.comment
    return response


def pose(d: TestDaemon, side: int = RIGHT, frame: int = pb.ORIGINAL_FRAME) -> tuple[Any, float]:
    """(4x4 pose with p in mm, elbow [deg]) from getFeedbackPosCartesian."""
    request = pb.GetFeedbackPosCartesianRequest(type=side, frame_type=frame)
    r = ok(d.spec_a.GetFeedbackPosCartesian(request))
    m = np.vstack([np.array(r.pos.car_pos.m).reshape(3, 4), [0.0, 0.0, 0.0, 1.0]])
    return m, r.pos.elbow


def joints(d: TestDaemon, unit: int) -> np.ndarray:
    r = ok(d.spec_a.GetFeedbackPosJoint(pb.GetFeedbackPosJointRequest(type=unit)))
    return np.array(r.position)


def measured(d: TestDaemon) -> np.ndarray:
    """Every hardware joint [rad, m], straight from the snapshot."""
    return d.ctx.snapshot().q


def moving(d: TestDaemon) -> bool:
    return bool(d.spec_a.IsMoving(pb.IsMovingRequest()).is_moving)


def wait_state(d: TestDaemon, state: int, timeout: float = 20.0) -> None:
    assert d.wait_for(lambda: d.state() == state, timeout), (
        f"state {d.state():#x}, expected {state:#x}"
    )


def wait_cycles(d: TestDaemon, n: int = 5) -> None:
    start = d.ctx.snapshot().cycle
    assert d.wait_for(lambda: d.ctx.snapshot().cycle >= start + n, 10.0)


def wait_at_rest(d: TestDaemon) -> None:
    """Until the joints stop changing (a paused motion has decelerated)."""

    def at_rest() -> bool:
        before = measured(d)
        wait_cycles(d, 3)
        return bool(np.array_equal(measured(d), before))

    assert d.wait_for(at_rest, 10.0)


def assert_still(d: TestDaemon, before: np.ndarray) -> None:
    """Nothing moved: not moving, and every joint where it was a few cycles later."""
    wait_cycles(d)
    assert not moving(d)
    np.testing.assert_allclose(measured(d), before, rtol=0, atol=1e-12)


def select(d: TestDaemon, **mask: bool) -> Any:
    return d.spec_a.SelectRedundantAxes(
        pb.SelectRedundantAxesRequest(
            redundancy=pb.RedundantAxesMask(**mask), limit=pb.RedundantLimit()
        )
    )


class Robot:
    """A module-wide daemon and what brings it back to its start-up state."""

    def __init__(self, d: TestDaemon):
        self.d = d
        ok(d.spec_a.ServoOn(pb.ServoOnRequest()))
        wait_state(d, S.READY)
        self.initial = measured(d).copy()
        snap = d.ctx.snapshot()
        self.offsets = {}
        for side in d.ctx.view.arms:
            m = snap.offsets[int(side)].copy()
            m[:, 3] *= 1e3  # m -> mm
            self.offsets[int(side)] = pb.HgMatrix(m=m.ravel().tolist())

    def home(self) -> TestDaemon:
        """Start-up pose in Ready: faults and alarms gone, frames, offsets and mask default."""
        d, s = self.d, self.d.spec_a
        s.Abort(pb.AbortRequest())
        s.ServoOff(pb.ServoOffRequest())
        hw = d.daemon.hw
        hw.reset_faults()  # type: ignore[attr-defined]
        s.ClearAlarms(pb.ClearAlarmsRequest())
        hw.place(dict(zip(hw.joint_names, self.initial, strict=True)))  # type: ignore[attr-defined]
        ok(s.ServoOn(pb.ServoOnRequest()))
        wait_state(d, S.READY)
        ok(s.ResetOriginalFrame(pb.ResetOriginalFrameRequest()))
        for side, offset in self.offsets.items():
            ok(s.SetControlPointOffset(pb.SetControlPointOffsetRequest(type=side, offset=offset)))
        ok(select(d, elbow=True))
        return d


@pytest.fixture(scope="module")
def sp5() -> Iterator[Robot]:
    d = TestDaemon("smartpal5", "ideal", 250.0)
    try:
        yield Robot(d)
    finally:
        d.close()


@pytest.fixture
def d(sp5: Robot) -> TestDaemon:
    return sp5.home()


@pytest.fixture(scope="module")
def pa10_robot() -> Iterator[Robot]:
    d = TestDaemon("pa10", "ideal", 250.0)
    try:
        yield Robot(d)
    finally:
        d.close()


@pytest.fixture
def pa10(pa10_robot: Robot) -> TestDaemon:
    return pa10_robot.home()


# ----------------------------------------------------------------------------- states
def start_long_motion(d: TestDaemon) -> None:
    """A slow right-arm move (~10 s): the robot is Busy for the rest of the test."""
    request = pb.MoveUnitRelRequest(
        unit=pb.RIGHT_ARM, rel_pos=[40, 0, 0, 0, 0, 0, 0], speed=[4.0], accel=[20.0]
    )
    ok(d.spec_a.MoveUnitRel(request))
    wait_state(d, S.BUSY)


def inject_fault(d: TestDaemon) -> None:
    fault = HardwareFault(int(AlarmCode.DRIVE_FAULT), "r_arm_j3", "test: overcurrent")
    d.daemon.hw.inject_fault(fault)  # type: ignore[attr-defined]
    wait_state(d, S.ALARM)


def enter(d: TestDaemon, state: S) -> None:
    s = d.spec_a
    if state == S.SERVO_OFF:
        ok(s.ServoOff(pb.ServoOffRequest()))
    elif state == S.BUSY:
        start_long_motion(d)
    elif state == S.PAUSE:
        start_long_motion(d)
        ok(s.Pause(pb.PauseRequest()))
        wait_state(d, S.PAUSE)
        wait_at_rest(d)
    elif state == S.ALARM:
        inject_fault(d)
    wait_state(d, state)


def motion_ops(d: TestDaemon) -> dict[str, Any]:
    """One valid request per Spec A motion operation (accepted in Ready at home)."""
    m, elbow = pose(d)
    lumbar_ry = float(joints(d, pb.LUMBER).sum())
    vx, vy, vth = joints(d, pb.VEHICLE)
    up = m.copy()
    up[2, 3] += 20.0
    rel = hg(p=(0.0, 0.0, 20.0))
    return {
        "MoveUnitAbs": pb.MoveUnitAbsRequest(
            unit=pb.RIGHT_ARM, abs_pos=[5, -10, 0, 90, 0, 0, 0], speed=ARM_SPEED, accel=ARM_ACCEL
        ),
        "MoveUnitRel": pb.MoveUnitRelRequest(
            unit=pb.RIGHT_ARM, rel_pos=[2, 0, 0, 0, 0, 0, 0], speed=ARM_SPEED, accel=ARM_ACCEL
        ),
        "MoveCPHoldAbs": pb.MoveCPHoldAbsRequest(
            type=RIGHT,
            abs_pos=pb.RedundantPos(
                elbow=elbow + 5,
                lumbar_ry=lumbar_ry,
                vehicle_x=vx,
                vehicle_y=vy,
                vehicle_theta=vth,
            ),
            speed=RED_SPEED,
            accel=RED_ACCEL,
        ),
        "MoveCPHoldRel": pb.MoveCPHoldRelRequest(
            type=RIGHT, rel_pos=pb.RedundantPos(elbow=5), speed=RED_SPEED, accel=RED_ACCEL
        ),
        "MoveLinearCartesianAbs": pb.MoveLinearCartesianAbsRequest(
            type=RIGHT, abs_hg_mat=hg_of(up), speed=CART_SPEED, accel=CART_ACCEL
        ),
        "MoveLinearCartesianRel": pb.MoveLinearCartesianRelRequest(
            type=RIGHT,
            frame_type=pb.BASE_FRAME,
            rel_hg_mat=rel,
            speed=CART_SPEED,
            accel=CART_ACCEL,
        ),
        "MovePTPCartesianAbs": pb.MovePTPCartesianAbsRequest(
            type=RIGHT, abs_hg_mat=hg_of(up), time=1.0
        ),
        "MovePTPCartesianRel": pb.MovePTPCartesianRelRequest(type=RIGHT, rel_hg_mat=rel, time=1.0),
        "OpenGripper": pb.OpenGripperRequest(type=RIGHT),
        "CloseGripper": pb.CloseGripperRequest(type=LEFT),
        "MoveGripper": pb.MoveGripperRequest(type=RIGHT, angle_ratio=50),
    }


def expected_code(op: str, state: S) -> ReturnCode:
    """interfaces.md: motion only from Ready; Spec A never queues; NOT_SV_ON_ERR where the
    original lists it. Grippers are their own unit: they may move beside a running motion
    (Busy) but not while paused."""
    if state == S.READY:
        return ReturnCode.OK
    if state in (S.UNPOWERED, S.SERVO_OFF):
        return ReturnCode.NOT_SV_ON_ERR if op in SV_ON_LISTED else ReturnCode.STATUS_ERR
    if state == S.BUSY and op in GRIPPER_OPS:
        return ReturnCode.OK
    return ReturnCode.STATUS_ERR


def codes_in_state(d: TestDaemon, state: S) -> dict[str, int]:
    ops = motion_ops(d)
    enter(d, state)
    got = {}
    for name, request in ops.items():
        before = measured(d)
        got[name] = code(getattr(d.spec_a, name)(request))
        if state == S.READY:
            if got[name] == ReturnCode.OK and name != "CloseGripper":  # closed already at home
                assert moving(d), f"{name} accepted but nothing moves"
            ok(d.spec_a.Abort(pb.AbortRequest()))
            wait_state(d, S.READY)
        else:
            assert d.state() == state, f"{name} changed the state"
            if state in (S.UNPOWERED, S.SERVO_OFF, S.ALARM):
                assert_still(d, before)
    return got


@pytest.mark.parametrize(
    "state", [S.SERVO_OFF, S.READY, S.BUSY, S.PAUSE, S.ALARM], ids=lambda s: s.name
)
def test_motion_op_codes_in_each_state(d: TestDaemon, state: S):
    got = codes_in_state(d, state)
    want = {name: int(expected_code(name, state)) for name in got}
    assert got == want


@pytest.fixture(scope="module")
def unpowered() -> Iterator[TestDaemon]:
    d = TestDaemon("smartpal5", "ideal", 250.0, power_on_at_start=False)
    try:
        yield d
    finally:
        d.close()


def test_unpowered_codes_then_servo_on(unpowered: TestDaemon):
    d = unpowered
    assert d.state() == S.UNPOWERED
    assert not d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on
    got = {}
    for name, request in motion_ops(d).items():
        got[name] = code(getattr(d.spec_a, name)(request))
        assert d.state() == S.UNPOWERED
    assert got == {name: int(expected_code(name, S.UNPOWERED)) for name in got}
    assert not moving(d)
    ok(d.spec_a.ServoOn(pb.ServoOnRequest()))
    wait_state(d, S.READY)
    assert d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on
    np.testing.assert_allclose(joints(d, pb.RIGHT_ARM), [0, -10, 0, 90, 0, 0, 0], atol=1e-9)
    ok(d.spec_a.ServoOff(pb.ServoOffRequest()))
    wait_state(d, S.SERVO_OFF)  # powered now: ServoOff, not Unpowered


def test_always_ok_operations_in_every_state(d: TestDaemon):
    """abort, clearAlarms, pause, resume, stop, getters: always OK (whatever the state)."""
    always = {
        "Abort": pb.AbortRequest(),
        "Pause": pb.PauseRequest(),
        "Resume": pb.ResumeRequest(),
        "Stop": pb.StopRequest(),
        "GetActiveAlarm": pb.GetActiveAlarmRequest(),
        "GetState": pb.GetStateRequest(),
        "GetVersion": pb.GetVersionRequest(),
        "IsMoving": pb.IsMovingRequest(),
        "IsServoOn": pb.IsServoOnRequest(),
    }
    for state in (S.SERVO_OFF, S.ALARM):
        enter(d, state)
        for name, request in always.items():
            assert code(getattr(d.spec_a, name)(request)) == ReturnCode.OK, (name, state)
        assert d.state() == state
    ok(d.spec_a.ClearAlarms(pb.ClearAlarmsRequest()))


# ----------------------------------------------------------------------------- servo, alarms
def test_alarm_is_reported_and_cleared(d: TestDaemon):
    start_long_motion(d)
    inject_fault(d)
    assert not moving(d)
    alarms = ok(d.spec_a.GetActiveAlarm(pb.GetActiveAlarmRequest())).alarms
    assert [a.code for a in alarms] == [AlarmCode.DRIVE_FAULT]
    assert alarms[0].module_name == "r_arm_j3" and "overcurrent" in alarms[0].description
    assert alarms[0].type == pb.FAULT
    assert not d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on
    assert code(d.spec_a.ServoOn(pb.ServoOnRequest())) == ReturnCode.NG
    # clearAlarms resets the drive fault; the drives stay off until servoOn.
    ok(d.spec_a.ClearAlarms(pb.ClearAlarmsRequest()))
    wait_cycles(d)
    assert d.state() == S.SERVO_OFF
    assert not ok(d.spec_a.GetActiveAlarm(pb.GetActiveAlarmRequest())).alarms
    ok(d.spec_a.ServoOn(pb.ServoOnRequest()))
    wait_state(d, S.READY)
    ok(d.spec_a.MoveUnitRel(motion_ops(d)["MoveUnitRel"]))


def test_servo_off_during_motion_drops_it(d: TestDaemon):
    start_long_motion(d)
    ok(d.spec_a.ServoOff(pb.ServoOffRequest()))
    wait_state(d, S.SERVO_OFF)
    assert not d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on
    assert not moving(d)
    before = measured(d)
    ok(d.spec_a.ServoOn(pb.ServoOnRequest()))
    wait_state(d, S.READY)
    assert_still(d, before)  # the dropped motion does not come back


# ----------------------------------------------------------------------------- pause etc.
def test_pause_and_resume_when_idle(d: TestDaemon):
    ok(d.spec_a.Pause(pb.PauseRequest()))
    assert d.state() == S.PAUSE
    ok(d.spec_a.Pause(pb.PauseRequest()))
    assert d.state() == S.PAUSE  # already paused stays paused
    ok(d.spec_a.Resume(pb.ResumeRequest()))
    assert d.state() == S.READY
    ok(d.spec_a.Resume(pb.ResumeRequest()))
    assert d.state() == S.READY  # no change


def test_stop_from_idle_pause_goes_ready(d: TestDaemon):
    ok(d.spec_a.Pause(pb.PauseRequest()))
    assert d.state() == S.PAUSE
    ok(d.spec_a.Stop(pb.StopRequest()))
    wait_state(d, S.READY, 2.0)


def test_pause_resume_completes_the_motion(d: TestDaemon):
    target = [6, -10, 0, 90, 0, 0, 0]
    request = pb.MoveUnitAbsRequest(unit=pb.RIGHT_ARM, abs_pos=target, speed=[20], accel=[40])
    ok(d.spec_a.MoveUnitAbs(request))
    assert d.state() == S.BUSY
    ok(d.spec_a.Pause(pb.PauseRequest()))
    wait_state(d, S.PAUSE)  # Busy while decelerating, then Pause
    wait_at_rest(d)
    held = joints(d, pb.RIGHT_ARM)
    assert held[0] < 6.0 - 0.5
    wait_cycles(d, 10)
    np.testing.assert_allclose(joints(d, pb.RIGHT_ARM), held, atol=1e-9)
    ok(d.spec_a.Resume(pb.ResumeRequest()))
    assert d.state() == S.BUSY
    assert d.wait_idle(20.0)
    assert d.state() == S.READY
    np.testing.assert_allclose(joints(d, pb.RIGHT_ARM), target, atol=1e-3)


def test_stop_from_pause_drops_the_motion(d: TestDaemon):
    start_long_motion(d)
    ok(d.spec_a.Pause(pb.PauseRequest()))
    ok(d.spec_a.Stop(pb.StopRequest()))
    wait_state(d, S.READY)
    assert not moving(d)
    held = joints(d, pb.RIGHT_ARM)
    assert held[0] < 10.0  # far from the +40 deg target
    ok(d.spec_a.Resume(pb.ResumeRequest()))
    wait_cycles(d, 10)
    assert d.state() == S.READY
    np.testing.assert_allclose(joints(d, pb.RIGHT_ARM), held, atol=1e-9)


def test_pause_stop_resume_states_are_exact(d: TestDaemon):
    """Issue 16.13: a fully paused robot is not moving; stop in Pause is Ready at once (the
    answer comes after the snapshot shows it); resume then changes nothing; the texts say
    "paused", not "pause" or "moves"."""
    start_long_motion(d)
    ok(d.spec_a.Pause(pb.PauseRequest()))
    wait_state(d, S.PAUSE)
    wait_at_rest(d)
    assert not moving(d)  # paused and still
    refused = d.spec_a.ResetOriginalFrame(pb.ResetOriginalFrameRequest())
    assert code(refused) == ReturnCode.STATUS_ERR
    assert "paused" in refused.return_id.comment and "moves" not in refused.return_id.comment
    move = pb.MoveUnitRelRequest(
        unit=pb.RIGHT_ARM, rel_pos=[1, 0, 0, 0, 0, 0, 0], speed=[4.0], accel=[20.0]
    )
    busy = d.spec_a.MoveUnitRel(move)
    assert code(busy) == ReturnCode.STATUS_ERR and "the robot is paused" in busy.return_id.comment
    ok(d.spec_a.Stop(pb.StopRequest()))
    assert d.state() == S.READY and not moving(d)  # at once, no settling time
    ok(d.spec_a.Resume(pb.ResumeRequest()))
    for _ in range(5):
        assert d.state() == S.READY and not moving(d)
        wait_cycles(d, 5)


def test_stop_decelerates_to_ready(d: TestDaemon):
    start_long_motion(d)
    wait_cycles(d, 50)
    ok(d.spec_a.Stop(pb.StopRequest()))
    at_stop = joints(d, pb.RIGHT_ARM)[0]
    wait_state(d, S.READY)
    stopped = joints(d, pb.RIGHT_ARM)[0]
    assert at_stop <= stopped < at_stop + 3.0  # decelerated: went on a little, not to +40


def test_abort_goes_ready_at_once(d: TestDaemon):
    start_long_motion(d)
    wait_cycles(d, 50)
    ok(d.spec_a.Abort(pb.AbortRequest()))
    assert d.state() == S.READY  # at once, not after a deceleration
    assert not moving(d)
    held = measured(d)
    assert_still(d, held)
    # abort from Pause too
    start_long_motion(d)
    ok(d.spec_a.Pause(pb.PauseRequest()))
    ok(d.spec_a.Abort(pb.AbortRequest()))
    assert d.state() == S.READY


# ----------------------------------------------------------------------------- invalid args
Case = tuple[str, Callable[[TestDaemon], Any], str]

NAN, INF = float("nan"), float("inf")


def _linear_abs(d: TestDaemon, **kw: Any) -> Any:
    m, _ = pose(d)
    args: dict[str, Any] = {
        "type": RIGHT,
        "abs_hg_mat": hg_of(m),
        "speed": CART_SPEED,
        "accel": CART_ACCEL,
    }
    args.update(kw)
    return pb.MoveLinearCartesianAbsRequest(**args)


def _unit_abs(**kw: Any) -> Any:
    args: dict[str, Any] = {
        "unit": pb.RIGHT_ARM,
        "abs_pos": [2, -10, 0, 90, 0, 0, 0],
        "speed": [10],
        "accel": [50],
    }
    args.update(kw)
    return pb.MoveUnitAbsRequest(**args)


def _vehicle(**kw: Any) -> Any:
    args: dict[str, Any] = {
        "unit": pb.VEHICLE,
        "rel_pos": [10, 0, 0],
        "speed": [100, 10],
        "accel": [300, 30],
    }
    args.update(kw)
    return pb.MoveUnitRelRequest(**args)


def _cp_rel(**kw: Any) -> Any:
    args: dict[str, Any] = {
        "type": RIGHT,
        "rel_pos": pb.RedundantPos(elbow=5),
        "speed": RED_SPEED,
        "accel": RED_ACCEL,
    }
    args.update(kw)
    return pb.MoveCPHoldRelRequest(**args)


def _limit(**kw: Any) -> Any:
    return pb.SelectRedundantAxesRequest(
        redundancy=pb.RedundantAxesMask(elbow=True), limit=pb.RedundantLimit(**kw)
    )


SKEW = np.array([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
MIRROR = np.diag([1.0, 1.0, -1.0])
UP = hg(p=(0.0, 0.0, 10.0))

SP5_CASES: list[Case] = [
    # moveUnitAbs / moveUnitRel
    ("MoveUnitAbs", lambda d: _unit_abs(abs_pos=[0, 0, 0, 0, 0, 0]), "abs_pos"),
    ("MoveUnitAbs", lambda d: _unit_abs(abs_pos=[0, -10, NAN, 90, 0, 0, 0]), "abs_pos[2]"),
    ("MoveUnitAbs", lambda d: _unit_abs(abs_pos=[INF, -10, 0, 90, 0, 0, 0]), "abs_pos[0]"),
    ("MoveUnitAbs", lambda d: _unit_abs(speed=[0]), "speed[0]"),
    ("MoveUnitAbs", lambda d: _unit_abs(speed=[-5]), "speed[0]"),
    ("MoveUnitAbs", lambda d: _unit_abs(speed=[NAN]), "speed[0]"),
    ("MoveUnitAbs", lambda d: _unit_abs(speed=[10, 10, 10]), "speed"),
    ("MoveUnitAbs", lambda d: _unit_abs(speed=[10, 10, 10, 10, 5000, 10, 10]), "speed[4]"),
    ("MoveUnitAbs", lambda d: _unit_abs(accel=[0]), "accel[0]"),
    ("MoveUnitAbs", lambda d: _unit_abs(accel=[1e7]), "accel[0]"),
    ("MoveUnitAbs", lambda d: _unit_abs(abs_pos=[500, -10, 0, 90, 0, 0, 0]), "r_arm"),
    ("MoveUnitAbs", lambda d: _unit_abs(unit=7), "unit"),
    (
        "MoveUnitRel",
        lambda d: pb.MoveUnitRelRequest(unit=pb.LUMBER, rel_pos=[1, 2, 3], speed=[5], accel=[20]),
        "rel_pos",
    ),
    ("MoveUnitRel", lambda d: _vehicle(rel_pos=[10, NAN, 0]), "rel_pos[1]"),
    ("MoveUnitRel", lambda d: _vehicle(speed=[100]), "speed"),
    ("MoveUnitRel", lambda d: _vehicle(speed=[0, 10]), "speed[0]"),
    ("MoveUnitRel", lambda d: _vehicle(speed=[5000, 10]), "speed[0]"),
    ("MoveUnitRel", lambda d: _vehicle(accel=[300, -1]), "accel[1]"),
    # moveCPHoldAbs / moveCPHoldRel
    ("MoveCPHoldRel", lambda d: _cp_rel(rel_pos=pb.RedundantPos(elbow=NAN)), "rel_pos.elbow"),
    ("MoveCPHoldRel", lambda d: _cp_rel(speed=pb.RedundantSpeed(elbow=0)), "speed.elbow"),
    ("MoveCPHoldRel", lambda d: _cp_rel(speed=pb.RedundantSpeed(elbow=INF)), "speed.elbow"),
    ("MoveCPHoldRel", lambda d: _cp_rel(accel=pb.RedundantAccel(elbow=-3)), "accel.elbow"),
    ("MoveCPHoldRel", lambda d: _cp_rel(rel_pos=pb.RedundantPos(lumbar_ry=400)), "lumbar_ry"),
    ("MoveCPHoldRel", lambda d: _cp_rel(type=4), "type"),
    (
        "MoveCPHoldAbs",
        lambda d: pb.MoveCPHoldAbsRequest(
            type=RIGHT, abs_pos=pb.RedundantPos(vehicle_x=INF), speed=RED_SPEED, accel=RED_ACCEL
        ),
        "abs_pos.vehicle_x",
    ),
    # moveLinearCartesianAbs / Rel
    (
        "MoveLinearCartesianAbs",
        lambda d: _linear_abs(d, abs_hg_mat=pb.HgMatrix(m=[1.0] * 11)),
        "abs_hg_mat",
    ),
    ("MoveLinearCartesianAbs", lambda d: _linear_abs(d, abs_hg_mat=hg(SKEW)), "orthonormal"),
    ("MoveLinearCartesianAbs", lambda d: _linear_abs(d, abs_hg_mat=hg(MIRROR)), "determinant"),
    (
        "MoveLinearCartesianAbs",
        lambda d: _linear_abs(d, abs_hg_mat=hg(p=(0, NAN, 0))),
        "abs_hg_mat",
    ),
    (
        "MoveLinearCartesianAbs",
        lambda d: _linear_abs(d, speed=pb.CartesianSpeed(translation=0, rotation=10)),
        "speed.translation",
    ),
    (
        "MoveLinearCartesianAbs",
        lambda d: _linear_abs(d, speed=pb.CartesianSpeed(translation=10, rotation=INF)),
        "speed.rotation",
    ),
    (
        "MoveLinearCartesianAbs",
        lambda d: _linear_abs(d, accel=pb.CartesianAccel(translation=-1, rotation=10)),
        "accel.translation",
    ),
    ("MoveLinearCartesianAbs", lambda d: _linear_abs(d, type=2), "type"),
    (
        "MoveLinearCartesianRel",
        lambda d: pb.MoveLinearCartesianRelRequest(
            type=RIGHT, frame_type=5, rel_hg_mat=UP, speed=CART_SPEED, accel=CART_ACCEL
        ),
        "frame_type",
    ),
    (
        "MoveLinearCartesianRel",
        lambda d: pb.MoveLinearCartesianRelRequest(
            type=RIGHT, rel_hg_mat=hg(SKEW), speed=CART_SPEED, accel=CART_ACCEL
        ),
        "rel_hg_mat",
    ),
    # movePTPCartesianAbs / Rel
    (
        "MovePTPCartesianAbs",
        lambda d: pb.MovePTPCartesianAbsRequest(type=RIGHT, abs_hg_mat=hg_of(pose(d)[0]), time=0.0),
        "time",
    ),
    (
        "MovePTPCartesianAbs",
        lambda d: pb.MovePTPCartesianAbsRequest(type=RIGHT, abs_hg_mat=hg_of(pose(d)[0]), time=NAN),
        "time",
    ),
    (
        "MovePTPCartesianAbs",
        lambda d: pb.MovePTPCartesianAbsRequest(type=RIGHT, abs_hg_mat=hg(MIRROR), time=1.0),
        "abs_hg_mat",
    ),
    (
        "MovePTPCartesianRel",
        lambda d: pb.MovePTPCartesianRelRequest(type=RIGHT, rel_hg_mat=UP, time=-1.0),
        "time",
    ),
    (
        "MovePTPCartesianRel",
        lambda d: pb.MovePTPCartesianRelRequest(
            type=RIGHT, rel_hg_mat=hg(rot_x(60), (0, 100, 0)), time=0.01
        ),
        "time",
    ),
    (
        "MovePTPCartesianRel",
        lambda d: pb.MovePTPCartesianRelRequest(
            type=RIGHT, rel_hg_mat=pb.HgMatrix(m=[0.0] * 13), time=1.0
        ),
        "rel_hg_mat",
    ),
    (
        "MovePTPCartesianRel",
        lambda d: pb.MovePTPCartesianRelRequest(type=RIGHT, rel_hg_mat=UP, time=1e5),
        "time",
    ),
    (
        "MoveUnitRel",
        lambda d: _vehicle(rel_pos=[1e300, 0, 0]),
        "rel_pos[0]: 1e+300 mm is out of range",
    ),
    # grippers
    ("MoveGripper", lambda d: pb.MoveGripperRequest(type=RIGHT, angle_ratio=101), "angle_ratio"),
    ("MoveGripper", lambda d: pb.MoveGripperRequest(type=3, angle_ratio=50), "type"),
    ("OpenGripper", lambda d: pb.OpenGripperRequest(type=2), "type"),
    ("CloseGripper", lambda d: pb.CloseGripperRequest(type=-1), "type"),
    # settings and queries
    (
        "SelectRedundantAxes",
        lambda d: _limit(right_elbow=pb.LimitValue(upper=-10, lower=10)),
        "limit.right_elbow",
    ),
    (
        "SelectRedundantAxes",
        lambda d: _limit(lumbar_ry=pb.LimitValue(upper=170, lower=0)),
        "limit.lumbar_ry",
    ),
    (
        "SelectRedundantAxes",
        lambda d: _limit(left_elbow=pb.LimitValue(upper=200, lower=-200)),
        "limit.left_elbow",
    ),
    (
        "SelectRedundantAxes",
        lambda d: _limit(vehicle_x=pb.LimitValue(upper=NAN, lower=0)),
        "limit.vehicle_x.upper",
    ),
    (
        "SetControlPointOffset",
        lambda d: pb.SetControlPointOffsetRequest(type=RIGHT, offset=hg(SKEW)),
        "offset",
    ),
    (
        "SetControlPointOffset",
        lambda d: pb.SetControlPointOffsetRequest(type=RIGHT, offset=hg(p=(0, 0, 3000))),
        "offset",
    ),
    (
        "GetFeedbackPosCartesian",
        lambda d: pb.GetFeedbackPosCartesianRequest(type=RIGHT, frame_type=7),
        "frame_type",
    ),
    ("GetFeedbackPosJoint", lambda d: pb.GetFeedbackPosJointRequest(type=9), "type"),
    ("GetGripperPos", lambda d: pb.GetGripperPosRequest(type=5), "type"),
]


def _check_rejected(d: TestDaemon, name: str, request: Any, fragment: str) -> None:
    before = measured(d)
    reply = getattr(d.spec_a, name)(request)
    assert code(reply) == ReturnCode.VALUE_ERR, reply.return_id
    comment = reply.return_id.comment
    assert fragment in comment, comment
    assert d.state() == S.READY
    assert_still(d, before)


@pytest.mark.parametrize(
    "name, build, fragment", SP5_CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(SP5_CASES)]
)
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")  # the 1e300 mm one
def test_invalid_arguments_smartpal5(d: TestDaemon, name: str, build: Any, fragment: str):
    _check_rejected(d, name, build(d), fragment)


def _pa10_cases() -> list[Case]:
    left = "LEFT arm"
    cases: list[Case] = [
        ("CloseGripper", lambda d: pb.CloseGripperRequest(type=LEFT), left),
        ("OpenGripper", lambda d: pb.OpenGripperRequest(type=LEFT), left),
        ("MoveGripper", lambda d: pb.MoveGripperRequest(type=LEFT, angle_ratio=10), left),
        ("GetGripperPos", lambda d: pb.GetGripperPosRequest(type=LEFT), left),
        ("GetFeedbackPosCartesian", lambda d: pb.GetFeedbackPosCartesianRequest(type=LEFT), left),
        (
            "SetControlPointOffset",
            lambda d: pb.SetControlPointOffsetRequest(type=LEFT, offset=hg()),
            left,
        ),
        (
            "MoveCPHoldAbs",
            lambda d: pb.MoveCPHoldAbsRequest(type=LEFT, speed=RED_SPEED, accel=RED_ACCEL),
            left,
        ),
        ("MoveCPHoldRel", lambda d: _cp_rel(type=LEFT), left),
        ("MoveLinearCartesianAbs", lambda d: _linear_abs(d, type=LEFT), left),
        (
            "MoveLinearCartesianRel",
            lambda d: pb.MoveLinearCartesianRelRequest(
                type=LEFT, rel_hg_mat=UP, speed=CART_SPEED, accel=CART_ACCEL
            ),
            left,
        ),
        (
            "MovePTPCartesianAbs",
            lambda d: pb.MovePTPCartesianAbsRequest(
                type=LEFT, abs_hg_mat=hg_of(pose(d)[0]), time=1.0
            ),
            left,
        ),
        (
            "MovePTPCartesianRel",
            lambda d: pb.MovePTPCartesianRelRequest(type=LEFT, rel_hg_mat=UP, time=1.0),
            left,
        ),
    ]
    for unit, word in ((pb.LEFT_ARM, "LEFT_ARM"), (pb.LUMBER, "LUMBER"), (pb.VEHICLE, "VEHICLE")):
        cases += [
            (
                "MoveUnitAbs",
                lambda d, u=unit: pb.MoveUnitAbsRequest(
                    unit=u, abs_pos=[0, 0, 0], speed=[1, 1], accel=[1, 1]
                ),
                word,
            ),
            (
                "MoveUnitRel",
                lambda d, u=unit: pb.MoveUnitRelRequest(
                    unit=u, rel_pos=[0, 0, 0], speed=[1, 1], accel=[1, 1]
                ),
                word,
            ),
            ("GetFeedbackPosJoint", lambda d, u=unit: pb.GetFeedbackPosJointRequest(type=u), word),
        ]
    # pa10 joint 1 speed limit is 180 deg/s
    cases.append(
        (
            "MoveUnitRel",
            lambda d: pb.MoveUnitRelRequest(
                unit=pb.RIGHT_ARM, rel_pos=[5, 0, 0, 0, 0, 0, 0], speed=[181], accel=[100]
            ),
            "speed[0]",
        )
    )
    return cases


PA10_CASES = _pa10_cases()


@pytest.mark.parametrize(
    "name, build, fragment",
    PA10_CASES,
    ids=[f"{c[0]}-{c[2]}-{i}" for i, c in enumerate(PA10_CASES)],
)
def test_invalid_arguments_pa10(pa10: TestDaemon, name: str, build: Any, fragment: str):
    _check_rejected(pa10, name, build(pa10), fragment)


def test_pa10_right_is_the_arm_and_lumbar_vehicle_masks_are_ignored(pa10: TestDaemon):
    r = ok(select(pa10, elbow=True, lumbar_ry=True, vehicle_x=True))
    assert "lumbarRy" in r.return_id.comment and "vehicleX" in r.return_id.comment
    assert "leftElbow" not in r.return_id.comment  # the elbow bit is the one arm's elbow
    assert select(pa10, elbow=True).return_id.comment == "OK"
    ok(pa10.spec_a.MoveGripper(pb.MoveGripperRequest(type=RIGHT, angle_ratio=30)))
    assert pa10.wait_idle(10.0)
    assert ok(pa10.spec_a.GetGripperPos(pb.GetGripperPosRequest(type=RIGHT))).angle_ratio == 30
    assert len(joints(pa10, pb.RIGHT_ARM)) == 7


# ----------------------------------------------------------------------------- reachability
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")  # the 1e300 mm one
def test_unreachable_targets_fail_before_motion(d: TestDaemon):
    m, _ = pose(d)
    far = m.copy()
    far[0, 3] += 3000.0
    before = measured(d)
    for name, request in (
        ("MoveLinearCartesianAbs", _linear_abs(d, abs_hg_mat=hg_of(far))),
        (
            "MoveLinearCartesianRel",
            pb.MoveLinearCartesianRelRequest(
                type=RIGHT, rel_hg_mat=hg(p=(3000, 0, 0)), speed=CART_SPEED, accel=CART_ACCEL
            ),
        ),
        (
            "MovePTPCartesianAbs",
            pb.MovePTPCartesianAbsRequest(type=RIGHT, abs_hg_mat=hg_of(far), time=2.0),
        ),
        (
            "MovePTPCartesianRel",
            pb.MovePTPCartesianRelRequest(type=LEFT, rel_hg_mat=hg(p=(0, 0, 3000)), time=2.0),
        ),
        (  # within the edge bound (100 m) but beyond the arm: the reach check refuses
            "MoveLinearCartesianRel",
            pb.MoveLinearCartesianRelRequest(
                type=RIGHT, rel_hg_mat=hg(p=(20_000, 0, 0)), speed=CART_SPEED, accel=CART_ACCEL
            ),
        ),
        (
            "MovePTPCartesianRel",
            pb.MovePTPCartesianRelRequest(type=RIGHT, rel_hg_mat=hg(p=(0, 99_000, 0)), time=2.0),
        ),
    ):
        reply = getattr(d.spec_a, name)(request)
        assert code(reply) == ReturnCode.CANNOT_REACH_TARGET_ERR, (name, reply.return_id)
        assert reply.return_id.comment
        assert d.state() == S.READY
    assert_still(d, before)


# ----------------------------------------------------------------------------- units
def test_unit_abs_round_trip_in_degrees(d: TestDaemon):
    target = [10.0, -20.0, 5.0, 60.0, -15.0, 10.0, 20.0]
    ok(
        d.spec_a.MoveUnitAbs(
            pb.MoveUnitAbsRequest(unit=pb.RIGHT_ARM, abs_pos=target, speed=[60], accel=[150])
        )
    )
    lumbar = [-3.0, 8.0]
    assert d.wait_idle(20.0)
    ok(
        d.spec_a.MoveUnitAbs(
            pb.MoveUnitAbsRequest(unit=pb.LUMBER, abs_pos=lumbar, speed=[20, 30], accel=[40, 60])
        )
    )
    assert d.wait_idle(20.0)
    np.testing.assert_allclose(joints(d, pb.RIGHT_ARM), target, atol=1e-3)
    np.testing.assert_allclose(joints(d, pb.LUMBER), lumbar, atol=1e-3)
    ok(
        d.spec_a.MoveUnitRel(
            pb.MoveUnitRelRequest(
                unit=pb.RIGHT_ARM, rel_pos=[-10, 0, 0, 0, 0, 0, 0], speed=[60], accel=[150]
            )
        )
    )
    assert d.wait_idle(20.0)
    np.testing.assert_allclose(joints(d, pb.RIGHT_ARM)[0], 0.0, atol=1e-3)
    # SI inside: the measured joint is 10 deg in radians
    r_j = d.daemon.hw.joint_names.index(d.ctx.robot.unit_joints("RIGHT_ARM")[1])
    assert measured(d)[r_j] == pytest.approx(math.radians(-20.0), abs=1e-5)


def test_vehicle_round_trip_in_mm_and_deg(d: TestDaemon):
    ok(
        d.spec_a.MoveUnitAbs(
            pb.MoveUnitAbsRequest(
                unit=pb.VEHICLE, abs_pos=[120.0, -40.0, 15.0], speed=[300, 60], accel=[450, 90]
            )
        )
    )
    assert d.wait_idle(20.0)
    np.testing.assert_allclose(joints(d, pb.VEHICLE), [120.0, -40.0, 15.0], atol=1e-2)
    # The original frame stays; the current frame rides along: the control point moved
    # in the original frame but not in the current one.
    original, _ = pose(d, RIGHT, pb.ORIGINAL_FRAME)
    current, _ = pose(d, RIGHT, pb.CURRENT_FRAME)
    assert not np.allclose(original, current, atol=1.0)
    ok(
        d.spec_a.MoveUnitRel(
            pb.MoveUnitRelRequest(
                unit=pb.VEHICLE, rel_pos=[0.0, 0.0, -15.0], speed=[300, 60], accel=[450, 90]
            )
        )
    )
    assert d.wait_idle(20.0)
    np.testing.assert_allclose(joints(d, pb.VEHICLE), [120.0, -40.0, 0.0], atol=1e-2)
    # resetOriginalFrame: the original frame becomes the current pose
    ok(d.spec_a.ResetOriginalFrame(pb.ResetOriginalFrameRequest()))
    wait_cycles(d)
    np.testing.assert_allclose(joints(d, pb.VEHICLE), [0.0, 0.0, 0.0], atol=1e-6)
    original, _ = pose(d, RIGHT, pb.ORIGINAL_FRAME)
    current, _ = pose(d, RIGHT, pb.CURRENT_FRAME)
    np.testing.assert_allclose(original, current, atol=1e-6)


def test_control_point_offset_in_mm(d: TestDaemon, sp5: Robot):
    before, _ = pose(d)
    default = np.vstack([np.array(sp5.offsets[RIGHT].m).reshape(3, 4), [0, 0, 0, 1]])
    shifted = default @ np.array(
        [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 50.0], [0, 0, 0, 1]], dtype=float
    )
    ok(
        d.spec_a.SetControlPointOffset(
            pb.SetControlPointOffsetRequest(type=RIGHT, offset=hg_of(shifted))
        )
    )
    after, _ = pose(d)
    # 50 mm further along the control point's own z axis; orientation unchanged
    np.testing.assert_allclose(after[:3, 3] - before[:3, 3], 50.0 * before[:3, 2], atol=1e-6)
    np.testing.assert_allclose(after[:3, :3], before[:3, :3], atol=1e-9)
    # a TOOL_FRAME relative move is along the new control point's axes
    ok(
        d.spec_a.MoveLinearCartesianRel(
            pb.MoveLinearCartesianRelRequest(
                type=RIGHT,
                frame_type=pb.TOOL_FRAME,
                rel_hg_mat=hg(p=(0, 0, 20)),
                speed=CART_SPEED,
                accel=CART_ACCEL,
            )
        )
    )
    assert d.wait_idle(20.0)
    moved, _ = pose(d)
    np.testing.assert_allclose(moved[:3, 3] - after[:3, 3], 20.0 * after[:3, 2], atol=0.5)


def test_relative_and_absolute_cartesian_moves_arrive(d: TestDaemon):
    start, _ = pose(d)
    ok(
        d.spec_a.MoveLinearCartesianRel(
            pb.MoveLinearCartesianRelRequest(
                type=RIGHT,
                frame_type=pb.BASE_FRAME,
                rel_hg_mat=hg(p=(30.0, 0.0, -20.0)),
                speed=CART_SPEED,
                accel=CART_ACCEL,
            )
        )
    )
    assert d.wait_idle(20.0)
    end, _ = pose(d)
    np.testing.assert_allclose(end[:3, 3] - start[:3, 3], [30.0, 0.0, -20.0], atol=0.5)
    np.testing.assert_allclose(end[:3, :3], start[:3, :3], atol=1e-3)
    ok(
        d.spec_a.MovePTPCartesianAbs(
            pb.MovePTPCartesianAbsRequest(
                type=RIGHT, abs_hg_mat=hg_of(start), time=1.0, is_hold_other_arm=True
            )
        )
    )
    assert d.state() == S.BUSY
    left_before, _ = pose(d, LEFT)
    assert d.wait_idle(20.0)
    back, _ = pose(d)
    np.testing.assert_allclose(back[:3, 3], start[:3, 3], atol=0.5)
    np.testing.assert_allclose(pose(d, LEFT)[0], left_before, atol=0.5)
    ok(
        d.spec_a.MovePTPCartesianRel(
            pb.MovePTPCartesianRelRequest(type=RIGHT, rel_hg_mat=hg(p=(0.0, 0.0, 25.0)), time=0.8)
        )
    )
    assert d.wait_idle(20.0)
    np.testing.assert_allclose(pose(d)[0][:3, 3] - start[:3, 3], [0.0, 0.0, 25.0], atol=0.5)


def test_cp_hold_keeps_the_control_point(d: TestDaemon):
    start, elbow = pose(d)
    ok(d.spec_a.MoveCPHoldRel(_cp_rel(rel_pos=pb.RedundantPos(elbow=10.0))))
    assert d.wait_idle(20.0)
    end, elbow_end = pose(d)
    assert elbow_end == pytest.approx(elbow + 10.0, abs=0.1)
    np.testing.assert_allclose(end[:3, 3], start[:3, 3], atol=0.5)
    ok(
        d.spec_a.MoveCPHoldAbs(
            pb.MoveCPHoldAbsRequest(
                type=RIGHT,
                abs_pos=pb.RedundantPos(elbow=elbow, vehicle_x=30.0),
                speed=RED_SPEED,
                accel=RED_ACCEL,
            )
        )
    )
    assert d.wait_idle(20.0)
    end, elbow_end = pose(d)
    assert elbow_end == pytest.approx(elbow, abs=0.1)
    assert joints(d, pb.VEHICLE)[0] == pytest.approx(30.0, abs=0.1)
    np.testing.assert_allclose(end[:3, 3], start[:3, 3], atol=0.5)


def test_cp_hold_target_the_hand_cannot_follow(d: TestDaemon):
    """Refused before motion (the planner's dry run sees the hand cannot follow): never OK
    and silently short."""
    request = _cp_rel(
        rel_pos=pb.RedundantPos(vehicle_x=600.0),
        speed=pb.RedundantSpeed(vehicle_translation=400, vehicle_rotation=20),
        accel=pb.RedundantAccel(vehicle_translation=450, vehicle_rotation=60),
    )
    before = joints(d, pb.VEHICLE)
    reply = d.spec_a.MoveCPHoldRel(request)
    assert code(reply) == ReturnCode.CANNOT_REACH_TARGET_ERR, reply.return_id
    assert "vehicleX" in reply.return_id.comment and "short" in reply.return_id.comment
    assert not moving(d)
    np.testing.assert_allclose(joints(d, pb.VEHICLE), before, atol=1e-9)


def test_grippers_in_percent(d: TestDaemon):
    for side in (RIGHT, LEFT):
        assert ok(d.spec_a.GetGripperPos(pb.GetGripperPosRequest(type=side))).angle_ratio == 0
    ok(d.spec_a.OpenGripper(pb.OpenGripperRequest(type=RIGHT)))
    ok(d.spec_a.MoveGripper(pb.MoveGripperRequest(type=LEFT, angle_ratio=40)))
    assert d.wait_idle(20.0)
    assert ok(d.spec_a.GetGripperPos(pb.GetGripperPosRequest(type=RIGHT))).angle_ratio == 100
    assert ok(d.spec_a.GetGripperPos(pb.GetGripperPosRequest(type=LEFT))).angle_ratio == 40
    ok(d.spec_a.CloseGripper(pb.CloseGripperRequest(type=RIGHT)))
    assert moving(d)
    assert d.state() == S.READY  # grippers are not whole-body motions


# ----------------------------------------------------------------------------- settings
def test_settings_refused_while_moving(d: TestDaemon):
    start_long_motion(d)
    assert (
        code(d.spec_a.ResetOriginalFrame(pb.ResetOriginalFrameRequest())) == ReturnCode.STATUS_ERR
    )
    offset = pb.SetControlPointOffsetRequest(type=RIGHT, offset=hg())
    assert code(d.spec_a.SetControlPointOffset(offset)) == ReturnCode.STATUS_ERR
    assert code(select(d, elbow=True)) == ReturnCode.STATUS_ERR


def test_redundant_axes_mask_decides_reachability(d: TestDaemon):
    """A target 400 mm ahead needs the vehicle: refused with the default mask (elbow only),
    reached once vehicle_x may move; a vehicle range too narrow makes it unreachable again."""
    m, _ = pose(d)
    far = m.copy()
    far[0, 3] += 400.0
    fast = pb.CartesianSpeed(translation=300.0, rotation=60.0)
    request = _linear_abs(d, abs_hg_mat=hg_of(far), speed=fast)
    assert code(d.spec_a.MoveLinearCartesianAbs(request)) == ReturnCode.CANNOT_REACH_TARGET_ERR
    narrow = pb.SelectRedundantAxesRequest(
        redundancy=pb.RedundantAxesMask(elbow=True, vehicle_x=True),
        limit=pb.RedundantLimit(vehicle_x=pb.LimitValue(lower=-10, upper=10)),
    )
    ok(d.spec_a.SelectRedundantAxes(narrow))
    assert code(d.spec_a.MoveLinearCartesianAbs(request)) == ReturnCode.CANNOT_REACH_TARGET_ERR
    ok(select(d, elbow=True, vehicle_x=True, lumbar_ry=True))
    ok(d.spec_a.MoveLinearCartesianAbs(request))
    assert d.wait_idle(30.0)
    np.testing.assert_allclose(pose(d)[0][:3, 3], far[:3, 3], atol=1.0)
    assert joints(d, pb.VEHICLE)[0] > 50.0


# ----------------------------------------------------------------------------- queries
def test_queries(d: TestDaemon):
    version = ok(d.spec_a.GetVersion(pb.GetVersionRequest())).version
    assert "imotion" in version and "smartpal5" in version
    state = ok(d.spec_a.GetState(pb.GetStateRequest()))
    assert state.status_id == S.READY and "Ready" in state.message
    assert d.spec_a.IsServoOn(pb.IsServoOnRequest()).is_servo_on
    assert not moving(d)
    assert not ok(d.spec_a.GetActiveAlarm(pb.GetActiveAlarmRequest())).alarms
    right, _ = pose(d, RIGHT)
    left, _ = pose(d, LEFT)
    assert right[1, 3] < 0 < left[1, 3]  # right arm on the -y side
    np.testing.assert_allclose(right[:3, :3].T @ right[:3, :3], np.eye(3), atol=1e-9)
    assert len(joints(d, pb.LEFT_ARM)) == 7 and len(joints(d, pb.LUMBER)) == 2


# ----------------------------------------------------------------------------- monitor
def _distance_to_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip((points - a) @ ab / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


def _watch_linear_move(d: TestDaemon, delta: np.ndarray, accel: float) -> dict[str, Any]:
    """Run a BASE_FRAME linear move of the right control point by ``delta`` [mm] at 150 mm/s
    while a StreamState stream samples every cycle; returns what the stream saw."""
    start, _ = pose(d)
    samples: list[pb.StateSample] = []
    stream = d.monitor.StreamState(pb.StreamStateRequest(rate_hz=1000.0))  # clamped: 250 Hz
    started = threading.Event()

    def collect() -> None:
        try:
            for sample in stream:
                samples.append(sample)
                started.set()
        except grpc.RpcError:
            pass

    reader = threading.Thread(target=collect, daemon=True)
    reader.start()
    assert started.wait(10.0)
    ok(
        d.spec_a.MoveLinearCartesianRel(
            pb.MoveLinearCartesianRelRequest(
                type=RIGHT,
                frame_type=pb.BASE_FRAME,
                rel_hg_mat=hg(p=delta),
                speed=pb.CartesianSpeed(translation=150.0, rotation=30.0),
                accel=pb.CartesianAccel(translation=accel, rotation=100.0),
            )
        )
    )
    assert d.wait_idle(20.0)
    wait_cycles(d, 10)
    stream.cancel()
    reader.join(5.0)
    points = []
    for sample in samples:
        (cp,) = [c for c in sample.control_points if c.arm == RIGHT]
        points.append(np.array(cp.pose.car_pos.m).reshape(3, 4)[:, 3])
    path = np.array(points)
    return {
        "samples": samples,
        "deviation": _distance_to_segment(path, start[:3, 3], start[:3, 3] + delta),
        "travelled": np.linalg.norm(path - start[:3, 3], axis=1),
    }


LINE = np.array([80.0, 40.0, -60.0])  # mm, from home: ends near the arm's joint limits


def test_linear_move_stays_on_the_line_in_stream_state(d: TestDaemon):
    seen = _watch_linear_move(d, LINE, accel=200.0)
    samples = seen["samples"]
    assert [s.sequence for s in samples] == list(range(len(samples)))
    assert any(s.status_id == S.BUSY for s in samples)
    assert samples[-1].status_id == S.READY
    assert seen["travelled"].max() > 0.99 * np.linalg.norm(LINE)
    assert seen["deviation"].max() < 0.1, f"max deviation {seen['deviation'].max():.3f} mm"
    units = {j.unit for j in samples[-1].joints}
    assert units == {pb.RIGHT_ARM, pb.LEFT_ARM, pb.LUMBER, pb.VEHICLE}
    assert samples[-1].loop.cycles > 0


def test_linear_move_stays_on_the_line_at_high_acceleration(d: TestDaemon):
    seen = _watch_linear_move(d, LINE, accel=500.0)
    assert seen["deviation"].max() < 0.1, f"max deviation {seen['deviation'].max():.3f} mm"


@pytest.mark.parametrize("rate", [-1.0, float("nan"), float("inf")])
def test_stream_state_rejects_bad_rates(d: TestDaemon, rate: float):
    with pytest.raises(grpc.RpcError) as err:
        next(iter(d.monitor.StreamState(pb.StreamStateRequest(rate_hz=rate))))
    assert err.value.code() == grpc.StatusCode.INVALID_ARGUMENT


def test_every_integrated_motion_rpc_is_covered():
    """Guard: the RPC list of the service matches what this module calls."""
    service = pb.DESCRIPTOR.services_by_name["IntegratedMotion"]
    names = {m.name for m in service.methods}
    assert len(names) == 29
    source = open(__file__).read()
    missing = sorted(n for n in names if f".{n}(" not in source and f'"{n}"' not in source)
    assert not missing
    assert RightLeft.RIGHT == RIGHT


def test_linear_move_on_the_line_with_simulated_drives():
    """MuJoCo drives (tracking error, dynamics): the line holds to well under a millimetre."""
    d = TestDaemon("pa10", "sim", 250.0)
    try:
        ok(d.spec_a.ServoOn(pb.ServoOnRequest()))
        wait_state(d, S.READY)
        delta = np.array([-80.0, 40.0, -60.0])
        seen = _watch_linear_move(d, delta, accel=300.0)
        assert seen["travelled"].max() > 0.99 * np.linalg.norm(delta)
        assert seen["deviation"].max() < 1.0, f"max deviation {seen['deviation'].max():.3f} mm"
    finally:
        d.close()


def test_two_clients_racing_for_one_robot(d: TestDaemon):
    """Spec A never queues: of two moves sent at the same moment exactly one starts."""
    replies: list[int] = []
    barrier = threading.Barrier(2)

    def client(angle: float) -> None:
        channel = grpc.insecure_channel(d.address)
        stub = d.spec_a.__class__(channel)
        request = pb.MoveUnitRelRequest(
            unit=pb.RIGHT_ARM, rel_pos=[angle, 0, 0, 0, 0, 0, 0], speed=[20], accel=[100]
        )
        barrier.wait(10.0)
        replies.append(code(stub.MoveUnitRel(request)))
        channel.close()

    threads = [threading.Thread(target=client, args=(a,)) for a in (5.0, -5.0)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30.0)
    assert sorted(replies) == [ReturnCode.STATUS_ERR, ReturnCode.OK]
    assert d.ctx.snapshot().started - d.ctx.snapshot().finished == 1


def test_readers_of_one_snapshot_share_one_feedback_pose_answer_and_a_new_one_is_new():
    """getFeedbackPosCartesian (issue 17.12): the answer for a snapshot is built once and
    handed to every reader of that snapshot; a new joint value, control-point offset or
    original frame gives a new answer (no stale pose). No gRPC: the servicer alone."""
    from dataclasses import replace

    from controller.gateway.grpc.spec_a import IntegratedMotionServicer
    from tests.planning_support import context, robot, snapshot

    ctx, reader, _ = context("pa10")
    servicer = IntegratedMotionServicer(ctx)
    request = pb.GetFeedbackPosCartesianRequest(type=RIGHT, frame_type=pb.ORIGINAL_FRAME)
    first = servicer.GetFeedbackPosCartesian(request, None)
    assert first.return_id.id == ReturnCode.OK
    assert servicer.GetFeedbackPosCartesian(request, None) is first  # the same snapshot
    other_frame = pb.GetFeedbackPosCartesianRequest(type=RIGHT, frame_type=pb.CURRENT_FRAME)
    assert servicer.GetFeedbackPosCartesian(other_frame, None) is not first
    rob = robot("pa10")
    reader.snap = snapshot(rob, {rob.unit_joints("RIGHT_ARM")[0]: 0.3})  # the arm moved
    moved = servicer.GetFeedbackPosCartesian(request, None)
    assert list(moved.pos.car_pos.m) != list(first.pos.car_pos.m)
    tool = replace(reader.snap, offsets=reader.snap.offsets.copy())
    tool.offsets[0, 2, 3] += 0.1  # a tool 100 mm longer: same joints, another pose
    reader.snap = tool
    longer = servicer.GetFeedbackPosCartesian(request, None)
    assert longer is not moved
    assert list(longer.pos.car_pos.m) != list(moved.pos.car_pos.m)
    bad = servicer.GetFeedbackPosCartesian(pb.GetFeedbackPosCartesianRequest(type=7), None)
    assert bad.return_id.id == ReturnCode.VALUE_ERR  # checks first, never a kept answer
