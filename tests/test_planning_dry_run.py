"""controller.gateway.planning.dry_run: refusals name what binds (issue 16.9)."""

from __future__ import annotations

from controller.gateway.planning.dry_run import arrival_problem
from controller.model.redundant_axes import RedundantAxis
from controller.qp.tasks import AxisTask
from tests.planning_support import context


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
