"""controller.gateway.services.spec_a: the Spec A service in spec units, without gRPC or a
daemon (a recording command channel): argument checks, state, planning, the command."""

from __future__ import annotations

import numpy as np
import pytest

from controller.contract.motion_specs import CartesianMoveSpec, CPHoldSpec, JointMoveSpec
from controller.errors import ArgumentError, Refused
from controller.gateway.services.spec_a import SpecAService
from controller.model.redundant_axes import RedundantAxis
from controller.vocabulary import CoreState, ReturnCode, RightLeft, UnitType
from tests.planning_support import context, snapshot

RIGHT = RightLeft.RIGHT
UP = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 20.0]  # 20 mm up [mm]
RATES = {"elbow": 20.0, "lumbar_ry": 10.0, "vehicle_translation": 100, "vehicle_rotation": 10}


def service(robot: str = "smartpal5", **snap):
    ctx, reader, channel = context(robot)
    if snap:
        reader.snap = snapshot(ctx.robot, **snap)
    return SpecAService(ctx), channel


def test_a_unit_move_converts_deg_and_starts_a_joint_move():
    svc, channel = service()
    svc.move_unit(UnitType.RIGHT_ARM, [2, 0, 0, 0, 0, 0, 0], [10], [20], relative=True)
    (spec,) = channel.specs()
    assert isinstance(spec, JointMoveSpec)
    np.testing.assert_allclose(spec.speed, np.radians(10.0))


def test_arguments_are_checked_before_the_state_and_nothing_is_sent():
    svc, channel = service(state=CoreState.BUSY, moving=True)
    with pytest.raises(ArgumentError, match=r"abs_pos\[2\]: nan is not a finite number"):
        svc.move_unit(UnitType.RIGHT_ARM, [0, 0, float("nan"), 0, 0, 0, 0], [10], [20], False)
    with pytest.raises(Refused) as err:
        svc.move_unit(UnitType.RIGHT_ARM, [2, 0, 0, 0, 0, 0, 0], [10], [20], relative=True)
    assert err.value.code == ReturnCode.STATUS_ERR and "does not queue" in err.value.comment
    assert channel.calls == []


def test_servo_off_is_not_sv_on_err_only_where_the_operation_lists_it():
    svc, _ = service(state=CoreState.SERVO_OFF)
    with pytest.raises(Refused) as err:
        svc.move_ptp(RIGHT, UP, 2.0, False, True, "rel_hg_mat")
    assert err.value.code == ReturnCode.NOT_SV_ON_ERR
    with pytest.raises(Refused) as err:
        svc.move_linear(RIGHT, UP, (50, 20), (100, 40), False, False, "rel_hg_mat")
    assert err.value.code == ReturnCode.STATUS_ERR


def test_a_linear_move_is_planned_under_the_selected_axes():
    svc, channel = service()
    assert svc.select_redundant_axes({"elbow": True, "lumbar_ry": True}, {}) is None
    svc.move_linear(RIGHT, UP, (50, 20), (100, 40), False, False, "rel_hg_mat")
    (spec,) = channel.specs()
    assert isinstance(spec, CartesianMoveSpec)
    assert spec.allowed[RedundantAxis.LUMBAR_RY] is True


def test_select_redundant_axes_names_absent_axes_and_checks_ranges():
    svc, _ = service("pa10")
    comment = svc.select_redundant_axes({"elbow": True, "vehicle_x": True}, {})
    assert comment == "OK (this robot has no vehicleX: ignored)"
    with pytest.raises(ArgumentError, match=r"limit\.right_elbow: elbow ranges"):
        svc.select_redundant_axes({"elbow": True}, {"right_elbow": (-200.0, 10.0)})


def test_cp_hold_on_a_robot_without_the_axes_says_so():
    svc, channel = service("pa10")
    comment = svc.move_cp_hold(RIGHT, {"lumbar_rx": 5, "vehicle_x": 100}, RATES, RATES, True)
    assert comment is not None and "no lumbar_rx, vehicle_x: ignored" in comment
    assert channel.specs() == []


def test_cp_hold_checks_every_field_and_starts_the_plan():
    svc, channel = service()
    with pytest.raises(ArgumentError, match=r"rel_pos.lumbar_rx: inf"):
        svc.move_cp_hold(RIGHT, {"lumbar_rx": float("inf")}, RATES, RATES, True)
    assert svc.move_cp_hold(RIGHT, {"elbow": 10}, RATES, RATES, True) is None
    (spec,) = channel.specs()
    assert isinstance(spec, CPHoldSpec)


def test_tool_offset_and_ptp_time_bounds():
    svc, _ = service()
    far = [1, 0, 0, 2500.0, 0, 1, 0, 0, 0, 0, 1, 0]
    with pytest.raises(ArgumentError, match="not a plausible tool"):
        svc.set_control_point_offset(RIGHT, far)
    with pytest.raises(ArgumentError, match="longer than 600 s"):
        svc.move_ptp(RIGHT, UP, 4000.0, False, True, "rel_hg_mat")
    with pytest.raises(ArgumentError, match="expected 12 numbers"):
        svc.move_ptp(RIGHT, UP[:11], 1.0, False, True, "rel_hg_mat")
