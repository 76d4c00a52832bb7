"""controller.gateway.planning.relative: relative poses and the elbow ruling (issue 16.11)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from controller.errors import ArgumentError
from controller.gateway.planning.relative import elbow_goal, relative_pose


def test_base_frame_adds_the_translation_and_rotates_about_the_original_axes():
    current = pin.SE3(pin.utils.rotate("z", 0.3), np.array([0.1, 0.2, 0.3]))
    rel = pin.SE3(pin.utils.rotate("x", 0.5), np.array([0.0, 0.0, 0.05]))
    goal = relative_pose(current, rel, tool_frame=False)
    np.testing.assert_allclose(goal.translation, [0.1, 0.2, 0.35])
    np.testing.assert_allclose(goal.rotation, rel.rotation @ current.rotation)


def test_tool_frame_composes_in_the_control_point_frame():
    current = pin.SE3(pin.utils.rotate("z", math.pi / 2), np.zeros(3))
    rel = pin.SE3(np.eye(3), np.array([0.1, 0.0, 0.0]))
    goal = relative_pose(current, rel, tool_frame=True)
    np.testing.assert_allclose(goal.translation, [0.0, 0.1, 0.0], atol=1e-12)


@pytest.mark.parametrize("value", [-math.tau, -1.0, 0.0, math.pi, math.tau])
def test_absolute_elbow_targets_within_one_turn_either_way(value):
    assert elbow_goal(0.3, value, relative=False, name="e") == value


@pytest.mark.parametrize("value", [-math.pi, -0.2, 0.2, math.pi])
def test_relative_elbow_changes_within_half_a_turn(value):
    assert elbow_goal(0.3, value, relative=True, name="e") == pytest.approx(0.3 + value)


@pytest.mark.parametrize(
    ("value", "relative"),
    [
        (math.radians(720), True),
        (math.radians(181), True),
        (math.radians(361), False),
        (1e6, False),
    ],
)
def test_elbow_values_outside_the_ruling_are_argument_errors(value, relative):
    with pytest.raises(ArgumentError, match=r"rel_pos.elbow: .* deg is outside"):
        elbow_goal(0.0, value, relative, "rel_pos.elbow")
