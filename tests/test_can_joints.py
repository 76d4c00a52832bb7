"""hal.can.joints: joint set-points -> drive counts and feedback counts -> SI joint state."""

from __future__ import annotations

import numpy as np
import pytest

from hal.can.drive_profile import drives_path, load_drive_profile
from hal.can.joints import JointMap, joint_names
from hal.can.scaling import I32_MAX
from tests.support import robot


def make(robot_id: str) -> JointMap:
    r = robot(robot_id)
    return JointMap(r, load_drive_profile(drives_path(r), r), 0.002)


def test_joint_names_are_unit_joints_then_grippers():
    r = robot("smartpal5")
    names = joint_names(r)
    assert names[-len(r.gripper_joints) :] == r.gripper_joints
    assert "vehicle_x" in names and "wheel_1" not in names


def test_command_then_feedback_round_trip():
    m = make("pa10")
    all_seen = np.ones(len(m.drive_names), dtype=bool)
    q = np.linspace(-0.5, 0.5, len(m.joint_names))
    counts = np.full(len(m.drive_names), 0, dtype=np.int64)
    m.command(q, counts)
    m.update(counts, np.full(len(counts), 0, dtype=np.int64), all_seen, all_seen)
    np.testing.assert_allclose(m.position, q, atol=1e-5)
    np.testing.assert_allclose(m.target[m.joint_drive], q[m.joint_idx])
    m.update(counts, np.full(len(counts), 0, dtype=np.int64), all_seen, all_seen)
    np.testing.assert_allclose(m.velocity, 0.0, atol=1e-9)  # same counts: at rest


def test_unseen_drives_keep_their_position_and_stale_ones_their_velocity():
    m = make("pa10")
    n = len(m.drive_names)
    seen, fresh = np.ones(n, dtype=bool), np.ones(n, dtype=bool)
    a, b, c = np.flatnonzero(~m.has_velocity)[:3]  # velocity from positions
    m.update(np.full(n, 1000, dtype=np.int64), np.full(n, 0, dtype=np.int64), fresh, seen)
    before, vel_before = m.pos.copy(), m.vel.copy()
    seen[a] = fresh[a] = False
    fresh[b] = False
    m.update(np.full(n, 5000, dtype=np.int64), np.full(n, 0, dtype=np.int64), fresh, seen)
    assert m.pos[a] == before[a] and m.pos[b] != before[b]
    assert m.vel[b] == vel_before[b] and m.vel[c] != vel_before[c]


def test_wheels_integrate_across_the_32_bit_wrap():
    m = make("smartpal5")
    n = len(m.drive_names)
    ones = np.ones(n, dtype=bool)
    w = m.wheel_idx[0]
    raw = np.full(n, 0, dtype=np.int64)
    raw[w] = I32_MAX - 10
    m.update(raw, np.full(n, 0, dtype=np.int64), ones, ones)
    start = m.pos[w]
    raw[w] = -(2**31) + 9  # 20 counts further, wrapped
    m.update(raw, np.full(n, 0, dtype=np.int64), ones, ones)
    assert m.pos[w] - start == pytest.approx(20 / m.scale.factor[w])


def test_vehicle_command_moves_the_wheels_and_odometry_follows():
    m = make("smartpal5")
    n = len(m.drive_names)
    ones = np.ones(n, dtype=bool)
    counts = np.full(n, 0, dtype=np.int64)
    m.update(counts, np.full(n, 0, dtype=np.int64), ones, ones)
    m.hold()
    q = m.position.copy()
    x = m.joint_names.index("vehicle_x")
    q[x] += 0.01
    m.command(q, counts)
    m.update(counts, np.full(n, 0, dtype=np.int64), ones, ones)
    assert m.position[x] == pytest.approx(q[x], abs=1e-5)


def test_a_joint_without_a_drive_is_refused():
    r = robot("pa10")
    profile = load_drive_profile(drives_path(r), r)
    drives = dict(profile.drives)
    del drives["J3"]
    with pytest.raises(ValueError, match="joints without a drive: \\['J3'\\]"):
        JointMap(r, profile.model_copy(update={"drives": drives}), 0.002)
