"""The gRPC contract (controller/rpc/imotion.proto) matches the interface digest.

Checked through the descriptor API only; no server is started. The expected operation lists
are copied from ../shared/spec/interfaces.md and the seed IDL (Spec A, JARA_ARM,
JARA_ARM_DUAL), so a renamed, dropped or extra RPC fails here.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from types import ModuleType

import pytest
from google.protobuf.descriptor import Descriptor, FieldDescriptor, MethodDescriptor

from controller.rpc import imotion_pb2, imotion_pb2_grpc

REPO = Path(__file__).resolve().parents[1]

# Original operation names, in the originals' spelling (lowerCamel).
SPEC_A = [
    "abort", "clearAlarms", "closeGripper", "getActiveAlarm", "getFeedbackPosCartesian",
    "getFeedbackPosJoint", "getGripperPos", "getState", "getVersion", "isMoving", "isServoOn",
    "moveUnitAbs", "moveUnitRel", "moveCPHoldAbs", "moveCPHoldRel", "moveGripper",
    "moveLinearCartesianAbs", "moveLinearCartesianRel", "movePTPCartesianAbs",
    "movePTPCartesianRel", "openGripper", "pause", "resetOriginalFrame", "resume",
    "selectRedundantAxes", "servoOff", "servoOn", "setControlPointOffset", "stop",
]  # fmt: skip
JARA_COMMON = [
    "clearAlarms", "getActiveAlarm", "getFeedbackPosJoint", "getManipInfo",
    "getSoftLimitJoint", "getState", "servoOFF", "servoON", "setSoftLimitJoint",
]  # fmt: skip
JARA_MIDDLE = [
    "closeGripper", "getBaseOffset", "getFeedbackPosCartesian", "getMaxSpeedCartesian",
    "getMaxSpeedJoint", "getMinAccelTimeCartesian", "getMinAccelTimeJoint",
    "getSoftLimitCartesian", "moveGripper", "moveLinearCartesianAbs", "moveLinearCartesianRel",
    "movePTPCartesianAbs", "movePTPCartesianRel", "movePTPJointAbs", "movePTPJointRel",
    "openGripper", "pause", "resume", "stop", "setAccelTimeCartesian", "setAccelTimeJoint",
    "setBaseOffset", "setControlPointOffset", "setMaxSpeedCartesian", "setMaxSpeedJoint",
    "setMinAccelTimeCartesian", "setMinAccelTimeJoint", "setSoftLimitCartesian",
    "setSpeedCartesian", "setSpeedJoint", "moveCircularCartesianAbs",
    "moveCircularCartesianRel", "setHome", "getHome", "goHome",
]  # fmt: skip
SEED_NOID_EXTRAS = [
    "getSpeedCartesian", "getSpeedJoint", "setGraspForce", "getGraspForce",
    "moveLinearCartesianAbsCmdCycle", "moveLinearCartesianRelCmdCycle",
    "movePTPCartesianAbsCmdCycle", "movePTPCartesianRelCmdCycle",
    "movePTPJointAbsCmdCycle", "movePTPJointRelCmdCycle",
]  # fmt: skip
DUAL_COMMON = ["servoOFFArm", "servoOFFHand", "servoONArm", "servoONHand"]
DUAL_MIDDLE = [
    "closeGripper", "getRelativePosition", "moveGripper", "moveLinearCartesianAbs",
    "moveLinearCartesianRel", "movePTPCartesianAbs", "movePTPCartesianRel", "movePTPJointAbs",
    "movePTPJointRel", "openGripper",
]  # fmt: skip

SERVICES: dict[str, list[str]] = {
    "IntegratedMotion": SPEC_A,
    "ManipulatorCommon": JARA_COMMON,
    "ManipulatorMiddle": JARA_MIDDLE + SEED_NOID_EXTRAS,
    "DualManipulatorCommon": DUAL_COMMON,
    "DualManipulatorMiddle": DUAL_MIDDLE,
}
JARA_SINGLE_ARM = ("ManipulatorCommon", "ManipulatorMiddle")
# IntegratedMotion messages are <Rpc>Request/Response; the other services prefix the service
# name because their operation names recur within the one package.
UNPREFIXED = ("IntegratedMotion",)


def upper_camel(operation: str) -> str:
    return operation[0].upper() + operation[1:]


def snake(name: str) -> str:
    """The proto field name of an original lowerCamel argument name (absHgMat -> abs_hg_mat)."""
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


def methods(service: str) -> dict[str, MethodDescriptor]:
    return dict(imotion_pb2.DESCRIPTOR.services_by_name[service].methods_by_name)


def message(name: str) -> Descriptor:
    return imotion_pb2.DESCRIPTOR.message_types_by_name[name]


def load_gen_proto() -> ModuleType:
    spec = importlib.util.spec_from_file_location("gen_proto", REPO / "tools" / "gen_proto.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generated_modules_are_current() -> None:
    pytest.importorskip("grpc_tools", reason="grpcio-tools (dev extra) not installed")
    stale = load_gen_proto().stale_files()
    assert not stale, f"stale generated files {stale}; run: python tools/gen_proto.py"


#: imotion's own services beside the originals: the state stream and HIL fault injection.
OWN_SERVICES = ("Monitor", "Testing")


def test_package_and_grpc_module_import() -> None:
    assert imotion_pb2.DESCRIPTOR.package == "imotion.v1"
    for service in [*SERVICES, *OWN_SERVICES]:
        assert hasattr(imotion_pb2_grpc, f"{service}Stub")
        assert hasattr(imotion_pb2_grpc, f"{service}Servicer")
        assert hasattr(imotion_pb2_grpc, f"add_{service}Servicer_to_server")


def test_services_are_exactly_the_expected_ones() -> None:
    assert set(imotion_pb2.DESCRIPTOR.services_by_name) == {*SERVICES, *OWN_SERVICES}


def test_testing_service_is_fault_injection_only() -> None:
    methods = imotion_pb2.DESCRIPTOR.services_by_name["Testing"].methods_by_name
    assert set(methods) == {"InjectFault", "ClearFaults"}


def test_operation_counts() -> None:
    assert len(SPEC_A) == len(set(SPEC_A)) == 29
    assert len(JARA_COMMON) == 9
    assert len(JARA_MIDDLE) == 35
    assert len(SEED_NOID_EXTRAS) == 10
    assert len(DUAL_COMMON) == 4
    assert len(DUAL_MIDDLE) == 10


@pytest.mark.parametrize("service", SERVICES)
def test_rpc_names_are_the_operations_in_upper_camel_case(service: str) -> None:
    expected = {upper_camel(op) for op in SERVICES[service]}
    assert set(methods(service)) == expected
    assert len(methods(service)) == len(SERVICES[service])


def test_spelling_samples() -> None:
    assert "MoveCPHoldAbs" in methods("IntegratedMotion")
    assert {"ServoOn", "ServoOff"} <= set(methods("IntegratedMotion"))
    assert {"ServoON", "ServoOFF"} <= set(methods("ManipulatorCommon"))
    assert {"ServoONArm", "ServoOFFHand"} <= set(methods("DualManipulatorCommon"))
    assert "MovePTPJointRelCmdCycle" in methods("ManipulatorMiddle")


@pytest.mark.parametrize("service", SERVICES)
def test_request_and_response_message_names(service: str) -> None:
    prefix = "" if service in UNPREFIXED else service
    for rpc, method in methods(service).items():
        assert method.input_type.name == f"{prefix}{rpc}Request"
        assert method.output_type.name == f"{prefix}{rpc}Response"
        assert not method.client_streaming and not method.server_streaming


@pytest.mark.parametrize("service", SERVICES)
def test_every_response_starts_with_return_id(service: str) -> None:
    for method in methods(service).values():
        field = method.output_type.fields_by_name["return_id"]
        assert field.number == 1
        assert field.message_type.full_name == "imotion.v1.ReturnID"


@pytest.mark.parametrize("service", JARA_SINGLE_ARM)
def test_every_jara_request_has_an_arm_defaulting_to_right(service: str) -> None:
    for method in methods(service).values():
        arm = method.input_type.fields_by_name["arm"]
        assert arm.number == 1
        assert arm.enum_type.full_name == "imotion.v1.RightLeft"
        assert arm.enum_type.values_by_number[0].name == "RIGHT"  # the proto3 default


@pytest.mark.parametrize("service", [s for s in SERVICES if s not in JARA_SINGLE_ARM])
def test_non_jara_requests_have_no_arm_field(service: str) -> None:
    for method in methods(service).values():
        assert "arm" not in method.input_type.fields_by_name


def test_is_moving_and_is_servo_on_carry_a_bool() -> None:
    for rpc, field in (("IsMoving", "is_moving"), ("IsServoOn", "is_servo_on")):
        response = message(f"{rpc}Response")
        assert response.fields_by_name[field].type == FieldDescriptor.TYPE_BOOL


# (message, field names in order) for operations with arguments or out-parameters whose
# names and order must follow the original IDL.
ARGUMENTS = {
    "MoveCPHoldAbsRequest": ["type", "absPos", "speed", "accel"],
    "MoveLinearCartesianRelRequest": [
        "type", "frameType", "relHgMat", "speed", "accel", "isHoldOtherArm",
    ],
    "MovePTPCartesianAbsRequest": ["type", "absHgMat", "time", "isHoldOtherArm"],
    "SelectRedundantAxesRequest": ["redundancy", "limit"],
    "GetFeedbackPosCartesianResponse": ["return_id", "pos"],
    "GetStateResponse": ["return_id", "statusId", "message"],
    "GetGripperPosResponse": ["return_id", "angleRatio"],
    "ManipulatorCommonGetStateResponse": ["return_id", "state"],
    "ManipulatorMiddleGetSoftLimitCartesianResponse": ["return_id", "xLimit", "yLimit", "zLimit"],
    "ManipulatorMiddleMoveCircularCartesianAbsRequest": ["arm", "carPointR", "carPointT"],
    "DualManipulatorMiddleMovePTPJointAbsRequest": ["rArm", "lArm"],
    "DualManipulatorMiddleGetRelativePositionRequest": [],
    "DualManipulatorMiddleGetRelativePositionResponse": ["return_id", "relPos"],
}  # fmt: skip


@pytest.mark.parametrize("name", ARGUMENTS)
def test_argument_names_follow_the_originals(name: str) -> None:
    fields = [f.name for f in message(name).fields]
    assert fields == [snake(n) for n in ARGUMENTS[name]]
    # proto3 JSON names are the originals' lowerCamel names
    json = [f.json_name for f in message(name).fields if f.name != "return_id"]
    assert json == [n for n in ARGUMENTS[name] if n != "return_id"]


def test_hg_matrix_is_a_flat_row_major_list() -> None:
    m = message("HgMatrix").fields_by_name["m"]
    assert m.type == FieldDescriptor.TYPE_DOUBLE
    assert m.is_repeated
    sample = imotion_pb2.HgMatrix(m=[1, 0, 0, 10, 0, 1, 0, 20, 0, 0, 1, 30])
    assert list(sample.m[3::4]) == [10, 20, 30]  # p column, mm


def test_enums_follow_the_originals() -> None:
    def names(enum: str) -> list[str]:
        values = imotion_pb2.DESCRIPTOR.enum_types_by_name[enum].values
        return [v.name for v in sorted(values, key=lambda v: v.number)]

    assert names("RightLeft") == ["RIGHT", "LEFT"]
    assert names("UnitType") == ["RIGHT_ARM", "LEFT_ARM", "LUMBER", "VEHICLE"]
    assert names("AlarmType") == ["FAULT", "WARNING", "UNKNOWN"]
    assert names("FrameType") == ["ORIGINAL_FRAME", "CURRENT_FRAME"]
    assert names("CommandFrameType") == ["BASE_FRAME", "TOOL_FRAME"]


def test_monitor_stream_state_is_server_streaming() -> None:
    method = methods("Monitor")["StreamState"]
    assert set(methods("Monitor")) == {"StreamState"}
    assert method.server_streaming and not method.client_streaming
    assert method.input_type.name == "StreamStateRequest"
    assert method.output_type.name == "StateSample"
    rate = message("StreamStateRequest").fields_by_name["rate_hz"]
    assert rate.type == FieldDescriptor.TYPE_DOUBLE
    sample = message("StateSample").fields_by_name
    assert {"status_id", "status_message", "joints", "control_points", "alarms", "loop"} <= set(
        sample
    )
    assert sample["control_points"].message_type.fields_by_name["pose"].message_type.name == (
        "CarPosWithElbow"
    )
    loop = message("LoopStats").fields_by_name
    assert {"cycles", "overruns", "compute", "wake_latency"} <= set(loop)
    assert set(message("LatencyStats").fields_by_name) == {"p50_us", "p99_us", "max_us"}


def test_messages_round_trip() -> None:
    request = imotion_pb2.MoveLinearCartesianAbsRequest(
        type=imotion_pb2.LEFT,
        abs_hg_mat=imotion_pb2.HgMatrix(m=[1, 0, 0, 100, 0, 1, 0, 0, 0, 0, 1, 500]),
        speed=imotion_pb2.CartesianSpeed(translation=50, rotation=30),
        is_hold_other_arm=True,
    )
    decoded = imotion_pb2.MoveLinearCartesianAbsRequest.FromString(request.SerializeToString())
    assert decoded == request
    assert imotion_pb2.ManipulatorCommonServoONRequest().arm == imotion_pb2.RIGHT
