"""controller.gateway.grpc.testing: fault injection into a running `--hal hil` daemon
(issue 17.11), through gRPC, the Python client and `imotion inject`."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from controller.cli.main import main as imotion
from controller.client import Client
from controller.gateway.grpc.testing import parse_params
from controller.model.alarms import AlarmCode
from controller.rpc import imotion_pb2 as pb
from controller.rpc import imotion_pb2_grpc as pb_grpc
from controller.vocabulary import ReturnCode
from controller.vocabulary import SpecAState as S
from hal.can.backend import CanBackend
from hal.can.cia402 import State
from tests.daemon_support import TestDaemon


def test_parameters_are_read_from_text():
    assert parse_params({"code": "0x8110", "cycles": "2", "fault": "False", "bus": "body"}) == {
        "code": 0x8110,
        "cycles": 2,
        "fault": False,
        "bus": "body",
    }


@pytest.fixture(scope="module")
def hil() -> Iterator[TestDaemon]:
    d = TestDaemon("pa10", hal="hil", rate=250.0, **{"testing.fault_injection": True})
    try:
        yield d
    finally:
        d.close()


def _alarms(d: TestDaemon) -> list[Any]:
    listed = d.spec_a.GetActiveAlarm(pb.GetActiveAlarmRequest()).alarms
    return [a for a in listed if a.type != pb.WARNING]  # a starved host may warn


def _after_fault(d: TestDaemon, joint: str) -> None:
    """Recover from a drive fault once its fault reaction has ended (the drive reports
    Fault): earlier, a next alarm ("drive in state fault") may come between clearAlarms and
    servoOn on a busy host."""
    hw = d.daemon.hw
    assert isinstance(hw, CanBackend)
    assert d.wait_for(lambda: hw.drive_states()[joint] is State.FAULT, 60.0)
    _ready(d)


def _ready(d: TestDaemon) -> None:
    if d.state() == S.ALARM:
        d.spec_a.ClearAlarms(pb.ClearAlarmsRequest())
    if d.state() != S.READY:
        assert d.spec_a.ServoOn(pb.ServoOnRequest()).return_id.id == ReturnCode.OK
    assert d.wait_for(lambda: d.state() == S.READY, 60.0), _alarms(d)


def test_an_injected_drive_fault_is_an_alarm_naming_the_drive(hil: TestDaemon):
    _ready(hil)
    testing = pb_grpc.TestingStub(hil.channel)
    request = pb.TestingInjectFaultRequest(kind="emcy", target="J3", params={"code": "0x2310"})
    reply = testing.InjectFault(request, timeout=60.0)
    assert reply.return_id.id == ReturnCode.OK, reply.return_id.comment
    assert hil.wait_for(lambda: hil.state() == S.ALARM, 60.0)
    assert any(a.code == AlarmCode.EMCY and a.module_name == "J3" for a in _alarms(hil))
    _after_fault(hil, "J3")  # recoverable through the API
    assert not _alarms(hil)


def test_the_python_client_and_the_cli_inject_and_clear(hil: TestDaemon, capsys):
    _ready(hil)
    with Client.connect(hil.address) as client:
        rid = client.inject_fault("delayed_tpdo", "J2", cycles=1)
        assert rid.ok, rid
        rid, cleared = client.clear_faults()
        assert rid.ok and cleared == 1
    assert imotion(["--address", hil.address, "inject", "following_error", "J5"]) == 0
    assert "injected into J5" in capsys.readouterr().out
    assert hil.wait_for(lambda: hil.state() == S.ALARM, 60.0)
    assert any(a.module_name == "J5" for a in _alarms(hil))
    _after_fault(hil, "J5")


@pytest.mark.parametrize(
    "kind, target, params, words",
    [
        ("meltdown", "J1", {}, "meltdown"),
        ("emcy", "J99", {}, "J99"),
        ("delayed_tpdo", "J1", {"speed": "3"}, "speed"),
    ],
)
def test_bad_injections_are_value_errors_and_change_nothing(
    hil: TestDaemon, kind: str, target: str, params: dict[str, str], words: str
):
    _ready(hil)
    testing = pb_grpc.TestingStub(hil.channel)
    request = pb.TestingInjectFaultRequest(kind=kind, target=target, params=params)
    reply = testing.InjectFault(request, timeout=60.0)
    assert reply.return_id.id == ReturnCode.VALUE_ERR
    assert words in reply.return_id.comment
    assert hil.state() == S.READY and not _alarms(hil)


def test_off_unless_configured_and_only_with_the_emulator():
    d = TestDaemon("pa10", hal="ideal")
    try:
        testing = pb_grpc.TestingStub(d.channel)
        request = pb.TestingInjectFaultRequest(kind="emcy", target="J1")
        reply = testing.InjectFault(request, timeout=60.0)
        assert reply.return_id.id == ReturnCode.STATUS_ERR
        assert "testing.fault_injection" in reply.return_id.comment
    finally:
        d.close()
    d = TestDaemon("pa10", hal="ideal", **{"testing.fault_injection": True})
    try:
        reply = pb_grpc.TestingStub(d.channel).InjectFault(request, timeout=60.0)
        assert reply.return_id.id == ReturnCode.STATUS_ERR
        assert "--hal hil" in reply.return_id.comment
    finally:
        d.close()
