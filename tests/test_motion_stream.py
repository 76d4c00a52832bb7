"""JointStreamMotion: streamed set-points blend (no stop between them), the stream settles on
its last set-point when it dries up, stop and pause brake, resume continues."""

from __future__ import annotations

import numpy as np
import pytest

from controller.contract.motion_specs import JointStreamSpec
from controller.control.core import CoreState
from controller.motion.stream import JERK_TIME, JointStreamMotion
from controller.vocabulary import UnitType
from tests.motion_support import make_core

PERIOD = 0.02  # the client's command cycle [s]


@pytest.fixture
def core():
    return make_core("pa10")


def stream(core, points, each=None):
    """Feed ``points`` (arm joint vectors) one per PERIOD; returns the joint-1 velocities."""
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    specs = [core.robot.joints[n] for n in core.kin.joint_names]
    v_max = np.array([specs[i].velocity for i in joints])
    a_max = np.array([specs[i].acceleration for i in joints])
    per_point = round(PERIOD / core.dt)
    speeds = []
    for k, p in enumerate(points):
        spec = JointStreamSpec(
            joints=joints, target=p, v_max=v_max, a_max=a_max, period=PERIOD, key="R"
        )
        if k == 0:
            core.start(spec.build(core.kin, core.dt))
        else:
            assert spec.extends(core.motion)
            core.motion.extend(p)
        for _ in range(per_point):
            core.cycle()
            speeds.append(core.v_cmd[joints[0]])
            if each:
                each(core)
    return joints, np.array(speeds)


def test_set_points_blend_and_the_stream_settles_on_the_last(core):
    q0 = core.q.copy()
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    # joint 1 sweeps 0.2 rad at 0.5 rad/s in 20 ms steps
    points = [q0[joints] + np.r_[0.01 * (k + 1), np.zeros(len(joints) - 1)] for k in range(20)]
    _, speeds = stream(core, points)
    middle = speeds[len(speeds) // 4 : 3 * len(speeds) // 4]
    assert middle.min() > 0.2, "the joint stopped between set-points"
    for _ in range(2000):
        core.cycle()
        if core.motion is None:
            break
    assert core.motion is None and core.state == CoreState.READY
    np.testing.assert_allclose(core.q[joints], points[-1], atol=1e-6)


def test_stop_brakes_and_ends_the_stream(core):
    q0 = core.q.copy()
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    points = [q0[joints] + np.r_[0.01 * (k + 1), np.zeros(len(joints) - 1)] for k in range(10)]
    stream(core, points)
    v = core.v_cmd[joints[0]]
    a = core.robot.joints[core.kin.joint_names[joints[0]]].acceleration
    at_stop = core.q[joints[0]]
    core.stop()
    cycles = 0
    while core.motion is not None and cycles < 5000:
        core.cycle()
        cycles += 1
    assert core.motion is None and core.state == CoreState.READY
    # a brake, not a settle: ends within the braking time (+ jerk ramp and settling)
    assert cycles * core.dt < v / a + 0.6
    assert core.q[joints[0]] - at_stop < v * v / (2 * a) + v * JERK_TIME + 0.005


def test_pause_then_resume_reaches_the_last_set_point(core):
    q0 = core.q.copy()
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    points = [q0[joints] + np.r_[0.01 * (k + 1), np.zeros(len(joints) - 1)] for k in range(10)]
    stream(core, points)
    core.pause()
    for _ in range(500):
        core.cycle()
    assert core.state == CoreState.PAUSED
    held = core.q[joints[0]]
    for _ in range(100):
        core.cycle()
    assert core.q[joints[0]] == pytest.approx(held, abs=1e-9)
    core.resume()
    for _ in range(3000):
        core.cycle()
        if core.motion is None:
            break
    np.testing.assert_allclose(core.q[joints], points[-1], atol=1e-6)


def test_a_stream_of_other_joints_does_not_extend(core):
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    motion = JointStreamMotion(
        core.kin, core.dt, joints, core.q[joints], np.ones(7), np.ones(7), PERIOD, "R"
    )
    other = JointStreamSpec(
        joints=joints[:3],
        target=core.q[joints[:3]],
        v_max=np.ones(3),
        a_max=np.ones(3),
        period=PERIOD,
        key="R",
    )
    assert not other.extends(motion)
    with pytest.raises(NotImplementedError):
        motion.apply(0.0, 0.1, core.dt)


#: A Ruckig 0.19 input that fails in its synchronisation step: the joints 0-6 are within
#: round-off of their set-points, with round-off speeds and accelerations left (joints a
#: Cartesian stream of tiny steps barely moves). Found by fuzzing the stream's inputs.
ROUND_OFF_STATE = {
    "current_position": [
        -0.6306246135879521, 0.4616886808995506, -0.0288262676528257, 0.8850130987572284,
        -0.7778839432004638, -0.508972401977094, 0.047847500599355275,
    ],
    "current_velocity": [
        -2.4497971412564196e-17, 5.441650370810246e-16, -3.142922081385817e-16,
        4.046721839176806e-14, 9.035042327724329e-14, -6.949445862388076e-16,
        1.161999233481349e-16,
    ],
    "current_acceleration": [
        -1.5476161861051545e-15, 1.0107478342931312e-13, -9.57682103718483e-14,
        -4.336503388372304e-12, -2.2820869932879074e-12, 1.6104921710481427e-14,
        7.439782762097321e-15,
    ],
    "target_position": [
        -0.6306246135879521, 0.4616886808995512, -0.028826267652824287, 0.8850130987572381,
        -0.7778839432004352, -0.5089724019770945, 0.04784750059935524,
    ],
}  # fmt: skip


def test_round_off_left_on_set_points_never_fails_the_stream():
    """Issue 15.5: 'Ruckig failed on the joint stream' (alarm 0x412) at the start of
    Cartesian streams of ~0.04 mm steps: Ruckig's synchronisation fails on joints left
    within round-off of their set-points with round-off speed and acceleration."""
    core = make_core("seednoid", dt=0.002)
    joints = core.kin.unit_indices(UnitType.RIGHT_ARM)
    n = len(joints)
    motion = JointStreamMotion(
        core.kin, 0.002, joints, core.q[joints], np.full(n, 1.047), np.full(n, 2.094), PERIOD
    )
    for name, value in ROUND_OFF_STATE.items():
        setattr(motion._in, name, value)
    motion._in.target_velocity = [0.0] * n
    motion._in.target_acceleration = [0.0] * n
    motion._settling = True
    for _ in range(200):
        motion.advance()
        if motion.finished:
            break
    assert motion.finished
    np.testing.assert_allclose(
        motion.track.reference[joints], ROUND_OFF_STATE["target_position"], atol=1e-12
    )
