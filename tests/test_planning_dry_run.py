"""controller.gateway.planning.dry_run: refusals name what binds (issue 16.9)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.bounds import motion_time
from controller.contract.motion_specs import CPHoldSpec
from controller.gateway.planning.dry_run import DRY_RUN_MAX_TIME, arrival_problem, time_scaled
from controller.model.redundant_axes import RedundantAxis, axis_value
from controller.qp.tasks import AxisTask
from controller.vocabulary import RightLeft
from tests.planning_support import context
from tests.support import kinematics


def test_anarrival_problem_names_the_commanded_axis_before_one_held_along():
    ctx, _, _ = context("smartpal5")
    with ctx.view.at(ctx.snapshot()) as kin:
        x = AxisTask(RedundantAxis.VEHICLE_X, 0.05)  # 50 mm off, held along
        y = AxisTask(RedundantAxis.VEHICLE_Y, 0.03)  # 30 mm off, commanded
        why = arrival_problem(kin, [x, y], {RedundantAxis.VEHICLE_Y}, ["r_arm_j2"])
        assert why is not None
        assert why.startswith("in a dry run vehicleY stopped 30 mm short")
        assert "joints at their limits: r_arm_j2" in why
        only_held = arrival_problem(kin, [x], {RedundantAxis.VEHICLE_Y}, [])
        assert only_held is not None and "held along drifted (vehicleX 50 mm)" in only_held


# ------------------------------------------------------------------ bounded work (16.12)
ELBOW = RedundantAxis.RIGHT_ELBOW


def spec(kin, delta: float, speed: float, accel: float) -> CPHoldSpec:  # type: ignore[no-untyped-def]
    return CPHoldSpec(
        held=(RightLeft.RIGHT,),
        targets={ELBOW: axis_value(kin, ELBOW) + delta},
        speed=np.array([speed]),
        accel=np.array([accel]),
        planned_from=kin.q.copy(),
        label="test",
    )


def test_a_normal_cp_hold_is_dry_run_as_it_is() -> None:
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    normal = spec(kin, math.radians(5), math.radians(10), math.radians(100))
    assert time_scaled(kin, normal) is normal


@pytest.mark.parametrize("speed_deg", [0.0085, 1e-3])
def test_a_slow_cp_hold_is_dry_run_on_the_same_path_in_bounded_time(speed_deg: float) -> None:
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    slow = spec(kin, math.radians(5), math.radians(speed_deg), math.radians(100))
    fast = time_scaled(kin, slow)
    assert isinstance(fast, CPHoldSpec)
    assert fast.targets == slow.targets and fast.held == slow.held
    t = motion_time(math.radians(5), float(fast.speed[0]), float(fast.accel[0]))
    assert t == pytest.approx(DRY_RUN_MAX_TIME, rel=1e-6)
    k = float(fast.speed[0] / slow.speed[0])
    assert float(fast.accel[0] / slow.accel[0]) == pytest.approx(k * k)
