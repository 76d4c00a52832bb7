"""Naming-service registration (controller/gateway/corba/naming.py) against a running
imotiond: every servant the robot has is bound under its documented name, none it lacks;
after the naming service restarts (forgetting every binding) the names come back. Also the
SI units of the JARA 2014 SI edition, on the same one-arm daemon.

omniNames listens on a Unix socket in a private directory (corbaloc:omniunix:...): no TCP
port is picked, so there is no race for one.
"""

from __future__ import annotations

import random
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("omniORB")

import CosNaming

from controller.corba.stubs import JARA_ARM
from controller.corba.stubs import _GlobalIDL as A
from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode
from tests.corba_support import REPO, CorbaDaemon, UnixOmniNames

J = JARA_ARM
NAMES = {
    "imotion/IntegratedMotionInterface": A.IntegratedMotionInterface,
    "imotion/JARA_ARM.ManipulatorCommonInterface_Common": J.ManipulatorCommonInterface_Common,
    "imotion/JARA_ARM.ManipulatorCommonInterface_Middle": J.ManipulatorCommonInterface_Middle,
}
ABSENT = [  # PA10 has one arm
    "imotion/JARA_ARM_LEFT.LeftManipulatorCommonInterface_Common",
    "imotion/JARA_ARM_DUAL.DualManipulatorCommonInterface_Middle",
]


@pytest.fixture(scope="module")
def ns() -> Iterator[UnixOmniNames]:
    directory = Path(tempfile.mkdtemp(prefix="imd-ns-"))
    names = UnixOmniNames(directory)
    try:
        yield names
    finally:
        names.stop()
        shutil.rmtree(directory, ignore_errors=True)


@pytest.fixture(scope="module")
def d(ns: UnixOmniNames) -> Iterator[CorbaDaemon]:
    daemon = CorbaDaemon(
        f"corba.naming_service={ns.uri}",
        "corba.rebind_interval_s=0.2",
        "corba.units.jara_arm=si",
        robot="pa10",
    )
    try:
        yield daemon
    finally:
        daemon.close()


def _all_bound(ns: UnixOmniNames) -> bool:
    return all(ns.resolve(name) is not None for name in NAMES)


def test_every_interface_of_the_robot_is_bound_and_answers(
    d: CorbaDaemon, ns: UnixOmniNames
) -> None:
    assert d.wait_for(lambda: _all_bound(ns), 30.0), d.log
    for name, iface in NAMES.items():
        obj = ns.resolve(name)._narrow(iface)
        assert obj is not None, name
    spec_a = ns.resolve("imotion/IntegratedMotionInterface")._narrow(A.IntegratedMotionInterface)
    assert spec_a.getState()[0].id == ReturnCode.OK
    for name in ABSENT:
        assert ns.resolve(name) is None


def test_names_come_back_after_the_naming_service_restarts(
    d: CorbaDaemon, ns: UnixOmniNames
) -> None:
    assert d.wait_for(lambda: _all_bound(ns), 30.0), d.log
    ns.restart()
    assert d.wait_for(lambda: _all_bound(ns), 60.0), d.log
    spec_a = ns.resolve("imotion/IntegratedMotionInterface")._narrow(A.IntegratedMotionInterface)
    assert spec_a.isServoOn() in (True, False)


def test_si_units_on_the_jara_arm(d: CorbaDaemon) -> None:
    """corba.units.jara_arm: si: m and rad on the wire, the gRPC interface stays in mm/deg."""
    d.ready()
    middle = d.ref("jara_arm_middle", JARA_ARM.ManipulatorCommonInterface_Middle)
    common = d.ref("jara_arm_common", JARA_ARM.ManipulatorCommonInterface_Common)
    cp = middle.getFeedbackPosCartesian()[1]
    g = d.middle_grpc.GetFeedbackPosCartesian(pb.ManipulatorMiddleGetFeedbackPosCartesianRequest())
    np.testing.assert_allclose(
        np.array(cp.carPos)[:, 3], np.reshape(g.pos.car_pos.m, (3, 4))[:, 3] / 1000, atol=1e-6
    )
    q_rad = np.array(common.getFeedbackPosJoint()[1])
    q_deg = np.array(
        d.common_grpc.GetFeedbackPosJoint(pb.ManipulatorCommonGetFeedbackPosJointRequest()).pos
    )
    n = common.getManipInfo()[1].axisNum
    np.testing.assert_allclose(np.degrees(q_rad[:n]), q_deg[:n], atol=1e-3)
    speed = middle.getMaxSpeedCartesian()[1]
    gs = d.middle_grpc.GetMaxSpeedCartesian(pb.ManipulatorMiddleGetMaxSpeedCartesianRequest()).speed
    assert speed.translation == pytest.approx(gs.translation / 1000)
    assert speed.rotation == pytest.approx(np.radians(gs.rotation))
    reply: Any = middle.movePTPJointRel([0.05] + [0.0] * (n - 1))
    assert reply.id == ReturnCode.OK, reply.comment
    d.wait_idle()
    after = np.array(
        d.common_grpc.GetFeedbackPosJoint(pb.ManipulatorCommonGetFeedbackPosJointRequest()).pos
    )
    assert after[0] - q_deg[0] == pytest.approx(np.degrees(0.05), abs=0.05)
    # a bound is checked in the spec unit after conversion: 2 m is within, 1000 m is not
    far = JARA_ARM.CarPosWithElbow([[1.0, 0, 0, 1000.0], [0, 1.0, 0, 0], [0, 0, 1.0, 0]], 0.0, 0)
    reply = middle.moveLinearCartesianRel(far)
    assert reply.id == ReturnCode.VALUE_ERR and "1e+06 mm" in reply.comment, reply.comment


def test_the_documented_plain_omniorbpy_client_runs(d: CorbaDaemon, ns: UnixOmniNames) -> None:
    """tools/corba_example.py (docs/corba.md) against this daemon, through the naming service."""
    assert d.wait_for(lambda: _all_bound(ns), 30.0), d.log
    done = subprocess.run(
        [sys.executable, str(REPO / "tools" / "corba_example.py"), "--naming", ns.uri],
        capture_output=True, text=True, timeout=120, cwd=REPO, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "moveLinearCartesianRel: 0 OK" in done.stdout, done.stdout
    assert "right control point:" in done.stdout


def test_start_naming_service_serves_the_names_and_stops_with_the_daemon() -> None:
    """corba.start_naming_service: our own omniNames on 127.0.0.1. It binds a random port
    itself; a daemon whose omniNames found the port taken exits, and the test retries with
    another port (no probe-then-bind race)."""
    rng = random.Random()
    for _ in range(5):
        port = rng.randrange(20000, 60000)
        try:
            daemon = CorbaDaemon(
                "corba.start_naming_service=true", f"corba.naming_port={port}", robot="pa10"
            )
            break
        except AssertionError as exc:
            assert "omniNames" in str(exc), str(exc)
    else:
        pytest.fail("no port for omniNames in 5 tries")
    try:
        pid = int(daemon.wait_line(r"omniNames started on 127\.0\.0\.1:\d+ \(pid (\d+)\)").group(1))
        uri = f"corbaloc::127.0.0.1:{port}/NameService"
        root = daemon.orb.string_to_object(uri)._narrow(CosNaming.NamingContextExt)
        assert daemon.wait_for(lambda: _resolves(root, "imotion/IntegratedMotionInterface"), 30.0)
        obj = root.resolve_str("imotion/IntegratedMotionInterface")
        assert obj._narrow(A.IntegratedMotionInterface).getVersion()[0].id == ReturnCode.OK
    finally:
        daemon.close()
    assert daemon.wait_for(lambda: not Path(f"/proc/{pid}").exists(), 30.0), "omniNames outlived us"


def _resolves(root: Any, name: str) -> bool:
    try:
        root.resolve_str(name)
        return True
    except CosNaming.NamingContext.NotFound:
        return False
