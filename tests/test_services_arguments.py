"""controller.gateway.services.arguments: the argument checks every transport shares."""

from __future__ import annotations

import pytest

from controller.errors import ArgumentError
from controller.gateway.services.arguments import finite_arg, finite_values, positive_arg


def test_finite_and_positive():
    assert finite_arg(1, "x") == 1.0
    with pytest.raises(ArgumentError, match="x: nan is not a finite number"):
        finite_arg(float("nan"), "x")
    with pytest.raises(ArgumentError, match="v: must be > 0 mm/s, got -1"):
        positive_arg(-1.0, "v", "mm/s")
    with pytest.raises(ArgumentError, match=r"p\[1\]: inf"):
        finite_values([0.0, float("inf")], "p")
