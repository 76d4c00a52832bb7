"""controller.conversions: HgMatrix [mm] <-> SE3 [m], deg <-> rad, mm <-> m."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given
from hypothesis import strategies as st

from controller.conversions import (
    ORTHONORMAL_TOL,
    ArgumentError,
    deg_to_rad,
    finite_array,
    hg_to_se3,
    m_to_mm,
    mm_to_m,
    offset_to_se3,
    rad_to_deg,
    se3_to_hg,
)

NAME = "target_pose"


def random_rotation(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rpy = rng.uniform(-math.pi, math.pi, 3)
    return np.asarray(pin.rpy.rpyToMatrix(*rpy))


def hg(rotation: np.ndarray, translation_mm: np.ndarray | list[float]) -> np.ndarray:
    out = np.empty((3, 4))
    out[:, :3] = rotation
    out[:, 3] = translation_mm
    return out


def identity_hg() -> np.ndarray:
    return hg(np.eye(3), [0.0, 0.0, 0.0])


def valid_hg(seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed + 1000)
    return hg(random_rotation(seed), rng.uniform(-2000.0, 2000.0, 3))


def rejected(value: object) -> str:
    with pytest.raises(ArgumentError) as info:
        hg_to_se3(value, name=NAME)
    message = str(info.value)
    assert message.startswith(f"{NAME}: ")
    return message


# ----------------------------------------------------------------------------- accepted
def test_hg_identity_is_se3_identity() -> None:
    pose = hg_to_se3(identity_hg())
    assert pose.isIdentity()


def test_hg_identity_as_nested_lists_is_accepted() -> None:
    pose = hg_to_se3(identity_hg().tolist())
    assert pose.isIdentity()


@pytest.mark.parametrize("seed", range(5))
def test_hg_random_rotation_keeps_rotation(seed: int) -> None:
    rot = random_rotation(seed)
    pose = hg_to_se3(hg(rot, [0.0, 0.0, 0.0]))
    np.testing.assert_allclose(pose.rotation, rot, rtol=0, atol=1e-14)


def test_hg_translation_mm_becomes_m() -> None:
    pose = hg_to_se3(hg(np.eye(3), [1000.0, -250.0, 12.5]))
    np.testing.assert_allclose(pose.translation, [1.0, -0.25, 0.0125], rtol=1e-15, atol=0)


def test_se3_to_hg_translation_m_becomes_mm() -> None:
    out = se3_to_hg(pin.SE3(np.eye(3), np.array([0.5, -1.25, 2.0])))
    assert out.shape == (3, 4)
    np.testing.assert_allclose(out[:, 3], [500.0, -1250.0, 2000.0], rtol=1e-15, atol=0)


@pytest.mark.parametrize("seed", range(10))
def test_hg_round_trip(seed: int) -> None:
    matrix = valid_hg(seed)
    np.testing.assert_allclose(se3_to_hg(hg_to_se3(matrix)), matrix, rtol=0, atol=1e-12)


@pytest.mark.parametrize(("row", "col"), [(0, 0), (1, 2), (2, 1)])
def test_hg_rotation_slightly_off_is_accepted_and_projected(row: int, col: int) -> None:
    rot = random_rotation(7)
    noisy = rot.copy()
    noisy[row, col] += 1e-8
    assert np.abs(noisy.T @ noisy - np.eye(3)).max() < ORTHONORMAL_TOL
    pose = hg_to_se3(hg(noisy, [1.0, 2.0, 3.0]))
    r = pose.rotation
    assert np.abs(r.T @ r - np.eye(3)).max() < 1e-14
    assert abs(np.linalg.det(r) - 1.0) < 1e-14
    np.testing.assert_allclose(r, rot, rtol=0, atol=1e-7)


# ----------------------------------------------------------------------------- rejected
def test_hg_scaled_rotation_is_rejected() -> None:
    assert "not orthonormal" in rejected(hg(1.01 * random_rotation(3), [0.0, 0.0, 0.0]))


def test_hg_sheared_rotation_is_rejected() -> None:
    shear = np.array([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    assert "not orthonormal" in rejected(hg(random_rotation(4) @ shear, [0.0, 0.0, 0.0]))


def test_hg_rotation_off_beyond_tolerance_is_rejected() -> None:
    rot = np.eye(3)
    rot[0, 1] = 1e-4
    assert "not orthonormal" in rejected(hg(rot, [0.0, 0.0, 0.0]))


@pytest.mark.parametrize("axis", range(3))
def test_hg_reflection_is_rejected(axis: int) -> None:
    flip = np.eye(3)
    flip[axis, axis] = -1.0
    message = rejected(hg(random_rotation(5) @ flip, [0.0, 0.0, 0.0]))
    assert "determinant" in message
    assert "+1" in message


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("index", range(12))
def test_hg_non_finite_element_is_rejected(index: int, bad: float) -> None:
    matrix = valid_hg(2)
    matrix.ravel()[index] = bad
    message = rejected(matrix)
    assert f"element {index}" in message
    assert "finite" in message


@pytest.mark.parametrize(
    "value",
    [np.eye(3), np.eye(4), identity_hg().ravel(), identity_hg().ravel().tolist(), identity_hg().T],
    ids=["3x3", "4x4", "flat-12-array", "flat-12-list", "4x3"],
)
def test_hg_wrong_shape_is_rejected(value: object) -> None:
    assert "shape" in rejected(value)


@pytest.mark.parametrize(
    "value",
    [
        "identity",
        [["a", "b", "c", "d"], ["e", "f", "g", "h"], ["i", "j", "k", "l"]],
        [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, "zero"]],
        {"R": np.eye(3).tolist()},
        [[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0]],
    ],
    ids=["string", "strings", "one-string", "dict", "ragged"],
)
def test_hg_non_numeric_is_rejected(value: object) -> None:
    assert "expected numbers" in rejected(value)


def test_hg_none_is_rejected() -> None:
    rejected(None)


def test_hg_default_name_is_hgmatrix() -> None:
    with pytest.raises(ArgumentError, match=r"^HgMatrix: "):
        hg_to_se3(np.eye(3))


# -------------------------------------------------------------------------- unit scaling
finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False, allow_subnormal=False)


@given(finite)
def test_deg_rad_round_trip(value: float) -> None:
    np.testing.assert_allclose(rad_to_deg(deg_to_rad(value)), value, rtol=4e-16, atol=1e-300)
    np.testing.assert_allclose(deg_to_rad(rad_to_deg(value)), value, rtol=4e-16, atol=1e-300)


@given(finite)
def test_mm_m_round_trip(value: float) -> None:
    np.testing.assert_allclose(m_to_mm(mm_to_m(value)), value, rtol=4e-16, atol=1e-300)
    np.testing.assert_allclose(mm_to_m(m_to_mm(value)), value, rtol=4e-16, atol=1e-300)


def test_deg_to_rad_known_values() -> None:
    np.testing.assert_allclose(
        deg_to_rad([0.0, 90.0, -180.0, 360.0]), [0.0, math.pi / 2, -math.pi, 2 * math.pi]
    )
    np.testing.assert_allclose(rad_to_deg([math.pi, -math.pi / 4]), [180.0, -45.0])


def test_mm_to_m_known_values() -> None:
    np.testing.assert_allclose(mm_to_m([1000.0, -5.0]), [1.0, -0.005])
    np.testing.assert_allclose(m_to_mm(np.array([0.25])), [250.0])


def test_conversions_keep_the_shape() -> None:
    values = np.arange(6.0).reshape(2, 3)
    assert deg_to_rad(values).shape == (2, 3)
    assert rad_to_deg(values).shape == (2, 3)
    assert mm_to_m(values).shape == (2, 3)
    assert m_to_mm(values).shape == (2, 3)
    assert deg_to_rad(30.0).shape == ()


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
def test_deg_to_rad_rejects_non_finite_naming_the_argument(bad: float) -> None:
    with pytest.raises(ArgumentError, match=r"^joint_angles: element 1 .*finite"):
        deg_to_rad([10.0, bad, 30.0], name="joint_angles")


@pytest.mark.parametrize("bad", [math.nan, math.inf], ids=["nan", "inf"])
def test_mm_to_m_rejects_non_finite_naming_the_argument(bad: float) -> None:
    with pytest.raises(ArgumentError, match=r"^distance: element 0 .*finite"):
        mm_to_m(bad, name="distance")


def test_deg_to_rad_rejects_non_numbers_naming_the_argument() -> None:
    with pytest.raises(ArgumentError, match=r"^speed: expected numbers"):
        deg_to_rad("fast", name="speed")


# ------------------------------------------------------------------------------- offsets
@pytest.mark.parametrize(
    "rpy_deg",
    [(0.0, 0.0, 0.0), (90.0, 0.0, 0.0), (0.0, -90.0, 0.0), (180.0, 0.0, 0.0), (10.0, -35.5, 170.0)],
)
def test_offset_to_se3_matches_pinocchio_rpy(rpy_deg: tuple[float, float, float]) -> None:
    xyz = (0.01, -0.02, 0.12)
    pose = offset_to_se3(xyz, rpy_deg)
    expected = pin.rpy.rpyToMatrix(*np.radians(rpy_deg))
    np.testing.assert_allclose(pose.rotation, expected, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(pose.translation, xyz)


def test_offset_to_se3_yaw_90_turns_x_into_y() -> None:
    pose = offset_to_se3((0.0, 0.0, 0.0), (0.0, 0.0, 90.0))
    np.testing.assert_allclose(pose.rotation @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)


@pytest.mark.parametrize("value", ["1", True, None, [1.0, "2"], [[1.0], [2.0, 3.0]]])
def test_finite_array_rejects_non_numbers(value: object) -> None:
    with pytest.raises(ArgumentError, match=r"^speed: expected numbers"):
        finite_array(value, "speed")
