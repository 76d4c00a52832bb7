"""controller.model.elbow: the swivel-angle definition, its continuity and its gradient."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from controller.model.elbow import MIN_OFFSET, reference_vector, swivel
from controller.vocabulary import RightLeft
from tests.support import kinematics

F = np.array([1.0, 0.0, 0.0])  # forward
T = np.array([0.0, 0.0, -1.0])  # down


def wrap(x):
    """Angle difference on the circle, in (-π, π]."""
    return np.angle(np.exp(1j * np.asarray(x)))


def angle(s, e, w) -> float:
    return swivel(np.asarray(s, float), np.asarray(e, float), np.asarray(w, float), F, T).angle


def test_zero_when_the_elbow_points_down_with_the_wrist_forward():
    assert angle((0, 0, 0), (0.2, 0, -0.1), (0.4, 0, 0)) == 0.0


def test_right_handed_about_shoulder_to_wrist():
    # Wrist forward (+x): rotating down (-z) by +90 deg about +x gives +y.
    assert math.isclose(angle((0, 0, 0), (0.2, 0.1, 0), (0.4, 0, 0)), math.pi / 2)
    assert math.isclose(angle((0, 0, 0), (0.2, -0.1, 0), (0.4, 0, 0)), -math.pi / 2)


def test_reference_is_unit_and_orthogonal_to_the_direction():
    rng = np.random.default_rng(5)
    for _ in range(1000):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        if 1 + F @ u < 1e-6:
            continue
        v = reference_vector(u, F, T)
        assert abs(np.linalg.norm(v) - 1) < 1e-12
        assert abs(v @ u) < 1e-12


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_continuous_where_a_vertical_reference_plane_breaks(side: float):
    """The wrist swings through straight below the shoulder (u ∥ down) with the elbow fixed
    relative to the upper arm: the angle changes smoothly, in steps proportional to motion.
    (side=+1: elbow forward, near ±π; side=-1: elbow backward, near 0.)"""
    angles = []
    steps = np.linspace(-0.3, 0.3, 601)  # wrist direction tilt [rad], passing through 0
    for tilt in steps:
        u = np.array([math.sin(tilt), 0.05 * math.sin(3 * tilt), -math.cos(tilt)])
        u /= np.linalg.norm(u)
        w = 0.5 * u
        elbow_dir = np.cross(u, [0.0, 1.0, 0.0])
        elbow_dir /= np.linalg.norm(elbow_dir)
        e = 0.25 * u + side * 0.05 * elbow_dir
        angles.append(angle((0, 0, 0), e, w))
    jumps = np.abs(wrap(np.diff(angles)))
    assert jumps.max() < 5 * (steps[1] - steps[0])


def test_the_pole_falls_back_to_minus_down_and_stays_finite():
    s = swivel(np.zeros(3), np.array([-0.2, 0, 0.1]), np.array([-0.4, 0, 0]), F, T)
    assert math.isfinite(s.angle)
    assert math.isclose(s.angle, 0.0, abs_tol=1e-12)  # elbow on the -down side = reference
    assert all(np.isfinite(g).all() for g in (s.grad_shoulder, s.grad_elbow, s.grad_wrist))


def test_stretched_arm_has_a_bounded_gradient():
    s = swivel(np.zeros(3), np.array([0.25, 0, 0]), np.array([0.5, 0, 0]), F, T)
    assert s.offset == 0.0
    bound = 1.0 / MIN_OFFSET
    for g in (s.grad_shoulder, s.grad_elbow, s.grad_wrist):
        assert np.isfinite(g).all() and np.abs(g).max() <= 10 * bound


points = st.tuples(*[st.floats(-0.6, 0.6) for _ in range(3)])


@settings(max_examples=300, deadline=None)
@given(points, points, points)
def test_gradient_matches_finite_differences(s, e, w):
    s, e, w = (np.asarray(p, float) for p in (s, e, w))
    d = w - s
    if np.linalg.norm(d) < 0.1:
        return
    u = d / np.linalg.norm(d)
    if 1 + F @ u < 0.05:  # near the pole the reference turns fast
        return
    result = swivel(s, e, w, F, T)
    if result.offset < 0.02:
        return
    h = 1e-7
    for which, grad in ((0, result.grad_shoulder), (1, result.grad_elbow), (2, result.grad_wrist)):
        for i in range(3):
            pts_p = [s.copy(), e.copy(), w.copy()]
            pts_m = [s.copy(), e.copy(), w.copy()]
            pts_p[which][i] += h
            pts_m[which][i] -= h
            num = wrap(swivel(*pts_p, F, T).angle - swivel(*pts_m, F, T).angle) / (2 * h)
            assert abs(num - grad[i]) < 1e-5 * max(1.0, abs(grad[i]))


def test_smartpal_elbow_angle_is_continuous_over_a_shoulder_sweep():
    """Raise the arm from hanging to overhead (J1 over its whole range): no jumps."""
    kin = kinematics("smartpal5")
    q = kin.home()
    j1 = kin.index("r_arm_j1")
    values = []
    sweep = np.radians(np.linspace(-45, 180, 901))
    for a in sweep:
        q[j1] = a
        kin.update(q)
        values.append(kin.elbow_angle(RightLeft.RIGHT))
    assert np.abs(wrap(np.diff(values))).max() < 5 * (sweep[1] - sweep[0])


def test_mirrored_postures_read_opposite_angles():
    """Right-hand positive about shoulder→wrist: the mirror image of a posture reads -φ."""
    kin = kinematics("smartpal5")
    kin.update(kin.home())
    right = kin.elbow_angle(RightLeft.RIGHT)
    left = kin.elbow_angle(RightLeft.LEFT)
    assert abs(right) > 1e-3
    assert math.isclose(right, -left, abs_tol=1e-12)
