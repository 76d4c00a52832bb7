"""CORBA values to spec units (controller/gateway/corba/values.py): SI conversion and the
bounds of every number, before any service sees them."""

from __future__ import annotations

import math

import pytest

from controller.bounds import ANGLE, ANGULAR_SPEED, LENGTH, MAX_REPEATED
from controller.errors import ArgumentError
from controller.gateway.corba.values import Units

EYE = [[1.0, 0.0, 0.0, 0.1], [0.0, 1.0, 0.0, 0.2], [0.0, 0.0, 1.0, 0.3]]


def test_mm_deg_passes_through_bounded() -> None:
    u = Units(si=False)
    assert u.scalar_in(12.5, LENGTH, "x") == 12.5
    assert u.hg_in(EYE, "m")[3::4] == [0.1, 0.2, 0.3]
    assert u.hg_out([[1, 0, 0, 5], [0, 1, 0, 6], [0, 0, 1, 7]])[2][3] == 7.0


def test_si_converts_in_and_out() -> None:
    u = Units(si=True)
    assert u.scalar_in(0.25, LENGTH, "x") == pytest.approx(250.0)
    assert u.scalar_in(math.pi, ANGLE, "a") == pytest.approx(180.0)
    assert u.scalar_in(math.pi, ANGULAR_SPEED, "w") == pytest.approx(180.0)
    assert u.hg_in(EYE, "m")[3::4] == pytest.approx([100.0, 200.0, 300.0])
    assert u.hg_in(EYE, "m")[0] == 1.0  # rotation entries have no unit
    assert u.length_out(250.0) == pytest.approx(0.25)
    assert u.angles_out([180.0]) == pytest.approx([math.pi])
    assert u.limit_in(type("L", (), {"lower": -0.5, "upper": 0.5})(), LENGTH, "x") == (
        pytest.approx(-500.0),
        pytest.approx(500.0),
    )


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda u: u.scalar_in(math.nan, LENGTH, "x"), "x: nan is not a finite number"),
        (lambda u: u.scalar_in(1e308, LENGTH, "x"), "x: 1e\\+308 mm is out of range"),
        (lambda u: u.seq_in([0.0] * (MAX_REPEATED + 1), ANGLE, "q"), "too many"),
        (lambda u: u.seq_in([0.0, math.inf], ANGLE, "q"), r"q\[1\]"),
        (lambda u: u.hg_in([[1.0, 0, 0, 0]] * 2, "m"), "3 x 4"),
        (lambda u: u.hg_in([[2.0, 0, 0, 0]] * 3, "m"), r"m\[0\]\[0\]"),
    ],
)
def test_bad_numbers_name_the_argument(call, match: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ArgumentError, match=match):
        call(Units(si=False))


def test_si_overflow_is_still_refused() -> None:
    with pytest.raises(ArgumentError, match="x: 1e\\+308 is out of range"):
        Units(si=True).scalar_in(1e308, LENGTH, "x")
