"""Shared fixtures."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.support import ROBOT_IDS


@pytest.fixture(params=ROBOT_IDS)
def robot_id(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="session")
def corba_daemon() -> Iterator[Any]:
    """One imotiond (SmartPal V, sim, CORBA on, IOR files) for every CORBA interface test:
    started by the first test that asks for it."""
    pytest.importorskip("omniORB")
    from tests.corba_support import CorbaDaemon

    daemon = CorbaDaemon()
    try:
        yield daemon
    finally:
        daemon.close()
