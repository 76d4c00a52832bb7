"""controller.bounds: one bound per quantity at the API edge."""

from __future__ import annotations

import math

import pytest

from controller.bounds import (
    ANGLE,
    LENGTH,
    MAX_MOTION_TIME,
    bounded,
    motion_time,
    require_duration,
    show,
)
from controller.errors import ArgumentError


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_numbers_are_refused(bad: float) -> None:
    with pytest.raises(ArgumentError, match=r"x: .* is not a finite number"):
        bounded(bad, LENGTH, "x")


def test_the_bound_itself_is_accepted_and_beyond_it_is_refused_briefly() -> None:
    assert bounded(-LENGTH.limit, LENGTH, "x") == -LENGTH.limit
    with pytest.raises(ArgumentError) as err:
        bounded(1e300, ANGLE, "elbow")
    assert err.value.comment.startswith("elbow: 1e+300 deg is out of range")
    assert len(err.value.comment) < 120


def test_show_keeps_huge_numbers_short() -> None:
    assert show(1e300) == "1e+300"
    assert show(-10.000000000000002) == "-10"


def test_motion_time_of_trapezoid_and_triangle() -> None:
    assert motion_time(0.0, 1.0, 1.0) == 0.0
    assert motion_time(10.0, 1.0, 1.0) == pytest.approx(11.0)  # cruise
    assert motion_time(-0.25, 1.0, 1.0) == pytest.approx(1.0)  # triangle, sign ignored


def test_motions_longer_than_the_longest_are_refused_in_the_callers_units() -> None:
    require_duration(10.0, 10.0, 100.0, "speed.elbow", "deg")
    with pytest.raises(ArgumentError) as err:
        require_duration(5.0, 1e-9, 100.0, "speed.elbow", "deg")
    comment = err.value.comment
    assert comment.startswith("speed.elbow: 5 deg at 1e-09 deg/s")
    assert f"({MAX_MOTION_TIME:g} s)" in comment
