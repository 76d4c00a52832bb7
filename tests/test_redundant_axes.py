"""controller.model.redundant_axes: the axes' kinds, and what each reads from the kinematics."""

from __future__ import annotations

import numpy as np
import pytest

from controller.model.redundant_axes import (
    RedundantAxis,
    available_axes,
    axis_jacobian,
    axis_value,
    elbow_axis,
)
from controller.vocabulary import LumbarAxis, RightLeft
from tests.support import ROBOT_IDS, kinematics, random_configuration


def test_each_axis_has_one_kind() -> None:
    for axis in RedundantAxis:
        assert [axis.is_elbow, axis.is_lumbar, axis.is_vehicle].count(True) == 1


def test_sides_waist_angles_and_vehicle_coordinates() -> None:
    assert elbow_axis(RightLeft.RIGHT).side is RightLeft.RIGHT
    assert elbow_axis(RightLeft.LEFT).side is RightLeft.LEFT
    assert [a.lumbar for a in RedundantAxis if a.is_lumbar] == list(LumbarAxis)
    assert [a.vehicle_index for a in RedundantAxis if a.is_vehicle] == [0, 1, 2]


def test_asking_an_axis_for_what_it_is_not_raises() -> None:
    with pytest.raises(ValueError, match="not a waist axis"):
        _ = RedundantAxis.RIGHT_ELBOW.lumbar
    with pytest.raises(ValueError, match="not a vehicle axis"):
        _ = RedundantAxis.LUMBAR_RX.vehicle_index


@pytest.mark.parametrize("robot_id", ROBOT_IDS)
def test_values_and_rows_are_the_kinematics(robot_id: str) -> None:
    kin = kinematics(robot_id)
    kin.update(random_configuration(kin, np.random.default_rng(5)))
    for axis in available_axes(kin):
        if axis.is_elbow:
            assert axis_value(kin, axis) == kin.elbow_angle(axis.side)
            assert axis_jacobian(kin, axis) is kin.elbow_jacobian(axis.side)
        elif axis.is_lumbar:
            assert axis_value(kin, axis) == kin.lumbar_angle(axis.lumbar)
        else:
            assert axis_value(kin, axis) == kin.vehicle_pose()[axis.vehicle_index]
            np.testing.assert_array_equal(
                axis_jacobian(kin, axis), kin.vehicle_jacobian()[axis.vehicle_index]
            )
