"""The product's IDL (controller/corba/idl) against the wire facts of the original
interfaces: repository IDs, operations, parameter directions and counts, struct layouts; and
the committed omniidl stubs are fresh (tools/gen_idl.py --check)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

pytest.importorskip("omniORB")

from omniORB import tcInternal

from controller.corba.stubs import (
    JARA_ARM,
    JARA_ARM_DUAL,
    JARA_ARM_LEFT,
)
from controller.corba.stubs import _GlobalIDL as SPEC_A

REPO = Path(__file__).resolve().parents[1]

#: operation: (number of in parameters, number of out parameters), from the interface facts.
SPEC_A_OPS = {
    "abort": (0, 0), "clearAlarms": (0, 0), "closeGripper": (1, 0), "getActiveAlarm": (0, 1),
    "getFeedbackPosCartesian": (2, 1), "getFeedbackPosJoint": (1, 1), "getGripperPos": (1, 1),
    "getState": (0, 2), "getVersion": (0, 1), "isMoving": (0, 0), "isServoOn": (0, 0),
    "moveUnitAbs": (4, 0), "moveUnitRel": (4, 0), "moveCPHoldAbs": (4, 0),
    "moveCPHoldRel": (4, 0), "moveGripper": (2, 0), "moveLinearCartesianAbs": (5, 0),
    "moveLinearCartesianRel": (6, 0), "movePTPCartesianAbs": (4, 0),
    "movePTPCartesianRel": (4, 0), "openGripper": (1, 0), "pause": (0, 0),
    "resetOriginalFrame": (0, 0), "resume": (0, 0), "selectRedundantAxes": (2, 0),
    "servoOff": (0, 0), "servoOn": (0, 0), "setControlPointOffset": (2, 0), "stop": (0, 0),
}  # fmt: skip
COMMON_OPS = {
    "clearAlarms": (0, 0), "getActiveAlarm": (0, 1), "getFeedbackPosJoint": (0, 1),
    "getManipInfo": (0, 1), "getSoftLimitJoint": (0, 1), "getState": (0, 1),
    "servoOFF": (0, 0), "servoON": (0, 0), "setSoftLimitJoint": (1, 0),
}  # fmt: skip
MIDDLE_OPS = {
    "closeGripper": (0, 0), "getBaseOffset": (0, 1), "getFeedbackPosCartesian": (0, 1),
    "getMaxSpeedCartesian": (0, 1), "getMaxSpeedJoint": (0, 1),
    "getMinAccelTimeCartesian": (0, 1), "getMinAccelTimeJoint": (0, 1),
    "getSoftLimitCartesian": (0, 3), "moveGripper": (1, 0), "moveLinearCartesianAbs": (1, 0),
    "moveLinearCartesianRel": (1, 0), "movePTPCartesianAbs": (1, 0),
    "movePTPCartesianRel": (1, 0), "movePTPJointAbs": (1, 0), "movePTPJointRel": (1, 0),
    "openGripper": (0, 0), "pause": (0, 0), "resume": (0, 0), "stop": (0, 0),
    "setAccelTimeCartesian": (1, 0), "setAccelTimeJoint": (1, 0), "setBaseOffset": (1, 0),
    "setControlPointOffset": (1, 0), "setMaxSpeedCartesian": (1, 0),
    "setMaxSpeedJoint": (1, 0), "setMinAccelTimeCartesian": (1, 0),
    "setMinAccelTimeJoint": (1, 0), "setSoftLimitCartesian": (3, 0),
    "setSpeedCartesian": (1, 0), "setSpeedJoint": (1, 0), "moveCircularCartesianAbs": (2, 0),
    "moveCircularCartesianRel": (2, 0), "setHome": (1, 0), "getHome": (0, 1), "goHome": (0, 0),
    "getSpeedCartesian": (0, 1), "getSpeedJoint": (0, 1), "setGraspForce": (1, 0),
    "getGraspForce": (0, 1), "moveLinearCartesianAbsCmdCycle": (1, 0),
    "moveLinearCartesianRelCmdCycle": (1, 0), "movePTPCartesianAbsCmdCycle": (1, 0),
    "movePTPCartesianRelCmdCycle": (1, 0), "movePTPJointAbsCmdCycle": (1, 0),
    "movePTPJointRelCmdCycle": (1, 0),
}  # fmt: skip
DUAL_COMMON_OPS = {n: (0, 0) for n in ("servoOFFArm", "servoOFFHand", "servoONArm", "servoONHand")}
DUAL_MIDDLE_OPS = {
    n: (2, 0)
    for n in (
        "closeGripper", "moveGripper", "moveLinearCartesianAbs", "moveLinearCartesianRel",
        "movePTPCartesianAbs", "movePTPCartesianRel", "movePTPJointAbs", "movePTPJointRel",
        "openGripper",
    )
} | {"getRelativePosition": (1, 0)}  # fmt: skip

INTERFACES = [
    (SPEC_A.IntegratedMotionInterface, "IDL:IntegratedMotionInterface:1.0", SPEC_A_OPS),
    (JARA_ARM.ManipulatorCommonInterface_Common,
     "IDL:JARA_ARM/ManipulatorCommonInterface_Common:1.0", COMMON_OPS),
    (JARA_ARM.ManipulatorCommonInterface_Middle,
     "IDL:JARA_ARM/ManipulatorCommonInterface_Middle:1.0", MIDDLE_OPS),
    (JARA_ARM_LEFT.LeftManipulatorCommonInterface_Common,
     "IDL:JARA_ARM_LEFT/LeftManipulatorCommonInterface_Common:1.0", COMMON_OPS),
    (JARA_ARM_LEFT.LeftManipulatorCommonInterface_Middle,
     "IDL:JARA_ARM_LEFT/LeftManipulatorCommonInterface_Middle:1.0", MIDDLE_OPS),
    (JARA_ARM_DUAL.DualManipulatorCommonInterface_Common,
     "IDL:JARA_ARM_DUAL/DualManipulatorCommonInterface_Common:1.0", DUAL_COMMON_OPS),
    (JARA_ARM_DUAL.DualManipulatorCommonInterface_Middle,
     "IDL:JARA_ARM_DUAL/DualManipulatorCommonInterface_Middle:1.0", DUAL_MIDDLE_OPS),
]  # fmt: skip


def _ops(iface: Any) -> dict[str, tuple[int, int]]:
    out = {}
    for name in dir(iface):
        if name.startswith("_d_"):
            ins, outs = getattr(iface, name)[:2]
            out[name[3:]] = (len(ins), len(outs) - 1)
    return out


@pytest.mark.parametrize(("iface", "repo_id", "ops"), INTERFACES, ids=lambda v: str(v)[-40:])
def test_repository_ids_operations_and_directions(iface: Any, repo_id: str, ops: dict) -> None:
    assert iface._NP_RepositoryId == repo_id
    assert _ops(iface) == ops


def test_counts_are_the_originals() -> None:
    assert [len(ops) for _, _, ops in INTERFACES] == [29, 9, 45, 9, 45, 4, 10]


def test_booleans_and_return_ids() -> None:
    spec = SPEC_A.IntegratedMotionInterface
    assert spec._d_isMoving[1] == (tcInternal.tv_boolean,)
    assert spec._d_isServoOn[1] == (tcInternal.tv_boolean,)
    assert SPEC_A.ReturnID._NP_RepositoryId == "IDL:ReturnID:1.0"
    for module in (JARA_ARM, JARA_ARM_LEFT, JARA_ARM_DUAL):
        name = module.__name__.rsplit(".", 1)[-1]
        assert module.RETURN_ID._NP_RepositoryId == f"IDL:{name}/RETURN_ID:1.0"
        assert module.HgMatrix._NP_RepositoryId == f"IDL:{name}/HgMatrix:1.0"
        assert module.CarPosWithElbow._NP_RepositoryId == f"IDL:{name}/CarPosWithElbow:1.0"


@pytest.mark.parametrize(
    ("struct", "repo_id", "fields"),
    [
        (SPEC_A.Alarm, "IDL:Alarm:1.0", ["code", "type", "description", "moduleName"]),
        (SPEC_A.CarPosWithElbow, "IDL:CarPosWithElbow:1.0", ["carPos", "elbow", "structFlag"]),
        (SPEC_A.RedundantAxesMask, "IDL:RedundantAxesMask:1.0",
         ["elbow", "lumbarRx", "lumbarRy", "lumbarRz", "vehicleX", "vehicleY", "vehicleTheta"]),
        (SPEC_A.RedundantLimit, "IDL:RedundantLimit:1.0",
         ["rightElbow", "leftElbow", "lumbarRx", "lumbarRy", "lumbarRz", "vehicleX",
          "vehicleY", "vehicleTheta"]),
        (SPEC_A.RedundantSpeed, "IDL:RedundantSpeed:1.0",
         ["elbow", "lumbarRx", "lumbarRy", "lumbarRz", "vehicleTranslation", "vehicleRotation"]),
        (SPEC_A.LimitValue, "IDL:LimitValue:1.0", ["upper", "lower"]),
        (JARA_ARM.Alarm, "IDL:JARA_ARM/Alarm:1.0", ["code", "type", "description"]),
        (JARA_ARM.ManipInfo, "IDL:JARA_ARM/ManipInfo:1.0",
         ["manufactur", "type", "axisNum", "cmdCycle", "isGripper"]),
        (JARA_ARM_LEFT.ManipInfo, "IDL:JARA_ARM_LEFT/ManipInfo:1.0",
         ["manufactur", "type", "axisNum", "cmdCycle", "isGripper"]),
        (JARA_ARM.LimitValue, "IDL:JARA_ARM/LimitValue:1.0", ["upper", "lower"]),
    ],
)  # fmt: skip
def test_struct_layouts(struct: Any, repo_id: str, fields: list[str]) -> None:
    assert struct._NP_RepositoryId == repo_id
    import omniORB

    desc = omniORB.findType(repo_id)
    assert list(desc[4::2]) == fields


def test_enums_and_constants() -> None:
    assert [str(i) for i in SPEC_A.UnitType._items] == [
        "RIGHT_ARM",
        "LEFT_ARM",
        "LUMBER",
        "VEHICLE",
    ]
    assert [str(i) for i in SPEC_A.RightLeft._items] == ["RIGHT", "LEFT"]
    assert [str(i) for i in SPEC_A.CommandFrameType._items] == ["BASE_FRAME", "TOOL_FRAME"]
    assert [str(i) for i in SPEC_A.FrameType._items] == ["ORIGINAL_FRAME", "CURRENT_FRAME"]
    for m in (JARA_ARM, JARA_ARM_LEFT):
        assert (m.OK, m.NG, m.STATUS_ERR, m.VALUE_ERR) == (0, -1, -2, -3)
        assert (m.NOT_SV_ON_ERR, m.FULL_MOTION_QUEUE_ERR, m.NOT_IMPLEMENTED) == (-4, -5, -6)
        assert (m.CONST_BINARY_00000001, m.CONST_BINARY_00001000) == (1, 8)


def _load_gen_idl() -> ModuleType:
    spec = importlib.util.spec_from_file_location("gen_idl", REPO / "tools" / "gen_idl.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_committed_stubs_are_fresh() -> None:
    stale = _load_gen_idl().stale_files()
    assert not stale, f"stale stubs {stale}; run: python tools/gen_idl.py"
