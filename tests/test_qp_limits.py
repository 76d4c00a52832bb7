"""controller.qp.constraints: the braking formula, the joint box, the redundant-axis rows."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from controller.model.redundant_axes import RedundantAxis, available_axes
from controller.qp.constraints import INF, AxisRows, ConstraintSetup, JointBox, braking_speed
from controller.vocabulary import RightLeft, UnitType
from tests.support import kinematics


def one_joint_box(
    lower: float, upper: float, vmax: float, amax: float, dt: float, frozen: bool = False
) -> JointBox:
    kin = kinematics("pa10")
    box = JointBox(kin, dt)
    box.q_min, box.q_max = np.array([lower]), np.array([upper])
    box.v_max, box.a_max = np.array([vmax]), np.array([amax])
    box.a_brake = 0.5 * box.a_max
    box.configure(kin, ConstraintSetup(np.array([frozen])))
    return box


def test_braking_speed_is_zero_at_the_limit_and_grows_like_sqrt():
    a_b, dt = 1.0, 0.001
    assert braking_speed(0.0, a_b, dt) == 0.0
    assert braking_speed(-0.1, a_b, dt) == 0.0  # beyond the bound: never further out
    assert braking_speed(0.5, 0.0, dt) == INF  # no deceleration given: no bound
    far = braking_speed(0.5, a_b, dt)
    assert far < math.sqrt(2 * a_b * 0.5)
    assert far > math.sqrt(2 * a_b * 0.5) - a_b * dt - 1e-12
    # Stopping from it after one cycle at that rate stays within the distance.
    assert far * dt + far**2 / (2 * a_b) <= 0.5 * (1 + 1e-12)


@settings(max_examples=100, deadline=None)
@given(st.floats(-0.99, 0.99), st.floats(0.1, 20.0), st.sampled_from([0.001, 0.002, 0.004]))
def test_the_box_brakes_with_the_one_formula(start, a_brake, dt):
    """The box's prepared, vectorised braking bound is :func:`braking_speed` at a_brake
    (velocity and acceleration limits set out of the way)."""
    box = one_joint_box(-1.0, 1.0, 1e3, 1e7, dt)
    box.a_brake = np.array([a_brake])
    lb, ub = box.compute_qp_bounds(np.array([start]), np.zeros(1))
    assert math.isclose(ub[0], braking_speed(1.0 - start, a_brake, dt), rel_tol=1e-12)
    assert math.isclose(-lb[0], braking_speed(start + 1.0, a_brake, dt), rel_tol=1e-12)


@settings(max_examples=300, deadline=None)
@given(
    st.floats(0.05, 3.0),  # half range
    st.floats(0.1, 5.0),  # vmax
    st.floats(0.5, 20.0),  # amax
    st.sampled_from([0.001, 0.002, 0.004]),
    st.lists(st.floats(-50, 50), min_size=50, max_size=50),  # wished velocities
    st.floats(-0.99, 0.99),  # start position (fraction of range)
)
def test_limits_are_never_crossed_and_accelerations_respected(half, vmax, amax, dt, wish, start):
    """Whatever velocity the tasks wish for, the clipped command stays inside the position,
    velocity and acceleration limits (starting at rest inside the range)."""
    box = one_joint_box(-half, half, vmax, amax, dt)
    q = np.array([start * half])
    v = np.zeros(1)
    for w in wish * 8:  # 400 cycles, repeating the wishes
        lb, ub = box.compute_qp_bounds(q, v)
        assert lb[0] <= ub[0]
        v_new = np.clip(np.array([w]), lb, ub)
        assert abs(v_new[0]) <= vmax + 1e-12
        assert abs(v_new[0] - v[0]) <= amax * dt * (1 + 1e-9) + 1e-12
        v = v_new
        q = q + v * dt
        assert -half - 1e-12 <= q[0] <= half + 1e-12


def test_frozen_joint_stays_still_at_rest_and_brakes_when_moving():
    box = one_joint_box(-1, 1, 2, 4.0, 0.002, frozen=True)
    lb, ub = box.compute_qp_bounds(np.array([0.0]), np.array([0.0]))
    assert lb[0] == ub[0] == 0.0
    lb, ub = box.compute_qp_bounds(np.array([0.0]), np.array([1.0]))
    assert lb[0] == ub[0] == 1.0 - 4.0 * 0.002  # decelerating as hard as allowed


def test_beyond_a_limit_the_bound_points_back_inside():
    box = one_joint_box(-1, 1, 2, 4.0, 0.002)
    lb, ub = box.compute_qp_bounds(np.array([1.001]), np.array([0.0]))
    assert ub[0] <= 0.0  # may not move further out
    assert lb[0] < 0.0  # and may move back


def test_unbounded_vehicle_joints_get_only_velocity_and_acceleration_bounds():
    kin = kinematics("smartpal5")
    box = JointBox(kin, 0.002)
    q = np.zeros(kin.nv)
    q[kin.unit_indices(UnitType.VEHICLE)] = [1e6, -1e6, 1e3]
    lb, ub = box.compute_qp_bounds(q, np.zeros(kin.nv))
    vx = kin.unit_indices(UnitType.VEHICLE)[0]
    assert np.isfinite(lb).all() and np.isfinite(ub).all()
    assert ub[vx] == box.a_max[vx] * 0.002


def test_masked_axis_row_is_an_equality_and_free_axes_constrain_nothing():
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    axes = available_axes(kin)
    rows = AxisRows(kin, axes, 0.002)
    frozen = np.zeros(kin.nv, dtype=bool)
    rows.configure(kin, {RedundantAxis.RIGHT_ELBOW: False}, {}, frozen)
    C, lo, hi = rows.rows(kin)
    i = axes.index(RedundantAxis.RIGHT_ELBOW)
    assert lo[i] == hi[i] == 0.0
    assert np.array_equal(C[i], kin.elbow_jacobian(kin.arms[0]))
    others = [j for j in range(len(axes)) if j != i]
    assert np.all(lo[others] == -INF) and np.all(hi[others] == INF)


def test_axis_whose_joints_are_all_frozen_needs_no_row():
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    axes = available_axes(kin)
    rows = AxisRows(kin, axes, 0.002)
    frozen = np.zeros(kin.nv, dtype=bool)
    frozen[kin.unit_indices(UnitType.LEFT_ARM)] = True
    rows.configure(kin, {RedundantAxis.LEFT_ELBOW: False}, {}, frozen)
    _, lo, _ = rows.rows(kin)
    assert lo[axes.index(RedundantAxis.LEFT_ELBOW)] == -INF


def test_range_row_brakes_before_its_bounds_and_pulls_back_from_outside():
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    axes = available_axes(kin)
    rows = AxisRows(kin, axes, 0.002)
    i = axes.index(RedundantAxis.LUMBAR_RY)
    frozen = np.zeros(kin.nv, dtype=bool)
    rows.configure(kin, {}, {RedundantAxis.LUMBAR_RY: (-0.1, 0.2)}, frozen)
    _, lo, hi = rows.rows(kin)
    # Braking distance toward each bound: well below the one-cycle jump (bound − x)/dt.
    assert -0.1 / 0.002 < lo[i] < 0.0 < hi[i] < 0.2 / 0.002
    # Half the deceleration of the best joint on the row (both weights are 1).
    brake = 0.5 * max(kin.robot.joints[n].acceleration for n in ("lumbar_lower", "lumbar_upper"))
    assert math.isclose(hi[i], brake * (math.sqrt(0.002**2 + 2 * 0.2 / brake) - 0.002))
    rows.configure(kin, {}, {RedundantAxis.LUMBAR_RY: (0.3, 0.5)}, frozen)  # now outside
    _, lo, hi = rows.rows(kin)
    assert lo[i] > 0.0 and hi[i] >= lo[i]  # back in, never further out


def test_rows_never_ask_for_more_than_the_box_gives():
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    axes = available_axes(kin)
    rows = AxisRows(kin, axes, 0.002)
    frozen = np.zeros(kin.nv, dtype=bool)
    i = axes.index(RedundantAxis.RIGHT_ELBOW)
    rows.configure(kin, {RedundantAxis.RIGHT_ELBOW: False}, {}, frozen)
    q = kin.home()
    q[kin.index("r_arm_j3")] += 0.3  # the held elbow is now far off: big pull-back
    kin.update(q)
    lb, ub = -0.001 * np.ones(kin.nv), 0.001 * np.ones(kin.nv)
    C, lo, hi = rows.rows(kin, lb, ub)
    reach = np.abs(C[i]) @ ub
    assert lo[i] == hi[i]
    assert abs(lo[i]) < reach  # strictly inside what the box can give


def test_differential_base_row_forbids_sideways_motion():
    kin = kinematics("rh")
    q = kin.home()
    vx, vy, vt = kin.unit_indices(UnitType.VEHICLE)
    q[vt] = 0.7
    kin.update(q)
    rows = AxisRows(kin, available_axes(kin), 0.002)
    C, lo, hi = rows.rows(kin)
    assert lo[-1] == hi[-1] == 0.0
    forward = np.zeros(kin.nv)
    forward[[vx, vy]] = math.cos(0.7), math.sin(0.7)
    sideways = np.zeros(kin.nv)
    sideways[[vx, vy]] = -math.sin(0.7), math.cos(0.7)
    assert abs(C[-1] @ forward) < 1e-15
    assert abs(C[-1] @ sideways - 1.0) < 1e-15


def test_the_compiled_box_equals_the_numpy_one():
    """box_bounds (numba) against the NumPy code, bit for bit: random positions in, at and
    beyond the limits, NaN and inf, velocities beyond the limits, frozen joints."""
    import pytest

    from controller.model import jit

    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    kin = kinematics("smartpal5")  # its vehicle joints have unbounded positions
    compiled, plain = JointBox(kin, 0.001), JointBox(kin, 0.001)
    plain._compiled = False
    rng = np.random.default_rng(3)
    bounded = np.isfinite(compiled.q_max - compiled.q_min)
    lo = np.where(bounded, compiled.q_min, -10.0)
    hi = np.where(bounded, compiled.q_max, 10.0)
    for trial in range(400):
        frozen = rng.random(kin.nv) < 0.2
        for box in (compiled, plain):
            box.configure(kin, ConstraintSetup(frozen))
        q = lo + rng.uniform(-0.1, 1.1, kin.nv) * (hi - lo)
        at_limit = rng.random(kin.nv) < 0.1
        q[at_limit] = hi[at_limit]
        v = rng.normal(0.0, 1.5, kin.nv) * compiled.v_max
        if trial % 50 == 0:
            q[trial % kin.nv] = np.nan
        if trial % 50 == 25:
            v[trial % kin.nv] = np.inf
        a, b = compiled.compute_qp_bounds(q, v), plain.compute_qp_bounds(q, v)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])


def test_the_compiled_axis_rows_equal_the_python_ones():
    """axes_kernel.axis_bounds (numba) against AxisLimit's Python code: held elbows (one of
    them nearly stretched), a held vehicle heading, lumbar ranges inside and outside, with and
    without the cycle's joint box, at random postures."""
    import pytest

    from controller.model import jit

    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    kin = kinematics("smartpal5")
    axes = available_axes(kin)
    compiled, plain = AxisRows(kin, axes, 0.001), AxisRows(kin, axes, 0.001)
    plain.limit._compiled = False
    rng = np.random.default_rng(11)
    elbow = kin.index("r_arm_j4")

    def offset_at(angle: float) -> float:
        q = kin.home()
        q[elbow] = angle
        kin.update(q)
        return kin.elbow_offset(RightLeft.RIGHT)

    straight = min(np.linspace(0.0, 0.2, 401), key=offset_at)  # the arm's stretched angle
    for trial in range(40):
        q = kin.home() + rng.normal(scale=0.2, size=kin.nv)
        if trial % 5 == 0:
            q[elbow] = straight  # the right arm stretched: its held elbow is left free
        kin.update(kin.home())
        held = {RedundantAxis.RIGHT_ELBOW: False, RedundantAxis.LEFT_ELBOW: False}
        if RedundantAxis.VEHICLE_THETA in axes:
            held[RedundantAxis.VEHICLE_THETA] = False
        lumbar = (-0.05, 0.05) if trial % 2 else (0.3, 0.6)  # around home / beyond it
        ranges = {RedundantAxis.LUMBAR_RY: lumbar}
        frozen = np.zeros(kin.nv, dtype=bool)
        for rows in (compiled, plain):
            rows.configure(kin, held, ranges, frozen)
        kin.update(q)
        width = rng.uniform(0, 0.01, (2, kin.nv))
        box = () if trial % 3 == 0 else (-width[0], width[1])
        C1, lo1, hi1 = (a.copy() for a in compiled.rows(kin, *box))
        C0, lo0, hi0 = plain.rows(kin, *box)
        np.testing.assert_array_equal(C1, C0)
        np.testing.assert_allclose(lo1, lo0, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(hi1, hi0, rtol=1e-12, atol=1e-12)
        stretched = kin.elbow_offset(RightLeft.RIGHT) < 0.01
        assert stretched == (trial % 5 == 0)  # both cases are met
        assert (lo1[axes.index(RedundantAxis.RIGHT_ELBOW)] == -INF) == stretched


def test_every_held_axis_row_is_the_axis_jacobian_and_holds_its_value():
    """All axes held (elbows, waist angles, vehicle coordinates, each read by kind in a few
    array operations): each row is :func:`axis_jacobian` and its bound pulls the axis back
    to its held value, compiled and in Python, at random postures."""
    import pytest

    from controller.model.redundant_axes import axis_jacobian, axis_value
    from controller.qp.constraints.axes import HOLD_FRACTION

    dt = 0.001
    kin = kinematics("smartpal5")
    axes = available_axes(kin)
    assert any(a.is_lumbar for a in axes) and any(a.is_vehicle for a in axes)
    rng = np.random.default_rng(5)
    for compiled in (True, False):
        rows = AxisRows(kin, axes, dt)
        rows.limit._compiled = compiled and rows.limit._compiled
        for _ in range(10):
            kin.update(kin.home() + rng.normal(scale=0.2, size=kin.nv))
            held_at = {axis: axis_value(kin, axis) for axis in axes}
            rows.configure(kin, dict.fromkeys(axes, False), {}, np.zeros(kin.nv, dtype=bool))
            kin.update(kin.home() + rng.normal(scale=0.2, size=kin.nv))
            C, lo, hi = rows.rows(kin)
            for i, axis in enumerate(axes):
                np.testing.assert_array_equal(C[i], axis_jacobian(kin, axis))
                if axis.is_elbow and kin.elbow_offset(axis.side) < 0.01:
                    continue  # nearly stretched: free
                error = held_at[axis] - axis_value(kin, axis)
                if axis.is_elbow:
                    error = math.remainder(error, math.tau)
                assert lo[i] == hi[i] == pytest.approx(HOLD_FRACTION * error / dt, abs=1e-9)
