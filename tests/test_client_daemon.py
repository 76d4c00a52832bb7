"""The Python client and the ``imotion`` CLI against the real daemon (not the fake): names,
units and waiting agree end to end."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from controller.client import LEFT, RIGHT, CartesianAccel, CartesianSpeed, Client, codes, pose
from tests.daemon_support import TestDaemon


@pytest.fixture(scope="module")
def daemon():
    d = TestDaemon("smartpal5")
    yield d
    d.close()


@pytest.fixture(scope="module")
def client(daemon):
    with Client.connect(daemon.address, timeout=10.0) as c:
        yield c


def test_client_moves_and_reads_back_in_spec_units(client):
    (rid,) = client.integrated.servoOn()
    assert rid.id == codes.OK
    rid, status, _ = client.integrated.getState()
    assert status == 0x012
    rid, start = client.integrated.getFeedbackPosCartesian(RIGHT, "ORIGINAL_FRAME")
    target = np.array(start.carPos, dtype=float)
    target[2, 3] += 30.0  # mm
    (rid,) = client.integrated.moveLinearCartesianAbs(
        RIGHT, target, CartesianSpeed(60, 30), CartesianAccel(300, 100), False
    )
    assert rid.id == codes.OK, rid.comment
    assert client.wait_until_idle(timeout=30)
    rid, end = client.integrated.getFeedbackPosCartesian(RIGHT, "ORIGINAL_FRAME")
    np.testing.assert_allclose(np.asarray(end.carPos)[:, 3], target[:, 3], atol=0.01)


def test_client_reach_error_and_jara_proxy(client):
    client.integrated.servoOn()
    far = pose([3000, 0, 0], [0, 0, 0])
    (rid,) = client.integrated.moveLinearCartesianAbs(
        RIGHT, far, CartesianSpeed(60, 30), CartesianAccel(300, 100), False
    )
    assert rid.id == codes.CANNOT_REACH_TARGET_ERR and rid.comment
    rid, joints = client.arm(LEFT).getFeedbackPosJoint()
    assert rid.id == codes.OK and len(joints) == 8
    (rid,) = client.arm(LEFT).movePTPJointRel([2, 0, 0, 0, 0, 0, 0])
    assert rid.id == codes.OK, rid.comment
    assert client.wait_until_idle(timeout=30)
    rid, rel = client.dual.getRelativePosition()
    assert rid.id == codes.OK and np.asarray(rel).shape == (3, 4)


def test_cli_against_the_daemon(daemon):
    env = dict(os.environ, IMOTION_ADDRESS=daemon.address)
    run = [sys.executable, "-m", "controller.cli"]
    out = subprocess.run(
        [*run, "getState", "--json"], env=env, capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0, out.stderr
    reply = json.loads(out.stdout)
    assert (reply["operation"], reply["id"], reply["name"]) == ("getState", 0, "OK")
    assert reply["outputs"]["statusId"] in (0x011, 0x012)
    bad = subprocess.run(
        [*run, "moveGripper", "--side", "RIGHT", "150"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert bad.returncode == 10 + 3, bad.stdout + bad.stderr  # VALUE_ERR
    assert "angle_ratio" in bad.stdout + bad.stderr
