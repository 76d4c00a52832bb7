"""controller.gateway.planning.robot_view: poses from the snapshot; a repeated query of the
same published state is answered without the kinematics (issue 17.12)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from controller.vocabulary import FrameType, RightLeft
from tests.planning_support import FixedReader, robot, snapshot, view


class _CountingView:
    """Counts how often the view runs its kinematics."""

    def __init__(self, name: str):
        rob = robot(name)
        self.reader = FixedReader(snapshot(rob))
        self.view = view(rob, self.reader)
        self.runs = 0
        at = self.view.at

        def counted(*args: Any, **kwargs: Any) -> Any:
            self.runs += 1
            return at(*args, **kwargs)

        self.view.at = counted  # type: ignore[method-assign]


@pytest.mark.parametrize("name", ["pa10", "smartpal5"])
def test_the_same_state_twice_is_one_kinematics_run_with_the_same_answer(name: str):
    c = _CountingView(name)
    snap = c.reader.snap
    first = c.view.pose(snap, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)
    again = c.view.pose(snap, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)
    assert c.runs == 1
    np.testing.assert_array_equal(first[0].homogeneous, again[0].homogeneous)
    assert first[1] == again[1]
    again[0].translation = np.array([9.0, 9.0, 9.0])  # a caller's copy, not the kept one
    third = c.view.pose(snap, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)
    np.testing.assert_array_equal(third[0].homogeneous, first[0].homogeneous)


def test_anything_the_pose_depends_on_is_a_new_answer():
    c = _CountingView("pa10")
    snap = c.reader.snap
    base = c.view.pose(snap, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)[0]
    moved = snapshot(robot("pa10"), {robot("pa10").unit_joints("RIGHT_ARM")[0]: 0.3})
    assert not np.allclose(
        c.view.pose(moved, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)[0].homogeneous,
        base.homogeneous,
    )
    tool = snapshot(robot("pa10"))
    tool.offsets[0, 2, 3] += 0.1  # the control point 100 mm further along the flange's z
    shifted = c.view.pose(tool, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)[0]
    assert np.linalg.norm(shifted.translation - base.translation) == pytest.approx(0.1)
    frame = snapshot(robot("pa10"))
    frame.original[0, 3] = 1.0  # the original frame 1 m along x
    seen = c.view.pose(frame, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)[0]
    assert seen.translation[0] == pytest.approx(base.translation[0] - 1.0)
    assert c.runs == 4
    c.view.pose(snap, RightLeft.RIGHT, FrameType.CURRENT_FRAME)  # another frame
    assert c.runs == 5
