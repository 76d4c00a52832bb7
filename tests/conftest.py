"""Shared fixtures."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.support import ROBOT_IDS


@pytest.fixture(scope="session", autouse=True)
def compiled_collision_kernels() -> None:
    """Compile numba's collision kernels once, first, into its on-disk cache: daemons the
    tests start in other processes then load them instead of each compiling them (~15 s of
    CPU on this machine) during their start-up."""
    from controller.model.collision_pairs import robot_distances
    from controller.model.kinematics import Kinematics
    from controller.model.robot import load_robot
    from controller.qp.constraints.collision import CollisionAvoidance

    kin = Kinematics(load_robot("pa10"))
    distances = robot_distances(kin)  # compiles the distance kernels
    settings = kin.robot.profile.collision_avoidance
    CollisionAvoidance(kin, distances, settings, 0.002)  # and the rows' kernel


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


@pytest.fixture(params=["compiled", "python"])
def jit_backend(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a test with the compiled kernels (controller.model.jit) and again without them
    (``IMOTION_JIT=0``: coal, NumPy and Pinocchio alone, the fallback where numba is
    missing)."""
    if request.param == "python":
        monkeypatch.setenv("IMOTION_JIT", "0")
    else:
        monkeypatch.delenv("IMOTION_JIT", raising=False)
    return str(request.param)
