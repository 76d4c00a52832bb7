"""The ``imotion`` CLI against an in-process fake daemon (tests/client_fake.py).

Every operation is run from a command line built from its request fields, and the request
the fake receives is compared, value by value, with the words given.
"""

from __future__ import annotations

import io
import itertools
import json
import os
import re
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from google.protobuf.descriptor import FieldDescriptor
from rich.console import Console
from rich.text import Text

from controller.cli import arguments, wait, watch
from controller.cli.main import main, operation_parser
from controller.client import Client, codes, pose, rpy_of
from controller.client.convert import from_message
from controller.rpc import imotion_pb2
from tests import client_fake

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def daemon() -> Iterator[tuple[client_fake.FakeDaemon, str]]:
    server, fake, address = client_fake.start()
    yield fake, address
    server.stop(None)


@pytest.fixture
def fake(
    daemon: tuple[client_fake.FakeDaemon, str], monkeypatch: pytest.MonkeyPatch
) -> client_fake.FakeDaemon:
    daemon[0].reset()
    monkeypatch.setenv("IMOTION_ADDRESS", daemon[1])
    monkeypatch.delenv("IMOTION_TOKEN", raising=False)
    monkeypatch.delenv("IMOTION_TLS_CA", raising=False)
    return daemon[0]


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, dict[str, Any]]:
    code, out, _ = run(capsys, *argv, "--json")
    return code, json.loads(out)


# ---------------------------------------------------------------- every operation

_numbers = itertools.count(3)


def words(f: FieldDescriptor) -> list[str]:
    """Command-line words for a field (lists end with the separator)."""
    if f.is_repeated and f.type == FieldDescriptor.TYPE_DOUBLE:
        return ["1.25", "-2.5", "30", ","]
    if f.is_repeated:
        return [*single_words(f), *single_words(f), ","]
    return single_words(f)


def single_words(f: FieldDescriptor) -> list[str]:
    if f.type == FieldDescriptor.TYPE_MESSAGE:
        d = f.message_type
        if d.name == "HgMatrix":
            return [str(next(_numbers)), "-5", "7.5", "10", "20", "30"]
        return [w for sub in d.fields for w in single_words(sub)]
    if f.type == FieldDescriptor.TYPE_ENUM:
        return [f.enum_type.values_by_number[1].name.lower()]
    if f.type == FieldDescriptor.TYPE_BOOL:
        return ["true"]
    return [str(next(_numbers))]


def leaves(f: FieldDescriptor, value: Any) -> list[Any]:
    """The received request field as the flat list of values the words stand for."""
    if f.is_repeated:
        return [x for item in value for x in single_leaves(f, item)]
    return single_leaves(f, value)


def single_leaves(f: FieldDescriptor, value: Any) -> list[Any]:
    if f.type == FieldDescriptor.TYPE_MESSAGE:
        if f.message_type.name == "HgMatrix":
            hg = np.array(value.m).reshape(3, 4)
            return [*hg[:, 3], *rpy_of(hg)]
        return [x for sub in f.message_type.fields for x in leaves(sub, getattr(value, sub.name))]
    if f.type == FieldDescriptor.TYPE_ENUM:
        return [f.enum_type.values_by_number[value].name.lower()]
    return [value if isinstance(value, bool) else float(value)]


def word_values(tokens: list[str]) -> list[Any]:
    out: list[Any] = []
    for t in tokens:
        if t == ",":
            continue
        try:
            out.append(float(t))
        except ValueError:
            out.append(True if t == "true" else t)
    return out


def all_commands() -> list[tuple[list[str], str]]:
    out = []
    for group, prefixes in (("integrated", [[]]), ("arm", [["arm", "RIGHT"], ["arm", "left"]]),
                            ("dual", [["dual"]])):  # fmt: skip
        for op in arguments.operations(group).values():
            for prefix in prefixes:
                out.append(([*prefix, op.name], group))
    return out


@pytest.mark.parametrize(("command", "group"), all_commands(), ids=lambda c: " ".join(c))
def test_every_operation_runs(
    capsys: pytest.CaptureFixture[str],
    fake: client_fake.FakeDaemon,
    command: list[str],
    group: str,
) -> None:
    op = arguments.find(group, command[-1])
    assert op is not None
    tokens = [w for f in op.fields for w in words(f)]
    code, data = run_json(capsys, *command, *tokens)
    assert code == 0
    assert data["operation"] == op.name and data["service"] == op.service
    assert (data["id"], data["name"], data["comment"]) == (0, "OK", f"{op.method.name} done")
    outputs = [f.json_name for f in op.method.output_type.fields if f.name != "return_id"]
    assert list(data["outputs"]) == outputs

    call = fake.last()
    assert (call.service, call.rpc) == (op.service, op.method.name)
    received = [x for f in op.fields for x in leaves(f, getattr(call.request, f.name))]
    assert received == pytest.approx(word_values(tokens))
    if group == "arm":
        assert call.request.arm == (imotion_pb2.LEFT if command[1] == "left" else imotion_pb2.RIGHT)


def test_every_operation_has_a_command() -> None:
    count = sum(len(arguments.operations(g)) for g in arguments.GROUPS)
    assert count == 97


# ---------------------------------------------------------------- syntax


def test_examples_from_the_docs(capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon):
    code, _, _ = run(capsys, "moveLinearCartesianRel", "--side", "RIGHT", "--frame", "BASE",
                     "--xyz", "0", "0", "50", "--rpy", "0", "0", "0", "--speed", "50", "30",
                     "--accel", "200", "100")  # fmt: skip
    assert code == 0
    assert fake.last().request == imotion_pb2.MoveLinearCartesianRelRequest(
        type=imotion_pb2.RIGHT,
        frame_type=imotion_pb2.BASE_FRAME,
        rel_hg_mat=imotion_pb2.HgMatrix(m=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 50]),
        speed=imotion_pb2.CartesianSpeed(translation=50, rotation=30),
        accel=imotion_pb2.CartesianAccel(translation=200, rotation=100),
        is_hold_other_arm=False,
    )
    assert (
        run(capsys, "arm", "LEFT", "movePTPJointAbs", "0", "10", "0", "45", "0", "0", "0")[0] == 0
    )
    assert fake.last().request == imotion_pb2.ManipulatorMiddleMovePTPJointAbsRequest(
        arm=imotion_pb2.LEFT, joint_points=[0, 10, 0, 45, 0, 0, 0]
    )
    assert run(capsys, "dual", "moveGripper", "50", "50")[0] == 0
    assert fake.last().request == imotion_pb2.DualManipulatorMiddleMoveGripperRequest(
        r_arm=50, l_arm=50
    )


def test_pose_forms(capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon) -> None:
    hg = pose([400, -200, 800], [180, 0, 90])
    matrix = [f"{x:.17g}" for x in hg.ravel()]
    forms = [
        ["RIGHT", "400", "-200", "800", "180", "0", "90", "0.5", "true"],
        ["RIGHT", "--matrix", *matrix, "--time", "0.5", "--isHoldOtherArm", "yes"],
        ["--absHgMat", "400", "-200", "800", "180", "0", "90", "RIGHT", "0.5", "1"],
        ["--rpy", "180", "0", "90", "--xyz", "400", "-200", "800", "--side", "r", "0.5", "on"],
    ]
    for form in forms:
        assert run(capsys, "movePTPCartesianAbs", *form)[0] == 0, form
        r = fake.last().request
        np.testing.assert_allclose(np.array(r.abs_hg_mat.m).reshape(3, 4), hg, atol=1e-9)
        assert (r.time, r.is_hold_other_arm, r.type) == (0.5, True, imotion_pb2.RIGHT)

    run(capsys, "arm", "RIGHT", "moveLinearCartesianAbs", "--xyz", "1", "2", "3", "--elbow", "45")
    car = fake.last().request.car_point
    assert (list(car.car_pos.m[3::4]), car.elbow, car.struct_flag) == ([1, 2, 3], 45, 0)
    run(capsys, "dual", "movePTPCartesianRel", "--rArm-xyz", "0", "0", "10",
        "--lArm-rpy", "0", "0", "5", "--lArm-structFlag", "3")  # fmt: skip
    r = fake.last().request
    assert list(r.r_arm.car_pos.m[3::4]) == [0, 0, 10] and r.l_arm.struct_flag == 3
    assert rpy_of(np.array(r.l_arm.car_pos.m).reshape(3, 4)) == pytest.approx((0, 0, 5))


def test_lists_structs_and_separators(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon
) -> None:
    run(capsys, "dual", "movePTPJointRel", "1", "2", ",", "-3", "-4.5")
    assert fake.last().request == imotion_pb2.DualManipulatorMiddleMovePTPJointRelRequest(
        r_arm=[1, 2], l_arm=[-3, -4.5]
    )
    run(capsys, "moveUnitAbs", "--unit", "lumb", "--absPos", "10", "20", "--speed", "5", "5",
        "--accel", "50", "50")  # fmt: skip
    assert fake.last().request == imotion_pb2.MoveUnitAbsRequest(
        unit=imotion_pb2.LUMBER, abs_pos=[10, 20], speed=[5, 5], accel=[50, 50]
    )
    run(
        capsys, "moveUnitRel", "VEHICLE", "100", "0", "0", ",", "50", "50", "10", ",", "1", "2", "3"
    )
    assert list(fake.last().request.accel) == [1, 2, 3]
    run(capsys, "arm", "RIGHT", "setSoftLimitJoint", "90", "-90", "45", "-45")
    assert [(v.upper, v.lower) for v in fake.last().request.soft_limit] == [(90, -90), (45, -45)]
    mask = ["1", "0", "1", "0", "0", "yes", "no"]
    limits = [str(v) for v in range(16)]
    run(capsys, "selectRedundantAxes", *mask, *limits)
    r = fake.last().request
    assert (r.redundancy.elbow, r.redundancy.lumbar_rx, r.redundancy.vehicle_y) == (
        True,
        False,
        True,
    )
    assert (r.limit.right_elbow.upper, r.limit.vehicle_theta.lower) == (0, 15)
    run(capsys, "moveCPHoldRel", "left", *["1"] * 7, *["2"] * 6, *["3"] * 6)
    r = fake.last().request
    assert (r.type, r.rel_pos.vehicle_theta, r.speed.vehicle_rotation, r.accel.elbow) == (
        1,
        1,
        2,
        3,
    )


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["moveGriper"], "unknown operation 'moveGriper'; did you mean moveGripper?"),
        (["moveGripper", "RIGHT"], "missing angleRatio: ANGLERATIO"),
        (["moveGripper", "RIGHT", "half"], "angleRatio: 'half' is not a whole number"),
        (["moveGripper", "UP", "5"], "type: 'UP' is not a RightLeft (RIGHT, LEFT)"),
        (["moveGripper", "RIGHT", "5", "6"], "unexpected extra values: 6"),
        (["movePTPCartesianAbs", "RIGHT", "1", "2", "3"], "missing absHgMat"),
        (["movePTPCartesianAbs", "RIGHT", "--absHgMat", *"123456", "--xyz", "1", "2", "3", "1"],
         "give --absHgMat or its parts, not both"),
        (["movePTPCartesianAbs", "R", "--matrix", *"123456789012", "--rpy", "1", "2", "3", "1"],
         "give a matrix or xyz/rpy, not both"),
        (["movePTPCartesianAbs", "R", "--time", "1", "--xyz", "1", "2"], "expected 3 arguments"),
        (["arm"], "missing RIGHT|LEFT"),
        (["arm", "MIDDLE", "servoON"], "'MIDDLE' is not a RightLeft"),
        (["arm", "RIGHT"], "missing OPERATION"),
        (["dual", "servoOn"], "imotion dual: unknown operation 'servoOn'"),
        (["arm", "LEFT", "setSoftLimitJoint", "1", "2", "3"], "expected groups of 2"),
        (["getState", "--bogus"], "unrecognized arguments: --bogus"),
        (["getState", "--jsn"], "did you mean --json?"),
        (["--adress", "x", "getState"], "did you mean --address?"),
        (["moveCPHoldRel", "RIGHT", "--elbo", "3"], "did you mean --elbow?"),
        (["servoOnn"], "unknown operation 'servoOnn'; did you mean servoOn?"),
        (["wach"], "did you mean watch?"),
        (["arm", "LEFT", "servoOnn"], "did you mean servoON?"),
        (["moveCPHoldRel", "R", "--elbow", "1", "--relPos", *"1234567"],
         "relPos: give --relPos or its parts, not both"),
        (["moveCPHoldRel", "R", "--elbow", "x"], "relPos.elbow: 'x' is not a number"),
        (["moveCPHoldAbs", "R", "--elbow", "30", "--elbow-speed", "1"],
         "absPos is an absolute target: give every part, missing --lumbarRx-absPos"),
        (["watch", "--rate", "-1"], "--rate must be a finite number >= 0"),
        ([], "usage: imotion"),
    ],
)  # fmt: skip
def test_usage_errors_exit_2_with_one_line(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon, argv: list[str], message: str
) -> None:
    code, out, err = run(capsys, *argv)
    assert code == 2
    text = err if argv else out
    assert message in text
    if argv:
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not fake.calls  # nothing sent for a bad command line


def test_struct_parts_by_name(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon
) -> None:
    """moveCPHoldRel --elbow -30 --elbow-speed 20 instead of 20 positional numbers; the parts
    left out are 0; a struct not named at all still comes positionally."""
    code, _, err = run(
        capsys, "moveCPHoldRel", "--side", "RIGHT", "--elbow", "-30", "--elbow-speed", "20",
        "--elbow-accel", "40", "--vehicleX", "5",
    )  # fmt: skip
    assert code == 0, err
    r = fake.last().request
    assert r.rel_pos == imotion_pb2.RedundantPos(elbow=-30, vehicle_x=5)
    assert r.speed == imotion_pb2.RedundantSpeed(elbow=20)
    assert r.accel == imotion_pb2.RedundantAccel(elbow=40)
    code, _, err = run(capsys, "moveCPHoldRel", "RIGHT", *"0000000", "--vehicleTranslation-speed",
                       "50", *"123456")  # fmt: skip
    assert code == 0, err
    r = fake.last().request
    assert r.speed == imotion_pb2.RedundantSpeed(vehicle_translation=50)
    assert list(r.accel.ListFields()[i][1] for i in range(6)) == [1, 2, 3, 4, 5, 6]
    code, _, err = run(
        capsys, "moveLinearCartesianAbs", "RIGHT", "--xyz", "400", "0", "800",
        "--translation", "50", "--rotation-speed", "30", "--translation-accel", "200",
        "--rotation-accel", "100",
    )  # fmt: skip
    assert code == 0, err
    r = fake.last().request
    assert (r.speed.translation, r.speed.rotation) == (50, 30)
    assert (r.accel.translation, r.accel.rotation) == (200, 100)


def test_nested_struct_parts_by_name(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon
) -> None:
    code, _, err = run(
        capsys, "selectRedundantAxes", "--elbow", "true", "--vehicleX-redundancy", "yes",
        "--rightElbow-upper-limit", "90", "--rightElbow-lower", "-90",
    )  # fmt: skip
    assert code == 0, err
    r = fake.last().request
    assert r.redundancy == imotion_pb2.RedundantAxesMask(elbow=True, vehicle_x=True)
    assert (r.limit.right_elbow.upper, r.limit.right_elbow.lower) == (90, -90)
    assert r.limit.vehicle_x.upper == 0


_UNIT = re.compile(r"(mm|deg|\bs\b|%|ms)")


def _field_helps(op: arguments.CliOperation) -> dict[str, str]:
    parser = operation_parser(op, f"imotion {op.name}")
    return {a.dest: a.help or "" for a in parser._actions if a.dest.startswith(("f_", "l_"))}


@pytest.mark.parametrize("group", list(arguments.GROUPS))
def test_help_gives_units_for_every_number_and_no_developer_text(group: str) -> None:
    for op in arguments.operations(group).values():
        text = operation_parser(op, f"imotion {op.name}").format_help()
        assert "``" not in text and ":mod:" not in text and ":func:" not in text, op.name
        assert "how to give the arguments" in text
        helps = _field_helps(op)
        for f in op.fields:
            numbers = f.type in (FieldDescriptor.TYPE_DOUBLE, FieldDescriptor.TYPE_FLOAT) or (
                f.type == FieldDescriptor.TYPE_MESSAGE
                and f.message_type.name not in ("RedundantAxesMask",)
            )
            if numbers:
                assert _UNIT.search(helps[f"f_{f.name}"]), (op.name, f.name, helps[f"f_{f.name}"])
            for leaf in arguments.leaves(f):
                if leaf.path[-1].type == FieldDescriptor.TYPE_DOUBLE:
                    assert _UNIT.search(helps[leaf.dest]), (op.name, leaf.dest, helps[leaf.dest])


def test_operation_help_example(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["moveCPHoldRel", "--help"])
    out = capsys.readouterr().out
    assert "--elbow DEG, --elbow-relPos DEG" in out
    assert "--elbow-speed DEG/S" in out and "--vehicleTranslation-accel MM/S^2" in out


def test_operation_names_are_case_tolerant(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon
) -> None:
    assert run(capsys, "arm", "left", "servoon")[0] == 0
    assert fake.last().rpc == "ServoON" and fake.last().request.arm == imotion_pb2.LEFT


# ---------------------------------------------------------------- output, exit codes


def test_json_and_text_output(capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon):
    fake.handlers[("IntegratedMotion", "GetState")] = lambda _: imotion_pb2.GetStateResponse(
        return_id=imotion_pb2.ReturnID(id=0, comment="fine"), status_id=0x012, message="Ready"
    )
    code, data = run_json(capsys, "getState")
    assert code == 0 and data == {
        "operation": "getState", "id": 0, "name": "OK", "comment": "fine",
        "outputs": {"statusId": 0x012, "message": "Ready"}, "service": "IntegratedMotion",
    }  # fmt: skip
    code, data = run_json(capsys, "arm", "LEFT", "getFeedbackPosCartesian")
    assert data["arm"] == "LEFT"
    assert data["outputs"]["pos"]["carPos"] == np.reshape(client_fake.CANNED_HG, (3, 4)).tolist()
    code, data = run_json(capsys, "getActiveAlarm")
    assert data["outputs"]["alarms"] == [
        {"code": 7, "type": "WARNING", "description": "description text",
         "moduleName": "module_name text"}
    ]  # fmt: skip

    code, out, _ = run(capsys, "getState")
    assert out.splitlines() == ["OK (0): fine", "statusId: 0x012 (Ready)", "message: Ready"]
    code, out, _ = run(capsys, "getFeedbackPosCartesian", "RIGHT", "ORIGINAL_FRAME")
    assert "pos: xyz 10 20 30 mm, rpy 0 0 90 deg, elbow 1.5 deg, structFlag 7" in out
    code, out, _ = run(capsys, "arm", "RIGHT", "getState")
    assert "state: 0x07 (servo on, moving, alarm)" in out


@pytest.mark.parametrize(
    ("return_id", "exit_status"),
    [(codes.NG, 11), (codes.STATUS_ERR, 12), (codes.VALUE_ERR, 13), (codes.NOT_SV_ON_ERR, 14),
     (codes.FULL_MOTION_QUEUE_ERR, 15), (codes.CANNOT_REACH_TARGET_ERR, 16), (-42, 1)],
)  # fmt: skip
def test_exit_status_follows_the_return_id(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon, return_id: int,
    exit_status: int
) -> None:  # fmt: skip
    fake.handlers[("IntegratedMotion", "MoveGripper")] = lambda _: imotion_pb2.MoveGripperResponse(
        return_id=imotion_pb2.ReturnID(id=return_id, comment="why")
    )
    code, data = run_json(capsys, "moveGripper", "RIGHT", "150")
    assert code == exit_status
    assert (data["id"], data["comment"]) == (return_id, "why")


def test_grpc_error_exits_1(capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon):
    def boom(_: Any) -> Any:
        raise RuntimeError("boom")

    fake.handlers[("IntegratedMotion", "Stop")] = boom
    code, out, err = run(capsys, "stop", "--json")
    assert code == 1 and "IntegratedMotion.stop failed" in err and len(err.splitlines()) == 1
    assert json.loads(out)["exitCode"] == 1


# ---------------------------------------------------------------- connection


def test_token_and_address_options(
    capsys: pytest.CaptureFixture[str],
    fake: client_fake.FakeDaemon,
    daemon: tuple[client_fake.FakeDaemon, str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("IMOTION_ADDRESS", "127.0.0.1:1")  # overridden by --address
    assert run(capsys, "--address", daemon[1], "--token", "tok1", "servoOn")[0] == 0
    assert fake.last("ServoOn").metadata["authorization"] == "Bearer tok1"
    monkeypatch.setenv("IMOTION_ADDRESS", daemon[1])
    monkeypatch.setenv("IMOTION_TOKEN", "tok2")
    assert run(capsys, "dual", "servoONArm")[0] == 0
    assert fake.last("ServoONArm").metadata["authorization"] == "Bearer tok2"
    assert run(capsys, "dual", "servoOFFArm", "--token", "tok3")[0] == 0  # after the operation
    assert fake.last("ServoOFFArm").metadata["authorization"] == "Bearer tok3"


@pytest.fixture
def refused_address() -> Iterator[str]:
    """A 127.0.0.1 address where nothing listens: the port stays bound (never listening)
    for the whole test, so no other process can take it meanwhile."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        yield f"127.0.0.1:{s.getsockname()[1]}"


def test_daemon_not_running(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, refused_address: str
) -> None:
    address = refused_address
    code, out, err = run(capsys, "--address", address, "getState")
    assert code == 2 and not out
    assert err.startswith(f"imotion: imotion daemon at {address} unreachable")
    assert "Connection refused" in err and len(err.splitlines()) == 1
    code, _, err = run(capsys, "--address", f"unix:{tmp_path}/none.sock", "watch", "--once")
    assert code == 2 and "unreachable" in err
    code, _, err = run(capsys, "--tls-ca", str(tmp_path / "ca.pem"), "getState")
    assert code == 2 and "cannot read the TLS root certificate" in err


def test_console_script_module_prints_one_line(refused_address: str) -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO), "IMOTION_ADDRESS": refused_address}
    proc = subprocess.run(
        [sys.executable, "-m", "controller.cli", "getVersion"],
        capture_output=True, text=True, env=env, timeout=60, check=False,
    )  # fmt: skip
    assert proc.returncode == 2
    assert "unreachable" in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


# ---------------------------------------------------------------- watch


def _watch_sample(**kw: Any) -> imotion_pb2.StateSample:
    fields: dict[str, Any] = dict(
        sequence=3, stamp_s=12.5, status_id=0x013, status_message="moving",
        joints=[imotion_pb2.UnitJointPositions(
                    unit=imotion_pb2.RIGHT_ARM, position=[1, 2, 119.5], commanded=[1.5, 2, 119.5],
                    names=["r_j1", "r_j2", "r_j3"],
                    limits=[imotion_pb2.LimitValue(upper=u, lower=-u) for u in (90, 90, 120)]),
                imotion_pb2.UnitJointPositions(unit=imotion_pb2.VEHICLE, position=[100, 5, 90])],
        control_points=[imotion_pb2.ControlPointPose(
            arm=imotion_pb2.RIGHT, pose=imotion_pb2.CarPosWithElbow(
                car_pos=imotion_pb2.HgMatrix(m=client_fake.CANNED_HG), elbow=30))],
        alarms=[imotion_pb2.Alarm(code=0x411, type=imotion_pb2.WARNING, description="overrun [x]",
                                  module_name="loop")],
        loop=imotion_pb2.LoopStats(cycles=1000, overruns=2,
                                   compute=imotion_pb2.LatencyStats(p50_us=80, p99_us=150,
                                                                    max_us=300)),
        wall_time_s=1_800_000_000.25,
        motion=imotion_pb2.MotionStatus(active=True, queued=2, queue_depth=8, started=5,
                                        finished=4),
    )  # fmt: skip
    fields.update(kw)
    return imotion_pb2.StateSample(**fields)


def test_watch_once_renders(
    capsys: pytest.CaptureFixture[str],
    fake: client_fake.FakeDaemon,
    monkeypatch: pytest.MonkeyPatch,
):
    monkeypatch.setenv("COLUMNS", "200")  # a wide terminal: no cell folded
    fake.samples.append(_watch_sample())
    code, out, err = run(capsys, "watch", "--once", "--rate", "5")
    assert code == 0, err
    assert fake.last("StreamState").request.rate_hz == 5.0
    clock = time.strftime("%H:%M:%S", time.localtime(1_800_000_000)) + ".250"
    expected = ["0x013 Busy", clock, "motion #5 running", "queue 2/8", "finished 4",
                "RIGHT_ARM", "r_j1 [deg]", "1.5", "0.5", "-90 .. 90", "r_j3 [deg]",
                "VEHICLE", "x [mm]", "theta [deg]", "0x0411", "overrun [x]", "active",
                "1000 cycles, 2 overruns", "p99 150", "30.0", "90.0"]  # fmt: skip
    for text in expected:
        assert text in out, text


def test_watch_marks_joints_near_their_limits() -> None:
    sample = from_message(_watch_sample())
    rows = watch.joint_rows(sample.joints[0])
    assert [Text.from_markup(cells[0]).plain for cells, _ in rows] == [
        "r_j1 [deg]",
        "r_j2 [deg]",
        "r_j3 [deg]",
    ]
    assert [cells[5] for cells, _ in rows] == ["89", "88", "0.5"]  # distance to the limit
    assert [style for _, style in rows] == ["", "", "bold red"]  # 0.5 of 240: within 2 %
    near = from_message(_watch_sample()).joints[0]._replace(position=[75.0, 0, 0])
    assert watch.joint_rows(near)[0][1] == "yellow"  # 15 of 180: within 10 %
    old = watch.joint_rows(sample.joints[1])  # no names, commands or limits (older daemon)
    assert [Text.from_markup(c[0]).plain for c, _ in old] == ["x [mm]", "y [mm]", "theta [deg]"]
    assert old[0][0][2:] == ["-", "-", "-", "-"]


def test_watch_keeps_alarm_history_and_highlights_overruns() -> None:
    history = watch.WatchHistory()
    first = from_message(_watch_sample())
    history.update(first, now=100.0)
    assert not history.overrunning(100.0)  # the first count is the baseline
    cleared = first._replace(alarms=[], wallTimeS=1_800_000_010.0,
                             loop=first.loop._replace(overruns=5))  # fmt: skip
    history.update(cleared, now=101.0)
    assert history.overrunning(101.0) and history.new_overruns == 3
    assert not history.overrunning(101.0 + watch.OVERRUN_HOLD_S)
    (seen,) = history.alarms
    assert (seen.code, seen.raised, seen.cleared) == (0x411, 1_800_000_000.25, 1_800_000_010.0)
    again = first._replace(wallTimeS=1_800_000_020.0)
    history.update(again, now=102.0)
    assert [a.cleared for a in history.alarms] == [1_800_000_010.0, None]
    console = Console(width=160, record=True, force_terminal=False)
    console.print(watch.render(again, "addr", history=history, now=102.0))
    text = console.export_text()
    assert "(+3)" in text and text.count("0x0411") == 2 and "active" in text


def test_watch_ends_cleanly(capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon):
    sample = client_fake.canned(imotion_pb2.StateSample.DESCRIPTOR)
    fake.samples.extend([sample] * 3)
    assert run(capsys, "watch")[0] == 0  # the live view ends when the stream does


# ---------------------------------------------------------------- --wait


class Motion:
    """A fake motion: Busy for ``steps`` state polls, feedback moving linearly to the goal."""

    def __init__(self, fake: client_fake.FakeDaemon, steps: int, end_state: int = codes.READY):
        self.steps, self.polls, self.end_state = steps, 0, end_state
        start, goal = pose([0, 0, 0]), pose([100, 0, 0])
        self.start, self.goal = start, goal

        def state(_: Any) -> Any:
            self.polls += 1
            busy = self.polls <= self.steps
            return imotion_pb2.GetStateResponse(status_id=codes.BUSY if busy else self.end_state)

        def feedback(_: Any) -> Any:
            f = min(1.0, self.polls / max(1, self.steps))
            hg = self.start + f * (self.goal - self.start)
            return imotion_pb2.GetFeedbackPosCartesianResponse(
                pos=imotion_pb2.CarPosWithElbow(car_pos=imotion_pb2.HgMatrix(m=hg.ravel()))
            )

        fake.handlers[("IntegratedMotion", "GetState")] = state
        fake.handlers[("IntegratedMotion", "GetFeedbackPosCartesian")] = feedback


@pytest.fixture
def fast_poll(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(wait, "POLL", 0.001)


MOVE = ["moveLinearCartesianAbs", "RIGHT", "100", "0", "0", "0", "0", "0", "50", "30", "200",
        "100"]  # fmt: skip


def test_wait_until_done(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon, fast_poll: None
) -> None:
    motion = Motion(fake, steps=5)
    code, data = run_json(capsys, *MOVE, "--wait")
    assert code == 0
    assert data["wait"]["finished"] is True and data["wait"]["alarm"] is False
    assert motion.polls == 6
    code, out, _ = run(capsys, *MOVE, "--wait")
    assert "wait: done in" in out


def test_wait_alarm_and_timeout(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon, fast_poll: None
) -> None:
    Motion(fake, steps=2, end_state=codes.ALARM)
    code, data = run_json(capsys, *MOVE, "--wait")
    assert code == 4 and data["wait"]["alarm"] is True
    assert data["wait"]["alarms"][0]["code"] == 7
    code, out, _ = run(capsys, *MOVE, "--wait")
    assert "wait: the motion ended in alarm" in out and "0x0007 WARNING" in out

    Motion(fake, steps=10**9)
    code, data = run_json(capsys, *MOVE, "--wait", "--wait-timeout", "0.01")
    assert code == 3 and data["wait"]["finished"] is False


def test_wait_not_sent_when_refused(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon
) -> None:
    fake.handlers[("IntegratedMotion", "MoveLinearCartesianAbs")] = lambda _: (
        imotion_pb2.MoveLinearCartesianAbsResponse(
            return_id=imotion_pb2.ReturnID(id=codes.NOT_SV_ON_ERR, comment="servo off")
        )
    )
    code, data = run_json(capsys, *MOVE, "--wait")
    assert code == 14 and "wait" not in data
    assert not [c for c in fake.calls if c.rpc == "GetState"]


def test_wait_jara_arm_and_dual(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon, fast_poll: None
) -> None:
    polls: list[int] = []

    def state(_: Any) -> Any:
        polls.append(1)
        bits = codes.JARA_SERVO_ON | (codes.JARA_MOVING if len(polls) < 4 else 0)
        return imotion_pb2.ManipulatorCommonGetStateResponse(state=bits)

    fake.handlers[("ManipulatorCommon", "GetState")] = state
    code, data = run_json(capsys, "arm", "LEFT", "movePTPJointRel", "10", "10", "--wait")
    assert code == 0 and data["wait"]["finished"] and len(polls) == 4
    polls.clear()
    code, data = run_json(capsys, "dual", "movePTPJointAbs", "1", ",", "2", "--wait")
    assert code == 0 and data["wait"]["finished"]
    assert {c.request.arm for c in fake.calls if c.rpc == "GetState"} == {0, 1}


def test_ctrl_c_while_waiting_stops_the_motion(
    capsys: pytest.CaptureFixture[str], fake: client_fake.FakeDaemon,
    monkeypatch: pytest.MonkeyPatch
) -> None:  # fmt: skip
    Motion(fake, steps=10**9)

    def interrupt(_: float) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(wait.time, "sleep", interrupt)
    code, _, err = run(capsys, *MOVE, "--wait")
    assert code == 130 and "interrupted" in err
    assert fake.last().rpc == "Stop"


def test_progress_estimates(fake: client_fake.FakeDaemon, daemon: Any, fast_poll: None) -> None:
    motion = Motion(fake, steps=4)
    with Client.connect(daemon[1]) as client:
        op = arguments.find("integrated", "moveLinearCartesianAbs")
        assert op is not None
        waiter = wait.Waiter(client, op, {"type": "RIGHT", "absHgMat": motion.goal}, None)
        assert waiter.fraction() == pytest.approx(0.0)
        motion.polls = 2
        assert waiter.fraction() == pytest.approx(0.5)
        motion.polls = 1
        console = Console(file=io.StringIO(), force_terminal=True, width=100)
        outcome = waiter.wait(None, console, show=True)
        assert outcome.finished and "100%" in console.file.getvalue()  # type: ignore[attr-defined]

    rel = wait.Target(lambda: pose([0, 0, 30]), pose([0, 0, 40]), relative=True, pose=True)
    rel.start = pose([0, 0, 10])
    assert rel.fraction() == pytest.approx(0.5)
    turn = wait.Target(
        lambda: pose(rpy=[0, 0, 30]), pose(rpy=[0, 0, 90]), relative=False, pose=True
    )
    turn.start = pose()
    assert turn.fraction() == pytest.approx(1 / 3)
    joints = wait.Target(lambda: [5.0, 0.0, 99.0], [10.0, 0.0], relative=False, pose=False)
    joints.start = [0.0, 0.0]
    assert joints.fraction() == pytest.approx(0.5)
    still = wait.Target(lambda: [0.0], [0.0], relative=True, pose=False)
    still.start = [0.0]
    assert still.fraction() is None
