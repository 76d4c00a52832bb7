"""Geometric paths in s ∈ [0, 1]: VectorPath, LinePath (Cartesian line) and ArcPath."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from controller.motion.paths import ArcPath, LinePath, VectorPath
from tests.motion_support import chord_twist

#: Step of the central differences in s.
H = 1e-6
SETTINGS = settings(deadline=None, max_examples=40)

coordinate = st.floats(-1.0, 1.0)
vec3 = st.tuples(coordinate, coordinate, coordinate).map(np.array)
unit_s = st.floats(0.0, 1.0)


def rotation_vector(max_angle: float) -> st.SearchStrategy[np.ndarray]:
    """Rotation vectors of norm at most ``max_angle`` (below π: a unique geodesic)."""
    direction = st.tuples(coordinate, coordinate, coordinate).map(np.array)
    return st.tuples(direction, st.floats(0.0, max_angle)).map(
        lambda da: (
            da[0] / np.linalg.norm(da[0]) * da[1] if np.linalg.norm(da[0]) > 1e-3 else np.zeros(3)
        )
    )


poses = st.tuples(vec3, rotation_vector(3.0)).map(lambda pr: pin.SE3(pin.exp3(pr[1]), pr[0]))


def pose(p, rot=(0.0, 0.0, 0.0)) -> pin.SE3:
    return pin.SE3(pin.exp3(np.asarray(rot, dtype=float)), np.asarray(p, dtype=float))


def angle_between(r1: np.ndarray, r2: np.ndarray) -> float:
    return float(np.linalg.norm(pin.log3(r1.T @ r2)))


def finite_difference_twist(path: LinePath | ArcPath, s: float, sd: float) -> np.ndarray:
    """d/dt of ``path.at(s(t))`` by central differences: linear, then angular (world axes)."""
    before, after = path.at(s - H), path.at(s + H)
    out = np.empty(6)
    out[:3] = (after.translation - before.translation) / (2 * H) * sd
    out[3:] = pin.log3(after.rotation @ before.rotation.T) / (2 * H) * sd
    return out


def assert_samples_spaced(path: LinePath | ArcPath, step: float, angle_step: float) -> None:
    samples = path.samples(step, angle_step)
    assert samples[0] == 0.0 and samples[-1] == 1.0
    for a, b in itertools.pairwise(samples):
        assert b > a
        assert (b - a) * path.length <= step * (1 + 1e-9)
        assert (b - a) * path.angle <= angle_step * (1 + 1e-9)


# ----------------------------------------------------------------------------- VectorPath
def test_vector_path_runs_from_start_to_end_and_clamps_s():
    path = VectorPath(np.array([1.0, -2.0, 0.5]), np.array([3.0, 2.0, 0.5]))
    assert np.array_equal(path.at(0.0), [1.0, -2.0, 0.5])
    assert np.array_equal(path.at(1.0), [3.0, 2.0, 0.5])
    assert np.allclose(path.at(0.25), [1.5, -1.0, 0.5], rtol=0, atol=1e-15)
    assert np.array_equal(path.at(-0.5), path.at(0.0))
    assert np.array_equal(path.at(1.5), path.at(1.0))


@SETTINGS
@given(start=vec3, end=vec3, s=unit_s, sd=st.floats(-3.0, 3.0))
def test_vector_path_rate_is_the_extent_times_sd(start, end, s, sd):
    path = VectorPath(start, end)
    assert np.allclose(path.rate(s, sd), (end - start) * sd, rtol=0, atol=1e-15)


def test_vector_path_limits_are_set_by_the_tightest_axis():
    path = VectorPath(np.zeros(3), np.array([0.5, -2.0, 0.0]))
    speed = np.array([1.0, 1.0, 1e-9])  # the third axis does not move: its limit is ignored
    accel = np.array([4.0, 2.0, 1e-9])
    v, a = path.limits(speed, accel)
    assert v == pytest.approx(min(1.0 / 0.5, 1.0 / 2.0))
    assert a == pytest.approx(min(4.0 / 0.5, 2.0 / 2.0))


def test_vector_path_without_motion_is_empty_and_unlimited():
    empty = VectorPath(np.array([0.3, 0.4]), np.array([0.3, 0.4]))
    assert empty.is_empty
    assert empty.limits(np.ones(2), np.ones(2)) == (math.inf, math.inf)
    assert not VectorPath(np.zeros(2), np.array([0.0, 1e-6])).is_empty


# ------------------------------------------------------------------------------- LinePath
@SETTINGS
@given(start=poses, p_end=vec3, rot=rotation_vector(3.0))
def test_line_path_runs_from_start_to_end(start, p_end, rot):
    end = pin.SE3(start.rotation @ pin.exp3(rot), p_end)
    path = LinePath(start, end)
    assert np.allclose(path.at(0.0).homogeneous, start.homogeneous, rtol=0, atol=1e-12)
    assert np.allclose(path.at(1.0).homogeneous, end.homogeneous, rtol=0, atol=1e-12)
    assert path.length == pytest.approx(np.linalg.norm(p_end - start.translation))
    assert path.angle == pytest.approx(np.linalg.norm(rot), abs=1e-12)


@SETTINGS
@given(start=poses, p_end=vec3, rot=rotation_vector(3.1), s=unit_s, tiny=st.booleans())
def test_line_path_poses_are_the_same_compiled_and_through_pinocchio(start, p_end, rot, s, tiny):
    """LinePath.at's compiled Rodrigues formula against pin.exp3, also at angles where it
    takes its series (θ < 1e-4)."""
    if tiny:
        rot = rot * 1e-6
    path = LinePath(start, pin.SE3(start.rotation @ pin.exp3(rot), p_end))
    path._compiled = True
    compiled = path.at(s)
    path._compiled = False
    through_pinocchio = path.at(s)
    np.testing.assert_allclose(compiled.rotation, through_pinocchio.rotation, rtol=0, atol=1e-14)
    np.testing.assert_allclose(
        compiled.translation, through_pinocchio.translation, rtol=0, atol=1e-14
    )


@SETTINGS
@given(start=poses, p_end=vec3, rot=rotation_vector(3.0), s=unit_s)
def test_line_path_is_linear_in_position_and_on_the_geodesic_in_orientation(start, p_end, rot, s):
    path = LinePath(start, pin.SE3(start.rotation @ pin.exp3(rot), p_end))
    here = path.at(s)
    expected = start.translation + s * (p_end - start.translation)
    assert np.allclose(here.translation, expected, rtol=0, atol=1e-12)
    # Rotation from the start: axis constant, angle proportional to s.
    assert np.allclose(pin.log3(start.rotation.T @ here.rotation), s * rot, rtol=0, atol=1e-9)


@SETTINGS
@given(
    start=poses,
    p_end=vec3,
    rot=rotation_vector(3.0),
    s=st.floats(0.01, 0.99),
    sd=st.floats(-2.0, 2.0),
)
def test_line_path_twist_is_the_time_derivative_of_the_pose(start, p_end, rot, s, sd):
    path = LinePath(start, pin.SE3(start.rotation @ pin.exp3(rot), p_end))
    twist = path.twist(s, sd)
    assert np.allclose(twist, finite_difference_twist(path, s, sd), rtol=0, atol=1e-6)


def test_line_path_limits_are_euclidean_and_the_tighter_of_translation_and_rotation():
    start = pose([0.1, 0.2, 0.3])
    path = LinePath(start, pose([0.4, 0.6, 0.3], [0.0, 0.0, 0.25]))  # 0.5 m, 0.25 rad
    assert path.length == pytest.approx(0.5) and path.angle == pytest.approx(0.25)
    v, a = path.limits((0.5, 1.0), (2.0, 0.25))
    assert v == pytest.approx(0.5 / 0.5)  # translation limits (rotation would allow 4)
    assert a == pytest.approx(0.25 / 0.25)  # rotation limits (translation would allow 4)
    v, _ = path.limits((0.5, 0.1), (2.0, 2.0))
    assert v == pytest.approx(0.1 / 0.25)


def test_line_path_limits_ignore_a_component_that_does_not_move():
    turn = LinePath(pose([0, 0, 0]), pose([0, 0, 0], [0.0, 0.5, 0.0]))
    assert turn.limits((1e-9, 1.0), (1e-9, 2.0)) == pytest.approx((2.0, 4.0))
    shift = LinePath(pose([0, 0, 0]), pose([0.2, 0, 0]))
    assert shift.limits((1.0, 1e-9), (2.0, 1e-9)) == pytest.approx((5.0, 10.0))
    still = LinePath(pose([0.1, 0, 0], [0.3, 0, 0]), pose([0.1, 0, 0], [0.3, 0, 0]))
    assert still.limits((1.0, 1.0), (1.0, 1.0)) == (math.inf, math.inf)


@SETTINGS
@given(
    start=poses,
    p_end=vec3,
    rot=rotation_vector(3.0),
    step=st.floats(0.005, 0.2),
    angle_step=st.floats(math.radians(0.5), math.radians(20)),
)
def test_line_path_samples_are_at_most_a_step_apart_and_include_both_ends(
    start, p_end, rot, step, angle_step
):
    path = LinePath(start, pin.SE3(start.rotation @ pin.exp3(rot), p_end))
    assert_samples_spaced(path, step, angle_step)


def test_line_path_samples_of_a_zero_path_are_its_ends():
    still = LinePath(pose([0.1, 0, 0]), pose([0.1, 0, 0]))
    assert still.samples() == [0.0, 1.0]


# -------------------------------------------------------------------------------- ArcPath
def circle_points(
    centre: np.ndarray, radius: float, normal: np.ndarray, angles: tuple[float, ...]
) -> list[np.ndarray]:
    """Points at ``angles`` [rad] on a circle (angle 0 on an arbitrary radius)."""
    normal = normal / np.linalg.norm(normal)
    e1 = np.cross(normal, [1.0, 0.0, 0.0])
    if np.linalg.norm(e1) < 0.1:
        e1 = np.cross(normal, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    return [centre + radius * (math.cos(t) * e1 + math.sin(t) * e2) for t in angles]


def arc(
    centre: np.ndarray,
    radius: float,
    normal: np.ndarray,
    via_angle: float,
    end_angle: float,
    rotations: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> ArcPath:
    """The arc on a known circle from angle 0 through ``via_angle`` to ``end_angle``."""
    points = circle_points(centre, radius, normal, (0.0, via_angle, end_angle))
    rotations = rotations or (np.eye(3), np.eye(3), np.eye(3))
    start, via, end = (pin.SE3(r, p) for r, p in zip(rotations, points, strict=True))
    return ArcPath(start, via, end)


circles = st.fixed_dictionaries(
    {
        "centre": vec3,
        "radius": st.floats(0.05, 1.0),
        "normal": st.tuples(coordinate, coordinate, coordinate)
        .map(np.array)
        .filter(lambda n: np.linalg.norm(n) > 0.1),
        "via_angle": st.floats(0.1, 3.0),
        "end_angle": st.floats(3.2, 6.0),
    }
)


@SETTINGS
@given(circle=circles)
def test_arc_passes_through_start_via_and_end(circle):
    path = arc(**circle)
    assert path.radius == pytest.approx(circle["radius"], rel=1e-9)
    assert np.allclose(path.centre, circle["centre"], rtol=0, atol=1e-9)
    assert 0.0 < path.s_via < 1.0
    assert path.s_via == pytest.approx(circle["via_angle"] / circle["end_angle"], rel=1e-9)
    angles = (0.0, circle["via_angle"], circle["end_angle"])
    start, via, end = circle_points(circle["centre"], circle["radius"], circle["normal"], angles)
    assert np.allclose(path.at(0.0).translation, start, rtol=0, atol=1e-9)
    assert np.allclose(path.at(path.s_via).translation, via, rtol=0, atol=1e-9)
    assert np.allclose(path.at(1.0).translation, end, rtol=0, atol=1e-9)
    assert path.length == pytest.approx(circle["radius"] * circle["end_angle"], rel=1e-9)


def test_arc_position_at_s_via_is_the_via_point():
    start, via, end = pose([0.4, -0.2, 0.5]), pose([0.45, -0.1, 0.6]), pose([0.4, 0.05, 0.55])
    path = ArcPath(start, via, end)
    assert np.allclose(path.at(path.s_via).translation, via.translation, rtol=0, atol=1e-9)
    assert np.allclose(path.at(1.0).translation, end.translation, rtol=0, atol=1e-9)


@SETTINGS
@given(circle=circles)
def test_arc_samples_stay_on_the_circle_in_its_plane(circle):
    path = arc(**circle)
    normal = circle["normal"] / np.linalg.norm(circle["normal"])
    for s in path.samples(0.02, math.radians(5)):
        offset = path.at(s).translation - circle["centre"]
        assert np.linalg.norm(offset) == pytest.approx(circle["radius"], rel=1e-9)
        assert abs(float(offset @ normal)) <= 1e-9


def test_arc_orientation_follows_the_start_to_end_geodesic_and_ignores_the_via_orientation():
    """The via pose gives a position only: the orientation turns from start to end in
    proportion to s, so the angular velocity never jumps."""
    r_start = pin.exp3(np.array([0.1, 0.2, 0.3]))
    r_end = r_start @ pin.exp3(np.array([0.0, 0.0, 0.9]))
    centre, normal = np.array([0.5, 0.0, 0.5]), np.array([0.0, 0.3, 1.0])
    plain = arc(centre, 0.2, normal, 1.0, 2.5, (r_start, r_start, r_end))
    twisted = arc(centre, 0.2, normal, 1.0, 2.5, (r_start, pin.exp3(np.array([1, 0, 0])), r_end))
    for s in (0.0, 0.2, plain.s_via, 0.7, 1.0):
        assert angle_between(plain.at(s).rotation, twisted.at(s).rotation) <= 1e-12
        expected = r_start @ pin.exp3(s * np.array([0.0, 0.0, 0.9]))
        assert angle_between(plain.at(s).rotation, expected) <= 1e-9
    assert angle_between(plain.at(1.0).rotation, r_end) <= 1e-12
    assert angle_between(plain.at(0.0).rotation, r_start) <= 1e-12


@SETTINGS
@given(
    circle=circles,
    rot=rotation_vector(2.5),
    s=st.floats(0.01, 0.99),
    sd=st.floats(-2.0, 2.0),
)
def test_arc_twist_is_the_time_derivative_of_the_pose(circle, rot, s, sd):
    r_start = pin.exp3(np.array([0.3, -0.2, 0.1]))
    path = arc(**circle, rotations=(r_start, r_start, r_start @ pin.exp3(rot)))
    twist = path.twist(s, sd)
    assert np.allclose(twist, finite_difference_twist(path, s, sd), rtol=0, atol=1e-6)
    # Constant speed along the arc.
    assert np.linalg.norm(twist[:3]) == pytest.approx(path.length * abs(sd), rel=1e-9, abs=1e-15)


@pytest.mark.parametrize(
    "via, end",
    [
        ([0.1, 0.0, 0.0], [0.2, 0.0, 0.0]),  # on one line
        ([0.2, 0.0, 0.0], [0.1, 0.0, 0.0]),  # on one line, via beyond the end
        ([0.0, 0.0, 0.0], [0.2, 0.1, 0.0]),  # via = start
        ([0.2, 0.1, 0.0], [0.0, 0.0, 0.0]),  # end = start
    ],
)
def test_collinear_points_are_rejected(via, end):
    with pytest.raises(ValueError, match="collinear"):
        ArcPath(pose([0.0, 0.0, 0.0]), pose(via), pose(end))


def test_arc_limits_keep_the_centripetal_acceleration_within_the_translation_limit():
    tight = arc(np.zeros(3), 0.05, np.array([0.0, 0.0, 1.0]), 1.0, math.pi)
    speed, accel = (1.0, 1.0), (0.5, 10.0)
    v, a = tight.limits(speed, accel)
    centripetal = math.sqrt(accel[0] * tight.radius) / tight.length
    assert centripetal < speed[0] / tight.length  # the centripetal term is the binding one
    assert v == pytest.approx(centripetal)
    assert (v * tight.length) ** 2 / tight.radius <= accel[0] * (1 + 1e-9)
    assert a == pytest.approx(accel[0] / tight.length)


def test_arc_limits_on_a_wide_arc_are_the_speed_limits():
    wide = arc(np.zeros(3), 1.0, np.array([0.0, 0.0, 1.0]), 0.5, 1.0)
    v, a = wide.limits((0.2, 1.0), (2.0, 1.0))
    assert v == pytest.approx(0.2 / wide.length)
    assert a == pytest.approx(2.0 / wide.length)


def test_arc_limits_include_the_rotation_limits():
    turning = arc(
        np.zeros(3),
        0.3,
        np.array([0.0, 0.0, 1.0]),
        0.5,
        1.0,
        (np.eye(3), np.eye(3), pin.exp3(np.array([0.0, 0.0, 1.5]))),
    )
    v, a = turning.limits((10.0, 0.3), (100.0, 0.6))
    assert turning.angle == pytest.approx(1.5)
    assert v == pytest.approx(0.3 / 1.5)
    assert a == pytest.approx(0.6 / 1.5)


@SETTINGS
@given(
    circle=circles,
    rot=rotation_vector(2.5),
    step=st.floats(0.01, 0.2),
    angle_step=st.floats(math.radians(0.5), math.radians(20)),
)
def test_arc_samples_are_at_most_a_step_apart_and_include_both_ends(circle, rot, step, angle_step):
    path = arc(**circle, rotations=(np.eye(3), np.eye(3), pin.exp3(rot)))
    assert_samples_spaced(path, step, angle_step)
    assert len(path.samples(step, angle_step)) >= 3


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    st.floats(0.0, 1.0),
    st.floats(0.0, 0.02),
    st.floats(1e-4, 0.01),
    st.booleans(),
)
def test_average_twist_in_closed_form_is_the_chord_between_two_poses(
    v: list[float], s0: float, ds: float, dt: float, arc: bool
):
    """Both paths' closed forms equal log3 of the relative rotation (and the position chord),
    ends clamped included (s1 may pass 1)."""
    start = pin.SE3(pin.exp3(np.array(v[3:]) * 2.0), np.array([0.3, -0.2, 0.8]))
    end = pin.SE3(
        pin.exp3(np.array(v[:3]) * 2.0), np.array([0.5, 0.1, 0.9]) + 0.1 * np.array(v[3:])
    )
    if arc:
        via = pin.SE3(start.rotation, np.array([0.45, -0.15, 1.1]))
        path: LinePath | ArcPath = ArcPath(start, via, end)
    else:
        path = LinePath(start, end)
    s1 = s0 + ds
    expected = chord_twist(path.at(s0), path.at(s1), dt)
    np.testing.assert_allclose(path.average_twist(s0, s1, dt), expected, rtol=0, atol=1e-9 / dt)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    st.floats(-0.1, 1.1),
    st.floats(0.0, 0.05),
    st.floats(1e-4, 0.01),
    st.sampled_from(["line compiled", "line numpy", "arc"]),
)
def test_follow_writes_the_pose_at_s0_and_the_average_twist_in_place(
    v: list[float], s0: float, ds: float, dt: float, kind: str
):
    """``follow`` gives what ``at`` and ``average_twist`` give (s outside [0, 1] clamped), into
    the caller's buffers, on both paths and both forms of the line."""
    start = pin.SE3(pin.exp3(np.array(v[3:]) * 2.0), np.array([0.3, -0.2, 0.8]))
    end = pin.SE3(
        pin.exp3(np.array(v[:3]) * 2.0), np.array([0.5, 0.1, 0.9]) + 0.1 * np.array(v[3:])
    )
    if kind == "arc":
        via = pin.SE3(start.rotation, np.array([0.45, -0.15, 1.1]))
        path: LinePath | ArcPath = ArcPath(start, via, end)
    else:
        path = LinePath(start, end)
        path._compiled = kind == "line compiled"
    s1 = s0 + ds
    rotation, position, twist = np.full((3, 3), np.nan), np.full(3, np.nan), np.full(6, np.nan)
    keep = (rotation, position, twist)
    path.follow(s0, s1, dt, rotation, position, twist)
    assert all(a is b for a, b in zip(keep, (rotation, position, twist), strict=True))
    pose = path.at(s0)
    np.testing.assert_allclose(rotation, pose.rotation, rtol=0, atol=1e-14)
    np.testing.assert_allclose(position, pose.translation, rtol=0, atol=1e-14)
    np.testing.assert_allclose(twist, path.average_twist(s0, s1, dt), rtol=0, atol=1e-12)
