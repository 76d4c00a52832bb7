"""controller.gateway.planning.cp_hold: CP-hold plans from SI requests, no daemon."""

from __future__ import annotations

import math

import pytest

from controller.errors import ArgumentError, Refused
from controller.gateway.planning.cp_hold import AxisRequest, plan_cp_hold
from controller.model.redundant_axes import RedundantAxis as A
from controller.vocabulary import ReturnCode, RightLeft
from tests.planning_support import context

RIGHT = RightLeft.RIGHT
DEG = math.pi / 180.0


def req(value, field, rate=None, speed=20 * DEG, accel=40 * DEG):
    return AxisRequest(value, speed, accel, field, rate or field)


def test_an_elbow_swing_holds_only_its_own_hand():
    ctx, _, _ = context("smartpal5")
    plan = plan_cp_hold(
        ctx.planner, ctx.snapshot(), RIGHT, {A.RIGHT_ELBOW: req(10 * DEG, "elbow")}, True, "rel_pos"
    )
    assert plan.spec is not None and plan.comment is None
    assert plan.spec.held == (RIGHT,)
    assert list(plan.spec.targets) == [A.RIGHT_ELBOW]


def test_the_waist_moving_holds_both_hands():
    ctx, _, _ = context("smartpal5")
    plan = plan_cp_hold(
        ctx.planner,
        ctx.snapshot(),
        RIGHT,
        {A.LUMBAR_RY: req(3 * DEG, "lumbar_ry")},
        True,
        "rel_pos",
    )
    assert plan.spec is not None and plan.spec.held == (RIGHT, RightLeft.LEFT)


def test_nothing_to_move_is_ok_without_a_spec_and_names_absent_axes():
    ctx, _, _ = context("pa10")
    plan = plan_cp_hold(
        ctx.planner,
        ctx.snapshot(),
        RIGHT,
        {A.RIGHT_ELBOW: req(0.0, "elbow")},
        True,
        "rel_pos",
        absent=("lumbar_rx", "vehicle_x"),
    )
    assert plan.spec is None
    assert plan.comment is not None
    assert "no lumbar_rx, vehicle_x: ignored" in plan.comment
    assert "already at its target" in plan.comment


def test_a_moving_axis_needs_a_positive_speed_named_in_interface_units():
    ctx, _, _ = context("smartpal5")
    with pytest.raises(ArgumentError, match=r"speed.elbow: must be > 0 deg/s, got -10"):
        plan_cp_hold(
            ctx.planner,
            ctx.snapshot(),
            RIGHT,
            {A.RIGHT_ELBOW: req(10 * DEG, "elbow", speed=-10 * DEG)},
            True,
            "rel_pos",
        )


def test_elbow_ruling_and_waist_range():
    ctx, _, _ = context("smartpal5")
    with pytest.raises(ArgumentError, match=r"outside -180\.\.180"):
        plan_cp_hold(
            ctx.planner,
            ctx.snapshot(),
            RIGHT,
            {A.RIGHT_ELBOW: req(4 * math.pi, "elbow")},
            True,
            "r",
        )
    with pytest.raises(ArgumentError, match="outside the waist's range"):
        plan_cp_hold(
            ctx.planner, ctx.snapshot(), RIGHT, {A.LUMBAR_RY: req(3.0, "lumbar_ry")}, True, "r"
        )


def test_a_vehicle_move_the_hands_cannot_follow_names_the_commanded_axis():
    """Issue 16.9: the refusal names vehicleY (commanded), not vehicleX (held along)."""
    ctx, _, _ = context("seednoid")
    v = req(0.0, "vehicle_x", "vehicle_translation", 0.1, 0.2)
    axes = {
        A.VEHICLE_X: v,
        A.VEHICLE_Y: req(0.15, "vehicle_y", "vehicle_translation", 0.1, 0.2),
        A.VEHICLE_THETA: req(0.0, "vehicle_theta", "vehicle_rotation"),
    }
    with pytest.raises(Refused) as err:
        plan_cp_hold(ctx.planner, ctx.snapshot(), RIGHT, axes, True, "rel_pos")
    assert err.value.code == ReturnCode.CANNOT_REACH_TARGET_ERR
    assert "vehicleY" in err.value.comment and "vehicleX" not in err.value.comment
