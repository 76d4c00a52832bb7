"""hal.can.scaling: counts <-> SI, wrap-around, vectorised form."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hal.can.scaling import I32_MAX, I32_MIN, Scaling, ScalingArray, delta_i32, wrap_i32


def test_revolute_round_trip_and_sign_offset():
    s = Scaling(131072, 100, -1, 1000, revolute=True)
    assert s.to_counts(0.0) == 1000
    assert s.to_counts(2 * math.pi) == 1000 - 131072 * 100
    assert s.to_si(1000 - 131072 * 100) == pytest.approx(2 * math.pi)
    assert s.velocity_to_si(-131072 * 100) == pytest.approx(2 * math.pi)
    assert s.window_to_counts(math.radians(1)) == round(131072 * 100 / 360)


def test_prismatic_counts_per_metre():
    s = Scaling(2_048_000, revolute=False)
    assert s.to_counts(0.03) == 61440
    assert s.to_si(61440) == pytest.approx(0.03)


@pytest.mark.parametrize(
    "bad", [{"per_unit": 0}, {"per_unit": 1, "gear": -2}, {"per_unit": 1, "sign": 2}]
)
def test_bad_parameters_are_refused(bad: dict):
    with pytest.raises(ValueError):
        Scaling(**bad)


def test_wrap_and_delta():
    assert wrap_i32(I32_MAX + 1) == I32_MIN
    assert wrap_i32(I32_MIN - 1) == I32_MAX
    assert delta_i32(I32_MIN + 5, I32_MAX - 5) == 11


@given(st.floats(-50.0, 50.0))
def test_round_trip_within_half_a_count(si: float):
    s = Scaling(131072, 80, 1, -77)
    assert abs(s.to_si(s.to_counts(si)) - si) <= 0.5 / abs(s.counts_per_si) + 1e-12


def test_array_matches_scalar():
    scalings = [Scaling(4096, 50, -1, 1000), Scaling(2_048_000, revolute=False)]
    arr = ScalingArray(scalings)
    counts = np.array([12345.0, -6789.0])
    np.testing.assert_allclose(
        arr.to_si(counts), [s.to_si(int(c)) for s, c in zip(scalings, counts, strict=True)]
    )
    si = np.array([0.5, 0.01])
    assert arr.to_counts(si).tolist() == [s.to_counts(v) for s, v in zip(scalings, si, strict=True)]
