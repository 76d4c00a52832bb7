"""controller/gateway/corba/server.py without a daemon: omniNames started and stopped by us,
and which servants a robot gets."""

from __future__ import annotations

import random
import tempfile
from pathlib import Path
from types import SimpleNamespace

import pytest

pytest.importorskip("omniORB")

import CosNaming

from controller.contract.config import load_config
from controller.gateway.corba import server
from controller.vocabulary import RightLeft
from tests.corba_support import client_orb


def test_omninames_on_loopback_answers_and_stops(tmp_path: Path) -> None:
    """A TCP port is needed here: omniNames binds it itself and exits when it cannot, so a
    taken port is retried with another (no probe-then-bind race)."""
    rng = random.Random()
    for _ in range(10):
        port = rng.randrange(20000, 60000)
        try:
            proc = server.start_omninames(port, tmp_path)
            break
        except RuntimeError as exc:
            assert "exited" in str(exc)
    else:
        pytest.fail("omniNames did not start on any of 10 ports")
    try:
        obj = client_orb().string_to_object(f"corbaloc::127.0.0.1:{port}/NameService")
        root = obj._narrow(CosNaming.NamingContextExt)
        assert root.list(10)[0] == []
        with pytest.raises(RuntimeError, match="exited"):  # the port is now ours
            server.start_omninames(port, Path(tempfile.mkdtemp()))
    finally:
        server.stop_omninames(proc)
    assert proc.poll() is not None


class _Services(SimpleNamespace):
    pass


@pytest.mark.parametrize(
    ("arms", "keys"),
    [
        ({RightLeft.RIGHT}, {"spec_a", "jara_arm_common", "jara_arm_middle"}),
        ({RightLeft.RIGHT, RightLeft.LEFT},
         {"spec_a", "jara_arm_common", "jara_arm_middle", "jara_arm_left_common",
          "jara_arm_left_middle", "jara_dual_common", "jara_dual_middle"}),
    ],
)  # fmt: skip
def test_every_interface_the_robot_has_and_no_other(arms: set, keys: set) -> None:
    ctx = SimpleNamespace(view=None, robot=None, config=None, call=None)
    services = _Services(
        ctx=ctx,
        spec_a=SimpleNamespace(ctx=ctx),
        arms=SimpleNamespace(arms=dict.fromkeys(arms)),
        settings=None,
        dual=None,
    )
    made = server.make_servants(services, load_config(None))  # type: ignore[arg-type]
    assert set(made) == keys
    assert made["jara_arm_middle"][1] == "JARA_ARM::ManipulatorCommonInterface_Middle"
    if "jara_arm_left_middle" in made:
        assert made["jara_arm_left_middle"][1] == (
            "JARA_ARM_LEFT::LeftManipulatorCommonInterface_Middle"
        )


def test_a_leftover_omninames_of_a_killed_gateway_is_stopped(tmp_path: Path) -> None:
    """The gateway was killed outright: its omniNames still holds the port. The next start
    in the same runtime directory stops it first (pid file), then takes the port again."""
    rng = random.Random()
    for _ in range(10):
        port = rng.randrange(20000, 60000)
        try:
            first = server.start_omninames(port, tmp_path)
            break
        except RuntimeError:
            continue
    else:
        pytest.fail("omniNames did not start on any of 10 ports")
    second = server.start_omninames(port, tmp_path)  # same port: only free once first stops
    try:
        assert first.wait(10.0) is not None
        assert second.poll() is None
    finally:
        server.stop_omninames(second)
