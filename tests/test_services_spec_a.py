"""controller.gateway.services.spec_a: the Spec A service in spec units, without gRPC or a
daemon (a recording command channel): argument checks, state, planning, the command."""

from __future__ import annotations

import numpy as np
import pytest

from controller.contract.motion_specs import CartesianMoveSpec, CPHoldSpec, JointMoveSpec
from controller.control.core import SETTLE_TIME
from controller.errors import ArgumentError, Refused
from controller.gateway.services.spec_a import SpecAService
from controller.model.redundant_axes import RedundantAxis
from controller.motion.arrival import POSITION_TOL
from controller.motion.reachability import LIMIT_MARGIN
from controller.vocabulary import CoreState, ReturnCode, RightLeft, UnitType
from tests.motion_support import build_planned, make_core, run_motion
from tests.planning_support import context, core_snapshot, snapshot

RIGHT, LEFT = RightLeft.RIGHT, RightLeft.LEFT
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


# ------------------------------------------------ a checked linear move runs as checked
#: 100 mm along each axis from home, per robot and hand [mm].
LINES = [
    (robot_id, side, axis, sign)
    for robot_id, sides in (("smartpal5", (RIGHT, LEFT)), ("pa10", (RIGHT,)), ("rh", (RIGHT,)))
    for side in sides
    for axis in range(3)
    for sign in (1.0, -1.0)
]


@pytest.mark.parametrize(
    ("robot_id", "side", "axis", "sign"),
    LINES,
    ids=[f"{r}-{s.name.lower()}-{'+-'[g < 0]}{'xyz'[a]}" for r, s, a, g in LINES],
)
def test_a_linear_move_from_home_runs_on_time_on_target_and_off_the_limits(
    robot_id: str, side: RightLeft, axis: int, sign: float
):
    """The first moveLinearCartesianRel after servoOn, planned by the service on the state a
    MuJoCo core publishes and run on that core (as the control process runs it): it ends on
    its target within the arrival settling after its time law, with no MOTION_INCOMPLETE,
    no arm joint ever closer than the check's LIMIT_MARGIN to a limit, on the configuration
    the check ended on. Was (SmartPal V, +z either hand): r_arm_j6 braked on its limit by
    the loop where the check had taken another null-space branch; 0x413 2 s late."""
    core = make_core(robot_id, "mujoco")
    ctx, reader, channel = context(robot_id)
    reader.snap = core_snapshot(core)
    change = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0]
    change[4 * axis + 3] = 100.0 * sign
    SpecAService(ctx).move_linear(side, change, (50, 20), (100, 40), False, False, "rel_hg_mat")
    (spec,) = channel.specs()
    checked_end = ctx.planner.checker.last_q.copy()
    motion = build_planned(core, spec)
    arm = core.kin.unit_indices(UnitType[f"{side.name}_ARM"])
    box = core.ik.box
    closest = np.inf
    law_end = None

    def watch(c) -> None:
        nonlocal closest, law_end
        gap = np.minimum(c.q[arm] - box.q_min[arm], box.q_max[arm] - c.q[arm])
        closest = min(closest, float(gap.min()))
        if law_end is None and motion.finished:
            law_end = c.cycles

    run_motion(core, motion, watch)
    assert core.alarms == []
    assert law_end is not None and (core.cycles - law_end) * core.dt < SETTLE_TIME
    pose = core.kin.pose(side)
    assert np.linalg.norm(pose.translation - spec.target[:3, 3]) < POSITION_TOL
    assert closest > LIMIT_MARGIN
    np.testing.assert_allclose(core.kin.q[arm], checked_end[arm], atol=np.radians(0.5))


def test_successive_raises_keep_the_wrist_off_its_limit():
    """moveLinearCartesianRel +20 mm z, again and again from home (perfect drives): every
    move ends on target with no warning, r_arm_j6 kept off its lower limit. Was: each move
    drawn to its own start let r_arm_j6 creep to its limit; the 5th was refused ('needs
    r_arm_j6 within 0.14 deg of its limit'; through CORBA JARA, intermittently, 'within
    0.00 deg')."""
    core = make_core("smartpal5", "ideal")
    j6 = core.kin.index("r_arm_j6")
    lower = core.ik.box.q_min[j6]
    for _ in range(8):
        ctx, reader, channel = context("smartpal5")
        reader.snap = core_snapshot(core)
        SpecAService(ctx).move_linear(RIGHT, UP, (50, 20), (100, 40), False, False, "rel")
        (spec,) = channel.specs()
        run_motion(core, build_planned(core, spec))
        assert core.alarms == []
        assert np.linalg.norm(core.kin.pose(RIGHT).translation - spec.target[:3, 3]) < 2e-4
        assert core.kin.q[j6] - lower > np.radians(3.0)
