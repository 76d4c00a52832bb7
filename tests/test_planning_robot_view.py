"""controller.gateway.planning.robot_view: poses from the snapshot; a repeated query of the
same published state is answered without the kinematics (issue 17.12)."""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
import pytest

from controller.vocabulary import FrameType, RightLeft
from tests.planning_support import FixedReader, robot, snapshot, view


class _CountingView:
    """Counts how often the view runs its kinematics (``Kinematics.update``)."""

    def __init__(self, name: str):
        rob = robot(name)
        self.reader = FixedReader(snapshot(rob))
        self.view = view(rob, self.reader)
        self.runs = 0
        update = self.view.kin.update

        def counted(*args: Any, **kwargs: Any) -> Any:
            self.runs += 1
            return update(*args, **kwargs)

        self.view.kin.update = counted  # type: ignore[method-assign]


class _CountingLock:
    """A lock that counts the attempts to take it (to see a caller waiting for it)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.attempts = 0

    def __enter__(self) -> None:
        self.attempts += 1
        self._lock.acquire()

    def __exit__(self, *exc: object) -> None:
        self._lock.release()


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


def test_frames_are_given_to_the_kinematics_again_only_when_they_change():
    """RobotView.at sets the control-point offsets and the original frame only when the
    snapshot's differ from the last ones it set; every answer still uses the snapshot's."""
    rob = robot("pa10")
    arm = rob.unit_joints("RIGHT_ARM")[0]
    fresh = view(rob, FixedReader(snapshot(rob)))  # a second view: its own Kinematics
    c = _CountingView("pa10")
    kin = c.view.kin
    sets: list[str] = []
    for name in ("set_control_point_offset", "set_original_frame"):
        method = getattr(kin, name)

        def counted(*args: Any, _m: Any = method, _n: str = name, **kwargs: Any) -> Any:
            sets.append(_n)
            return _m(*args, **kwargs)

        setattr(kin, name, counted)
    tool = snapshot(rob, {arm: 0.2})
    tool.offsets[0, 2, 3] += 0.1
    back = snapshot(rob, {arm: 0.3})  # (a new q: not an answer RobotView.pose kept)
    for k, snap in enumerate([snapshot(rob), snapshot(rob, {arm: 0.1}), tool, back]):
        got = c.view.pose(snap, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)[0]
        fresh._frames = None  # the reference sets its frames every time
        want = fresh.pose(snap, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME)[0]
        np.testing.assert_allclose(got.homogeneous, want.homogeneous, atol=1e-12, err_msg=str(k))
    # the first snapshot, the tool's and the way back: three times, not four
    assert sets.count("set_original_frame") == 3


def test_readers_of_one_snapshot_arriving_together_run_the_kinematics_once():
    """A second reader that arrives while the first computes the pose of the same snapshot
    waits for that answer instead of computing it again (issue 17.12: at most one
    kinematics run per snapshot, however many clients poll it)."""
    c = _CountingView("pa10")
    snap = c.reader.snap
    lock = _CountingLock()
    c.view._lock = lock  # type: ignore[assignment]
    inside, release = threading.Event(), threading.Event()
    counted = c.view.kin.update

    def held(*args: Any, **kwargs: Any) -> Any:
        inside.set()
        assert release.wait(30.0)
        return counted(*args, **kwargs)

    c.view.kin.update = held  # type: ignore[method-assign]
    answers: list[Any] = []

    def read() -> None:
        answers.append(c.view.pose(snap, RightLeft.RIGHT, FrameType.ORIGINAL_FRAME))

    first = threading.Thread(target=read)
    first.start()
    assert inside.wait(30.0)  # the first reader computes, holding the view's lock
    second = threading.Thread(target=read)
    second.start()
    deadline = time.monotonic() + 30.0
    while lock.attempts < 2 and time.monotonic() < deadline:  # the second waits for it
        time.sleep(0.001)
    assert lock.attempts == 2
    release.set()
    first.join(30.0)
    second.join(30.0)
    assert c.runs == 1
    np.testing.assert_array_equal(answers[0][0].homogeneous, answers[1][0].homogeneous)
