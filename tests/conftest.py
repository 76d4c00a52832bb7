"""Shared fixtures."""

from __future__ import annotations

import pytest

from tests.support import ROBOT_IDS


@pytest.fixture(params=ROBOT_IDS)
def robot_id(request: pytest.FixtureRequest) -> str:
    return str(request.param)
