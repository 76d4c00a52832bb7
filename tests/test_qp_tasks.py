"""controller.qp.tasks: the pose error and the control-point rows, compiled and not, against
Pinocchio."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from controller.model import jit
from controller.qp import tasks


def rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    return np.asarray(pin.exp3(angle * axis / np.linalg.norm(axis)))


def random_rotations(rng: np.random.Generator) -> list[np.ndarray]:
    """Uniform ones, and angles near 0 and near π (where log3 needs its special forms)."""
    out = [np.asarray(pin.SE3.Random().rotation) for _ in range(300)]
    for angle in (0.0, 1e-12, 1e-8, 1e-5, 1e-4, 2e-4, 1e-3, 0.5, 3.0):
        out.append(rotation(rng.normal(size=3), angle))
    for gap in (0.0, 1e-12, 1e-8, 1e-5, 1e-4, 9e-4, 1e-3, 1.1e-3, 1e-2):
        out.append(rotation(rng.normal(size=3), math.pi - gap))
    return out


@pytest.mark.skipif(not jit.available(), reason="numba not installed")
def test_compiled_pose_error_is_pinocchios() -> None:
    rng = np.random.default_rng(1)
    for r in random_rotations(rng):
        base = pin.SE3.Random()
        target = pin.SE3(r @ base.rotation, rng.normal(size=3))
        out = np.empty(6)
        tasks._pose_error(target.rotation, target.translation, base.rotation, base.translation, out)
        want = np.empty(6)
        want[:3] = target.translation - base.translation
        want[3:] = pin.log3((target * base.inverse()).rotation)
        np.testing.assert_allclose(out[:3], want[:3], atol=1e-15)
        angle = np.linalg.norm(want[3:])
        if angle < math.pi - 1e-6:  # the rotation vector is unique
            np.testing.assert_allclose(out[3:], want[3:], atol=1e-9)
        # anywhere (at π, ±axis): the same rotation, the same angle
        np.testing.assert_allclose(np.asarray(pin.exp3(out[3:])), r, atol=1e-9)
        assert np.linalg.norm(out[3:]) == pytest.approx(angle, abs=1e-9)


def test_pose_error_with_and_without_the_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    target, pose = pin.SE3.Random(), pin.SE3.Random()
    results = []
    for compiled in (False, jit.available()):
        monkeypatch.setattr(tasks, "_COMPILED", compiled)
        results.append(tasks.pose_error(target, pose))
    np.testing.assert_allclose(results[0], results[1], atol=1e-9)


def test_posture_tasks_over_the_same_joints_share_one_read_only_jacobian() -> None:
    nv = 7
    a = tasks.PostureTask(np.zeros(nv), np.array([1, 3]))
    b = tasks.PostureTask(np.ones(nv), np.array([1, 3]))
    jac = a._jacobian(nv)
    assert b._jacobian(nv) is jac and not jac.flags.writeable
    assert np.array_equal(jac, np.eye(nv)[[1, 3]])
    every = tasks.PostureTask(np.zeros(nv), np.arange(nv))
    assert np.array_equal(every._jacobian(nv), np.eye(nv)) and every._every and not a._every
    assert tasks.PostureTask(np.zeros(nv), np.array([3, 1]))._jacobian(nv)[0, 3] == 1.0


@pytest.mark.skipif(not jit.available(), reason="numba not installed")
def test_control_point_rows_are_the_same_compiled_and_through_pinocchio(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """ControlPointTask.compute_into: Jacobian rows and rate from one compiled call against
    Kinematics.jacobian/pose and pose_error, with the original frame turned and moved."""
    from controller.vocabulary import RightLeft
    from tests.support import kinematics

    kin = kinematics("smartpal5")
    rng = np.random.default_rng(5)
    for trial in range(12):
        q = kin.home() + rng.normal(scale=0.3, size=kin.nv)
        kin.update(q)
        if trial % 2:  # an original frame that is not the world
            kin.set_original_frame(pin.SE3.Random(), float(rng.normal()))
        side = RightLeft.RIGHT if trial % 3 else RightLeft.LEFT
        task = tasks.ControlPointTask(side, pin.SE3.Random(), gain=7.5)
        if trial % 4 == 0:  # set anew, then changed in place: the rows follow the pose
            task.target = pin.SE3.Random()
            task.target.translation[:] += rng.normal(size=3)
            task.target.rotation[:] = pin.SE3.Random().rotation
        else:
            task.set_target(pin.SE3.Random(), rng.normal(size=6))
        out = []
        for compiled in (True, False):
            monkeypatch.setattr(tasks, "_COMPILED", compiled)
            stack = np.full((8, kin.nv), np.nan, order="F")
            rate = np.full(6, np.nan)
            task.compute_into(kin, stack[1:7], rate)
            out.append((stack[1:7].copy(), rate))
        np.testing.assert_allclose(out[0][0], out[1][0], rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(out[0][1], out[1][1], rtol=1e-9, atol=1e-9)
        rate = np.empty(6)
        monkeypatch.setattr(tasks, "_COMPILED", True)
        task.compute_into(kin, None, rate)  # no rows to write: the rate alone
        np.testing.assert_array_equal(rate, out[0][1])


def test_a_control_point_task_keeps_its_own_target_and_twist() -> None:
    """``set_target`` copies: the caller's pose and twist may change afterwards; the buffers
    a path writes in place are the ones the rows read."""
    from controller.vocabulary import RightLeft
    from tests.support import kinematics

    kin = kinematics("smartpal5")
    kin.update(kin.home())
    side = RightLeft.RIGHT
    first = pin.SE3.Random()
    task = tasks.ControlPointTask(side, first)
    pose, twist = pin.SE3.Random(), np.arange(6.0)
    task.set_target(pose, twist)
    pose.translation[:] = 0.0
    twist[:] = -1.0
    assert np.array_equal(task.twist, np.arange(6.0))
    assert not np.array_equal(task.target.translation, np.zeros(3))
    rotation, translation, feed = task.target_buffers
    goal = pin.SE3.Random()
    rotation[...], translation[...], feed[...] = goal.rotation, goal.translation, 0.5
    assert np.array_equal(task.target.homogeneous, goal.homogeneous)
    rate = np.zeros(6)
    task.compute_into(kin, None, rate)
    expected = tasks.pose_error(goal, kin.pose(side)) * task.gain + 0.5
    np.testing.assert_allclose(rate, expected, rtol=0, atol=1e-12)
    task.set_target(first)
    assert np.array_equal(task.twist, np.zeros(6))
    assert np.array_equal(task.target.homogeneous, first.homogeneous)
