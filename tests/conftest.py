"""Shared fixtures."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.support import ROBOT_IDS


@pytest.fixture(params=ROBOT_IDS)
def robot_id(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def corba_daemon() -> Iterator[Any]:
    """One imotiond (SmartPal V, sim, CORBA on, IOR files) per CORBA interface test module:
    a daemon left running for the rest of the session would load the 2 cores all along."""
    pytest.importorskip("omniORB")
    from tests.corba_support import CorbaDaemon

    daemon = CorbaDaemon()
    try:
        yield daemon
    finally:
        daemon.close()


@pytest.fixture(params=["compiled", "coal"])
def collision_backend(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a test with the collision distances of the compiled kernels and again with coal
    alone (``IMOTION_JIT=0``, the fallback where numba is missing)."""
    if request.param == "coal":
        monkeypatch.setenv("IMOTION_JIT", "0")
    else:
        monkeypatch.delenv("IMOTION_JIT", raising=False)
    return str(request.param)
