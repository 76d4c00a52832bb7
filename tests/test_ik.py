"""controller.qp.ik: the whole-body IK step in closed loop on a kinematic simulation."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis, axis_value, elbow_axis
from controller.qp.ik import WholeBodyIK
from controller.qp.tasks import AxisTask, ControlPointTask
from controller.vocabulary import RightLeft, UnitType
from tests.support import kinematics

DT = 0.002


def all_but(kin: Kinematics, units: list[UnitType]) -> np.ndarray:
    """Frozen mask: every joint but those of ``units``."""
    frozen = np.ones(kin.nv, dtype=bool)
    for unit in units:
        frozen[kin.unit_indices(unit)] = False
    return frozen


def freeze_all_but(ik: WholeBodyIK, kin: Kinematics, units: list[UnitType]) -> None:
    ik.configure(all_but(kin, units))


def run(ik: WholeBodyIK, kin: Kinematics, q: np.ndarray, steps: int, each=None):
    """Integrate the IK's velocities (perfect drives); ``each(q, v)`` after every cycle."""
    v = np.zeros(kin.nv)
    for _ in range(steps):
        kin.update(q)
        result = ik.solve(q, v)
        assert result.ok, result.message
        v = result.velocity
        q = q + v * DT
        if each is not None:
            kin.update(q)
            each(q, v)
    kin.update(q)
    return q, v


def test_control_point_reaches_a_static_target_with_only_its_arm(robot_id: str):
    kin = kinematics(robot_id)
    q = kin.home()
    kin.update(q)
    side = RightLeft.RIGHT
    start = kin.pose(side)
    target = pin.SE3(
        start.rotation @ pin.exp3(np.array([0.1, -0.1, 0.2])),
        start.translation + np.array([0.05, 0.04, -0.03]),
    )
    ik = WholeBodyIK(kin, DT)
    freeze_all_but(ik, kin, [UnitType.RIGHT_ARM])
    task = ControlPointTask(side, target)
    ik.tasks = [task]
    arm = kin.unit_indices(UnitType.RIGHT_ARM)
    others = np.setdiff1d(np.arange(kin.nv), arm)
    q, _ = run(ik, kin, q, 1500)
    err = task.error(kin)
    assert np.abs(err[:3]).max() < 1e-6 and np.abs(err[3:]).max() < 1e-5
    assert np.array_equal(q[others], kin.home()[others])


def test_masked_elbow_stays_put_while_the_hand_moves():
    kin = kinematics("smartpal5")
    q = kin.home()
    kin.update(q)
    side = RightLeft.RIGHT
    ik = WholeBodyIK(kin, DT)
    ik.configure(all_but(kin, [UnitType.RIGHT_ARM]), {RedundantAxis.RIGHT_ELBOW: False})
    start_elbow = kin.elbow_angle(side)
    start = kin.pose(side)
    ik.tasks = [
        ControlPointTask(
            side, pin.SE3(start.rotation, start.translation + np.array([0.05, 0, 0.05]))
        )
    ]
    drift = []
    run(ik, kin, q, 600, lambda q, v: drift.append(abs(kin.elbow_angle(side) - start_elbow)))
    assert max(drift) < 1e-6  # second-order effect of the linearised equality only
    assert np.linalg.norm(kin.pose(side).translation - start.translation) > 0.05


def test_hand_held_while_the_elbow_swings(robot_id: str):
    """CP-hold at the IK level: the elbow follows a smooth 1 s ramp of 8 deg (as the motion
    generator would give it), the control point stays within 0.05 mm."""
    kin = kinematics(robot_id)
    side = RightLeft.RIGHT
    if not kin.has_elbow(side):
        pytest.skip(f"{robot_id} has no elbow angle")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    freeze_all_but(ik, kin, [UnitType.RIGHT_ARM])
    hold = ControlPointTask(side, kin.pose(side))
    axis = elbow_axis(side)
    start, swing, duration = axis_value(kin, axis), math.radians(8), 1.0
    elbow = AxisTask(axis, start)
    ik.tasks = [hold, elbow]
    worst = []
    steps = int(1.5 / DT)
    v = np.zeros(kin.nv)
    for i in range(steps):
        s = min(i * DT / duration, 1.0)
        elbow.set_target(
            start + swing * (10 * s**3 - 15 * s**4 + 6 * s**5),
            swing * (30 * s**2 - 60 * s**3 + 30 * s**4) / duration if s < 1 else 0.0,
        )
        kin.update(q)
        result = ik.solve(q, v)
        assert result.ok and not result.message
        v = result.velocity
        q = q + v * DT
        kin.update(q)
        worst.append(np.abs(hold.error(kin)[:3]).max())
    assert max(worst) < 0.05e-3
    assert abs(elbow.error(kin)) < math.radians(0.1)


def test_differential_base_never_moves_sideways():
    kin = kinematics("rh")
    q = kin.home()
    vx, vy, vt = kin.unit_indices(UnitType.VEHICLE)
    q[vt] = 0.7
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    freeze_all_but(ik, kin, [UnitType.VEHICLE])
    # Ask for a point straight to the body's left: impossible without turning.
    ik.tasks = [
        AxisTask(RedundantAxis.VEHICLE_X, 0.0, weight=1.0),
        AxisTask(RedundantAxis.VEHICLE_Y, 0.5, weight=1.0),
    ]
    lateral = []

    def check(q: np.ndarray, v: np.ndarray) -> None:
        lateral.append(abs(-math.sin(q[vt]) * v[vx] + math.cos(q[vt]) * v[vy]))

    run(ik, kin, q, 500, check)
    assert max(lateral) < 1e-9


def test_unreachable_target_gives_bounded_velocities():
    """Far out of reach (PA10 stretched toward a point 3 m away): no blow-up, no NaN."""
    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    start = kin.pose(RightLeft.RIGHT)
    ik.tasks = [ControlPointTask(RightLeft.RIGHT, pin.SE3(start.rotation, np.array([3.0, 0, 1])))]
    speeds = []
    run(ik, kin, q, 1500, lambda q, v: speeds.append(np.abs(v / ik.box.v_max).max()))
    assert np.isfinite(speeds).all() and max(speeds) <= 1.0 + 1e-9


def test_failed_solve_holds_position(monkeypatch: pytest.MonkeyPatch):
    kin = kinematics("pa10")
    q = kin.home()
    kin.update(q)
    ik = WholeBodyIK(kin, DT)
    ik.tasks = [ControlPointTask(RightLeft.RIGHT, kin.pose(RightLeft.RIGHT))]
    monkeypatch.setattr(ik.solver, "solve", lambda *a: None)
    result = ik.solve(q, np.ones(kin.nv))
    assert not result.ok
    assert np.array_equal(result.velocity, np.zeros(kin.nv))
    assert "infeasible" in result.message


def test_the_compiled_clip_and_equalities_equal_numpys() -> None:
    """The IK's last steps in one call each: the clip into the free joints' velocities
    (NaN limits or minimisers stay NaN and say so, an overflow of v·v too) and level 2's
    equality rows and right-hand side, against the NumPy code they replace."""
    from controller.model import jit
    from controller.qp import ik as ik_module

    if not jit.available():
        pytest.skip("compiled kernels are off in this variant")
    rng = np.random.default_rng(17)
    for trial in range(200):
        nv = int(rng.integers(3, 12))
        free = np.sort(rng.choice(nv, size=int(rng.integers(1, nv + 1)), replace=False))
        n = len(free)
        x = rng.normal(size=n)
        lb, ub = -rng.uniform(0, 1, n), rng.uniform(0, 1, n)
        if trial % 7 == 1:
            lb[rng.integers(n)] = np.nan
        if trial % 11 == 2:
            x[rng.integers(n)] = np.nan
        if trial % 13 == 3:
            ub[rng.integers(n)] = 1e200
            x[:] = 1e200
        base = rng.normal(size=nv)
        expected = base.copy()
        expected[free] = np.minimum(np.maximum(x, lb), ub)
        v = base.copy()
        finite = ik_module._clip_into(x, lb, ub, free.astype(np.int64), v)
        np.testing.assert_array_equal(v, expected)
        with np.errstate(over="ignore"):  # the overflow case
            assert finite == math.isfinite(expected.dot(expected))
        p = int(rng.integers(1, 7))
        jac = np.asfortranarray(rng.normal(size=(p + 2, nv)))
        A, b = np.zeros((p, n)), np.zeros(p)
        ik_module._equalities(jac, free.astype(np.int64), x, A, b)
        reference = np.ascontiguousarray(jac[:p, free])
        np.testing.assert_array_equal(A, reference)
        if np.isfinite(x).all():
            np.testing.assert_allclose(b, reference.dot(x), rtol=1e-12, atol=1e-12)
