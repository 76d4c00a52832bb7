"""controller.gateway.planning.redundancy: waist ranges and selectRedundantAxes ranges."""

from __future__ import annotations

import math

import pytest

from controller.errors import ArgumentError
from controller.gateway.planning.redundancy import axis_range, lumbar_range
from controller.model.redundant_axes import RedundantAxis
from tests.planning_support import robot


def test_the_waist_range_sums_the_weighted_joint_limits():
    rob = robot("smartpal5")
    lo, hi = lumbar_range(rob, RedundantAxis.LUMBAR_RY)
    assert lo < 0.0 < hi
    assert axis_range(rob, RedundantAxis.LUMBAR_RY, lo, hi, "limit.lumbar_ry") == (lo, hi)


def test_ranges_are_checked():
    rob = robot("smartpal5")
    with pytest.raises(ArgumentError, match="below lower"):
        axis_range(rob, RedundantAxis.VEHICLE_X, 0.2, 0.1, "limit.vehicle_x")
    with pytest.raises(ArgumentError, match=r"-180\.\.180"):
        axis_range(rob, RedundantAxis.RIGHT_ELBOW, -4.0, 0.0, "limit.right_elbow")
    lo, hi = lumbar_range(rob, RedundantAxis.LUMBAR_RY)
    with pytest.raises(ArgumentError, match="wider than the waist"):
        axis_range(rob, RedundantAxis.LUMBAR_RY, lo - math.radians(5), hi, "limit.lumbar_ry")
