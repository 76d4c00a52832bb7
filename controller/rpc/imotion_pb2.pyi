from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class AlarmType(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    FAULT: _ClassVar[AlarmType]
    WARNING: _ClassVar[AlarmType]
    UNKNOWN: _ClassVar[AlarmType]

class RightLeft(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    RIGHT: _ClassVar[RightLeft]
    LEFT: _ClassVar[RightLeft]

class FrameType(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    ORIGINAL_FRAME: _ClassVar[FrameType]
    CURRENT_FRAME: _ClassVar[FrameType]

class CommandFrameType(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    BASE_FRAME: _ClassVar[CommandFrameType]
    TOOL_FRAME: _ClassVar[CommandFrameType]

class UnitType(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    RIGHT_ARM: _ClassVar[UnitType]
    LEFT_ARM: _ClassVar[UnitType]
    LUMBER: _ClassVar[UnitType]
    VEHICLE: _ClassVar[UnitType]
FAULT: AlarmType
WARNING: AlarmType
UNKNOWN: AlarmType
RIGHT: RightLeft
LEFT: RightLeft
ORIGINAL_FRAME: FrameType
CURRENT_FRAME: FrameType
BASE_FRAME: CommandFrameType
TOOL_FRAME: CommandFrameType
RIGHT_ARM: UnitType
LEFT_ARM: UnitType
LUMBER: UnitType
VEHICLE: UnitType

class ReturnID(_message.Message):
    __slots__ = ("id", "comment")
    ID_FIELD_NUMBER: _ClassVar[int]
    COMMENT_FIELD_NUMBER: _ClassVar[int]
    id: int
    comment: str
    def __init__(self, id: _Optional[int] = ..., comment: _Optional[str] = ...) -> None: ...

class HgMatrix(_message.Message):
    __slots__ = ("m",)
    M_FIELD_NUMBER: _ClassVar[int]
    m: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, m: _Optional[_Iterable[float]] = ...) -> None: ...

class CarPosWithElbow(_message.Message):
    __slots__ = ("car_pos", "elbow", "struct_flag")
    CAR_POS_FIELD_NUMBER: _ClassVar[int]
    ELBOW_FIELD_NUMBER: _ClassVar[int]
    STRUCT_FLAG_FIELD_NUMBER: _ClassVar[int]
    car_pos: HgMatrix
    elbow: float
    struct_flag: int
    def __init__(self, car_pos: _Optional[_Union[HgMatrix, _Mapping]] = ..., elbow: _Optional[float] = ..., struct_flag: _Optional[int] = ...) -> None: ...

class CartesianSpeed(_message.Message):
    __slots__ = ("translation", "rotation")
    TRANSLATION_FIELD_NUMBER: _ClassVar[int]
    ROTATION_FIELD_NUMBER: _ClassVar[int]
    translation: float
    rotation: float
    def __init__(self, translation: _Optional[float] = ..., rotation: _Optional[float] = ...) -> None: ...

class CartesianAccel(_message.Message):
    __slots__ = ("translation", "rotation")
    TRANSLATION_FIELD_NUMBER: _ClassVar[int]
    ROTATION_FIELD_NUMBER: _ClassVar[int]
    translation: float
    rotation: float
    def __init__(self, translation: _Optional[float] = ..., rotation: _Optional[float] = ...) -> None: ...

class LimitValue(_message.Message):
    __slots__ = ("upper", "lower")
    UPPER_FIELD_NUMBER: _ClassVar[int]
    LOWER_FIELD_NUMBER: _ClassVar[int]
    upper: float
    lower: float
    def __init__(self, upper: _Optional[float] = ..., lower: _Optional[float] = ...) -> None: ...

class RedundantPos(_message.Message):
    __slots__ = ("elbow", "lumbar_rx", "lumbar_ry", "lumbar_rz", "vehicle_x", "vehicle_y", "vehicle_theta")
    ELBOW_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RX_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RY_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RZ_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_X_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_Y_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_THETA_FIELD_NUMBER: _ClassVar[int]
    elbow: float
    lumbar_rx: float
    lumbar_ry: float
    lumbar_rz: float
    vehicle_x: float
    vehicle_y: float
    vehicle_theta: float
    def __init__(self, elbow: _Optional[float] = ..., lumbar_rx: _Optional[float] = ..., lumbar_ry: _Optional[float] = ..., lumbar_rz: _Optional[float] = ..., vehicle_x: _Optional[float] = ..., vehicle_y: _Optional[float] = ..., vehicle_theta: _Optional[float] = ...) -> None: ...

class RedundantSpeed(_message.Message):
    __slots__ = ("elbow", "lumbar_rx", "lumbar_ry", "lumbar_rz", "vehicle_translation", "vehicle_rotation")
    ELBOW_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RX_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RY_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RZ_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_TRANSLATION_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_ROTATION_FIELD_NUMBER: _ClassVar[int]
    elbow: float
    lumbar_rx: float
    lumbar_ry: float
    lumbar_rz: float
    vehicle_translation: float
    vehicle_rotation: float
    def __init__(self, elbow: _Optional[float] = ..., lumbar_rx: _Optional[float] = ..., lumbar_ry: _Optional[float] = ..., lumbar_rz: _Optional[float] = ..., vehicle_translation: _Optional[float] = ..., vehicle_rotation: _Optional[float] = ...) -> None: ...

class RedundantAccel(_message.Message):
    __slots__ = ("elbow", "lumbar_rx", "lumbar_ry", "lumbar_rz", "vehicle_translation", "vehicle_rotation")
    ELBOW_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RX_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RY_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RZ_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_TRANSLATION_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_ROTATION_FIELD_NUMBER: _ClassVar[int]
    elbow: float
    lumbar_rx: float
    lumbar_ry: float
    lumbar_rz: float
    vehicle_translation: float
    vehicle_rotation: float
    def __init__(self, elbow: _Optional[float] = ..., lumbar_rx: _Optional[float] = ..., lumbar_ry: _Optional[float] = ..., lumbar_rz: _Optional[float] = ..., vehicle_translation: _Optional[float] = ..., vehicle_rotation: _Optional[float] = ...) -> None: ...

class RedundantAxesMask(_message.Message):
    __slots__ = ("elbow", "lumbar_rx", "lumbar_ry", "lumbar_rz", "vehicle_x", "vehicle_y", "vehicle_theta")
    ELBOW_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RX_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RY_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RZ_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_X_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_Y_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_THETA_FIELD_NUMBER: _ClassVar[int]
    elbow: bool
    lumbar_rx: bool
    lumbar_ry: bool
    lumbar_rz: bool
    vehicle_x: bool
    vehicle_y: bool
    vehicle_theta: bool
    def __init__(self, elbow: _Optional[bool] = ..., lumbar_rx: _Optional[bool] = ..., lumbar_ry: _Optional[bool] = ..., lumbar_rz: _Optional[bool] = ..., vehicle_x: _Optional[bool] = ..., vehicle_y: _Optional[bool] = ..., vehicle_theta: _Optional[bool] = ...) -> None: ...

class RedundantLimit(_message.Message):
    __slots__ = ("right_elbow", "left_elbow", "lumbar_rx", "lumbar_ry", "lumbar_rz", "vehicle_x", "vehicle_y", "vehicle_theta")
    RIGHT_ELBOW_FIELD_NUMBER: _ClassVar[int]
    LEFT_ELBOW_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RX_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RY_FIELD_NUMBER: _ClassVar[int]
    LUMBAR_RZ_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_X_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_Y_FIELD_NUMBER: _ClassVar[int]
    VEHICLE_THETA_FIELD_NUMBER: _ClassVar[int]
    right_elbow: LimitValue
    left_elbow: LimitValue
    lumbar_rx: LimitValue
    lumbar_ry: LimitValue
    lumbar_rz: LimitValue
    vehicle_x: LimitValue
    vehicle_y: LimitValue
    vehicle_theta: LimitValue
    def __init__(self, right_elbow: _Optional[_Union[LimitValue, _Mapping]] = ..., left_elbow: _Optional[_Union[LimitValue, _Mapping]] = ..., lumbar_rx: _Optional[_Union[LimitValue, _Mapping]] = ..., lumbar_ry: _Optional[_Union[LimitValue, _Mapping]] = ..., lumbar_rz: _Optional[_Union[LimitValue, _Mapping]] = ..., vehicle_x: _Optional[_Union[LimitValue, _Mapping]] = ..., vehicle_y: _Optional[_Union[LimitValue, _Mapping]] = ..., vehicle_theta: _Optional[_Union[LimitValue, _Mapping]] = ...) -> None: ...

class Alarm(_message.Message):
    __slots__ = ("code", "type", "description", "module_name")
    CODE_FIELD_NUMBER: _ClassVar[int]
    TYPE_FIELD_NUMBER: _ClassVar[int]
    DESCRIPTION_FIELD_NUMBER: _ClassVar[int]
    MODULE_NAME_FIELD_NUMBER: _ClassVar[int]
    code: int
    type: AlarmType
    description: str
    module_name: str
    def __init__(self, code: _Optional[int] = ..., type: _Optional[_Union[AlarmType, str]] = ..., description: _Optional[str] = ..., module_name: _Optional[str] = ...) -> None: ...

class ManipInfo(_message.Message):
    __slots__ = ("manufactur", "type", "axis_num", "cmd_cycle", "is_gripper")
    MANUFACTUR_FIELD_NUMBER: _ClassVar[int]
    TYPE_FIELD_NUMBER: _ClassVar[int]
    AXIS_NUM_FIELD_NUMBER: _ClassVar[int]
    CMD_CYCLE_FIELD_NUMBER: _ClassVar[int]
    IS_GRIPPER_FIELD_NUMBER: _ClassVar[int]
    manufactur: str
    type: str
    axis_num: int
    cmd_cycle: int
    is_gripper: bool
    def __init__(self, manufactur: _Optional[str] = ..., type: _Optional[str] = ..., axis_num: _Optional[int] = ..., cmd_cycle: _Optional[int] = ..., is_gripper: _Optional[bool] = ...) -> None: ...

class AbortRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class AbortResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ClearAlarmsRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class ClearAlarmsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class CloseGripperRequest(_message.Message):
    __slots__ = ("type",)
    TYPE_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class CloseGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class GetActiveAlarmRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class GetActiveAlarmResponse(_message.Message):
    __slots__ = ("return_id", "alarms")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    ALARMS_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    alarms: _containers.RepeatedCompositeFieldContainer[Alarm]
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., alarms: _Optional[_Iterable[_Union[Alarm, _Mapping]]] = ...) -> None: ...

class GetFeedbackPosCartesianRequest(_message.Message):
    __slots__ = ("type", "frame_type")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    FRAME_TYPE_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    frame_type: FrameType
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., frame_type: _Optional[_Union[FrameType, str]] = ...) -> None: ...

class GetFeedbackPosCartesianResponse(_message.Message):
    __slots__ = ("return_id", "pos")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    POS_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    pos: CarPosWithElbow
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., pos: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class GetFeedbackPosJointRequest(_message.Message):
    __slots__ = ("type",)
    TYPE_FIELD_NUMBER: _ClassVar[int]
    type: UnitType
    def __init__(self, type: _Optional[_Union[UnitType, str]] = ...) -> None: ...

class GetFeedbackPosJointResponse(_message.Message):
    __slots__ = ("return_id", "position")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    POSITION_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    position: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., position: _Optional[_Iterable[float]] = ...) -> None: ...

class GetGripperPosRequest(_message.Message):
    __slots__ = ("type",)
    TYPE_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class GetGripperPosResponse(_message.Message):
    __slots__ = ("return_id", "angle_ratio")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    ANGLE_RATIO_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    angle_ratio: int
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., angle_ratio: _Optional[int] = ...) -> None: ...

class GetStateRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class GetStateResponse(_message.Message):
    __slots__ = ("return_id", "status_id", "message")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    STATUS_ID_FIELD_NUMBER: _ClassVar[int]
    MESSAGE_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    status_id: int
    message: str
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., status_id: _Optional[int] = ..., message: _Optional[str] = ...) -> None: ...

class GetVersionRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class GetVersionResponse(_message.Message):
    __slots__ = ("return_id", "version")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    VERSION_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    version: str
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., version: _Optional[str] = ...) -> None: ...

class IsMovingRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class IsMovingResponse(_message.Message):
    __slots__ = ("return_id", "is_moving")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    IS_MOVING_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    is_moving: bool
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., is_moving: _Optional[bool] = ...) -> None: ...

class IsServoOnRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class IsServoOnResponse(_message.Message):
    __slots__ = ("return_id", "is_servo_on")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    IS_SERVO_ON_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    is_servo_on: bool
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., is_servo_on: _Optional[bool] = ...) -> None: ...

class MoveUnitAbsRequest(_message.Message):
    __slots__ = ("unit", "abs_pos", "speed", "accel")
    UNIT_FIELD_NUMBER: _ClassVar[int]
    ABS_POS_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    ACCEL_FIELD_NUMBER: _ClassVar[int]
    unit: UnitType
    abs_pos: _containers.RepeatedScalarFieldContainer[float]
    speed: _containers.RepeatedScalarFieldContainer[float]
    accel: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, unit: _Optional[_Union[UnitType, str]] = ..., abs_pos: _Optional[_Iterable[float]] = ..., speed: _Optional[_Iterable[float]] = ..., accel: _Optional[_Iterable[float]] = ...) -> None: ...

class MoveUnitAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class MoveUnitRelRequest(_message.Message):
    __slots__ = ("unit", "rel_pos", "speed", "accel")
    UNIT_FIELD_NUMBER: _ClassVar[int]
    REL_POS_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    ACCEL_FIELD_NUMBER: _ClassVar[int]
    unit: UnitType
    rel_pos: _containers.RepeatedScalarFieldContainer[float]
    speed: _containers.RepeatedScalarFieldContainer[float]
    accel: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, unit: _Optional[_Union[UnitType, str]] = ..., rel_pos: _Optional[_Iterable[float]] = ..., speed: _Optional[_Iterable[float]] = ..., accel: _Optional[_Iterable[float]] = ...) -> None: ...

class MoveUnitRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class MoveCPHoldAbsRequest(_message.Message):
    __slots__ = ("type", "abs_pos", "speed", "accel")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    ABS_POS_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    ACCEL_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    abs_pos: RedundantPos
    speed: RedundantSpeed
    accel: RedundantAccel
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., abs_pos: _Optional[_Union[RedundantPos, _Mapping]] = ..., speed: _Optional[_Union[RedundantSpeed, _Mapping]] = ..., accel: _Optional[_Union[RedundantAccel, _Mapping]] = ...) -> None: ...

class MoveCPHoldAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class MoveCPHoldRelRequest(_message.Message):
    __slots__ = ("type", "rel_pos", "speed", "accel")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    REL_POS_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    ACCEL_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    rel_pos: RedundantPos
    speed: RedundantSpeed
    accel: RedundantAccel
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., rel_pos: _Optional[_Union[RedundantPos, _Mapping]] = ..., speed: _Optional[_Union[RedundantSpeed, _Mapping]] = ..., accel: _Optional[_Union[RedundantAccel, _Mapping]] = ...) -> None: ...

class MoveCPHoldRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class MoveGripperRequest(_message.Message):
    __slots__ = ("type", "angle_ratio")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    ANGLE_RATIO_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    angle_ratio: int
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., angle_ratio: _Optional[int] = ...) -> None: ...

class MoveGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class MoveLinearCartesianAbsRequest(_message.Message):
    __slots__ = ("type", "abs_hg_mat", "speed", "accel", "is_hold_other_arm")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    ABS_HG_MAT_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    ACCEL_FIELD_NUMBER: _ClassVar[int]
    IS_HOLD_OTHER_ARM_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    abs_hg_mat: HgMatrix
    speed: CartesianSpeed
    accel: CartesianAccel
    is_hold_other_arm: bool
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., abs_hg_mat: _Optional[_Union[HgMatrix, _Mapping]] = ..., speed: _Optional[_Union[CartesianSpeed, _Mapping]] = ..., accel: _Optional[_Union[CartesianAccel, _Mapping]] = ..., is_hold_other_arm: _Optional[bool] = ...) -> None: ...

class MoveLinearCartesianAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class MoveLinearCartesianRelRequest(_message.Message):
    __slots__ = ("type", "frame_type", "rel_hg_mat", "speed", "accel", "is_hold_other_arm")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    FRAME_TYPE_FIELD_NUMBER: _ClassVar[int]
    REL_HG_MAT_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    ACCEL_FIELD_NUMBER: _ClassVar[int]
    IS_HOLD_OTHER_ARM_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    frame_type: CommandFrameType
    rel_hg_mat: HgMatrix
    speed: CartesianSpeed
    accel: CartesianAccel
    is_hold_other_arm: bool
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., frame_type: _Optional[_Union[CommandFrameType, str]] = ..., rel_hg_mat: _Optional[_Union[HgMatrix, _Mapping]] = ..., speed: _Optional[_Union[CartesianSpeed, _Mapping]] = ..., accel: _Optional[_Union[CartesianAccel, _Mapping]] = ..., is_hold_other_arm: _Optional[bool] = ...) -> None: ...

class MoveLinearCartesianRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class MovePTPCartesianAbsRequest(_message.Message):
    __slots__ = ("type", "abs_hg_mat", "time", "is_hold_other_arm")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    ABS_HG_MAT_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    IS_HOLD_OTHER_ARM_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    abs_hg_mat: HgMatrix
    time: float
    is_hold_other_arm: bool
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., abs_hg_mat: _Optional[_Union[HgMatrix, _Mapping]] = ..., time: _Optional[float] = ..., is_hold_other_arm: _Optional[bool] = ...) -> None: ...

class MovePTPCartesianAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class MovePTPCartesianRelRequest(_message.Message):
    __slots__ = ("type", "rel_hg_mat", "time", "is_hold_other_arm")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    REL_HG_MAT_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    IS_HOLD_OTHER_ARM_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    rel_hg_mat: HgMatrix
    time: float
    is_hold_other_arm: bool
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., rel_hg_mat: _Optional[_Union[HgMatrix, _Mapping]] = ..., time: _Optional[float] = ..., is_hold_other_arm: _Optional[bool] = ...) -> None: ...

class MovePTPCartesianRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class OpenGripperRequest(_message.Message):
    __slots__ = ("type",)
    TYPE_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class OpenGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class PauseRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class PauseResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ResetOriginalFrameRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class ResetOriginalFrameResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ResumeRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class ResumeResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class SelectRedundantAxesRequest(_message.Message):
    __slots__ = ("redundancy", "limit")
    REDUNDANCY_FIELD_NUMBER: _ClassVar[int]
    LIMIT_FIELD_NUMBER: _ClassVar[int]
    redundancy: RedundantAxesMask
    limit: RedundantLimit
    def __init__(self, redundancy: _Optional[_Union[RedundantAxesMask, _Mapping]] = ..., limit: _Optional[_Union[RedundantLimit, _Mapping]] = ...) -> None: ...

class SelectRedundantAxesResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ServoOffRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class ServoOffResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ServoOnRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class ServoOnResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class SetControlPointOffsetRequest(_message.Message):
    __slots__ = ("type", "offset")
    TYPE_FIELD_NUMBER: _ClassVar[int]
    OFFSET_FIELD_NUMBER: _ClassVar[int]
    type: RightLeft
    offset: HgMatrix
    def __init__(self, type: _Optional[_Union[RightLeft, str]] = ..., offset: _Optional[_Union[HgMatrix, _Mapping]] = ...) -> None: ...

class SetControlPointOffsetResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class StopRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class StopResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorCommonClearAlarmsRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorCommonClearAlarmsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorCommonGetActiveAlarmRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorCommonGetActiveAlarmResponse(_message.Message):
    __slots__ = ("return_id", "alarms")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    ALARMS_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    alarms: _containers.RepeatedCompositeFieldContainer[Alarm]
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., alarms: _Optional[_Iterable[_Union[Alarm, _Mapping]]] = ...) -> None: ...

class ManipulatorCommonGetFeedbackPosJointRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorCommonGetFeedbackPosJointResponse(_message.Message):
    __slots__ = ("return_id", "pos")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    POS_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    pos: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., pos: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorCommonGetManipInfoRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorCommonGetManipInfoResponse(_message.Message):
    __slots__ = ("return_id", "m_info")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    M_INFO_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    m_info: ManipInfo
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., m_info: _Optional[_Union[ManipInfo, _Mapping]] = ...) -> None: ...

class ManipulatorCommonGetSoftLimitJointRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorCommonGetSoftLimitJointResponse(_message.Message):
    __slots__ = ("return_id", "soft_limit")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    SOFT_LIMIT_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    soft_limit: _containers.RepeatedCompositeFieldContainer[LimitValue]
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., soft_limit: _Optional[_Iterable[_Union[LimitValue, _Mapping]]] = ...) -> None: ...

class ManipulatorCommonGetStateRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorCommonGetStateResponse(_message.Message):
    __slots__ = ("return_id", "state")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    STATE_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    state: int
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., state: _Optional[int] = ...) -> None: ...

class ManipulatorCommonServoOFFRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorCommonServoOFFResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorCommonServoONRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorCommonServoONResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorCommonSetSoftLimitJointRequest(_message.Message):
    __slots__ = ("arm", "soft_limit")
    ARM_FIELD_NUMBER: _ClassVar[int]
    SOFT_LIMIT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    soft_limit: _containers.RepeatedCompositeFieldContainer[LimitValue]
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., soft_limit: _Optional[_Iterable[_Union[LimitValue, _Mapping]]] = ...) -> None: ...

class ManipulatorCommonSetSoftLimitJointResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleCloseGripperRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleCloseGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleGetBaseOffsetRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetBaseOffsetResponse(_message.Message):
    __slots__ = ("return_id", "offset")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    OFFSET_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    offset: HgMatrix
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., offset: _Optional[_Union[HgMatrix, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleGetFeedbackPosCartesianRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetFeedbackPosCartesianResponse(_message.Message):
    __slots__ = ("return_id", "pos")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    POS_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    pos: CarPosWithElbow
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., pos: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleGetMaxSpeedCartesianRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetMaxSpeedCartesianResponse(_message.Message):
    __slots__ = ("return_id", "speed")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    speed: CartesianSpeed
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., speed: _Optional[_Union[CartesianSpeed, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleGetMaxSpeedJointRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetMaxSpeedJointResponse(_message.Message):
    __slots__ = ("return_id", "speed")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    speed: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., speed: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorMiddleGetMinAccelTimeCartesianRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetMinAccelTimeCartesianResponse(_message.Message):
    __slots__ = ("return_id", "acl_time")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    ACL_TIME_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    acl_time: float
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., acl_time: _Optional[float] = ...) -> None: ...

class ManipulatorMiddleGetMinAccelTimeJointRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetMinAccelTimeJointResponse(_message.Message):
    __slots__ = ("return_id", "acl_time")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    ACL_TIME_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    acl_time: float
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., acl_time: _Optional[float] = ...) -> None: ...

class ManipulatorMiddleGetSoftLimitCartesianRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetSoftLimitCartesianResponse(_message.Message):
    __slots__ = ("return_id", "x_limit", "y_limit", "z_limit")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    X_LIMIT_FIELD_NUMBER: _ClassVar[int]
    Y_LIMIT_FIELD_NUMBER: _ClassVar[int]
    Z_LIMIT_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    x_limit: LimitValue
    y_limit: LimitValue
    z_limit: LimitValue
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., x_limit: _Optional[_Union[LimitValue, _Mapping]] = ..., y_limit: _Optional[_Union[LimitValue, _Mapping]] = ..., z_limit: _Optional[_Union[LimitValue, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveGripperRequest(_message.Message):
    __slots__ = ("arm", "angle_ratio")
    ARM_FIELD_NUMBER: _ClassVar[int]
    ANGLE_RATIO_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    angle_ratio: int
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., angle_ratio: _Optional[int] = ...) -> None: ...

class ManipulatorMiddleMoveGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveLinearCartesianAbsRequest(_message.Message):
    __slots__ = ("arm", "car_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveLinearCartesianAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveLinearCartesianRelRequest(_message.Message):
    __slots__ = ("arm", "car_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveLinearCartesianRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPCartesianAbsRequest(_message.Message):
    __slots__ = ("arm", "car_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPCartesianAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPCartesianRelRequest(_message.Message):
    __slots__ = ("arm", "car_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPCartesianRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPJointAbsRequest(_message.Message):
    __slots__ = ("arm", "joint_points")
    ARM_FIELD_NUMBER: _ClassVar[int]
    JOINT_POINTS_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    joint_points: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., joint_points: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorMiddleMovePTPJointAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPJointRelRequest(_message.Message):
    __slots__ = ("arm", "joint_points")
    ARM_FIELD_NUMBER: _ClassVar[int]
    JOINT_POINTS_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    joint_points: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., joint_points: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorMiddleMovePTPJointRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleOpenGripperRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleOpenGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddlePauseRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddlePauseResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleResumeRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleResumeResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleStopRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleStopResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetAccelTimeCartesianRequest(_message.Message):
    __slots__ = ("arm", "acl_time")
    ARM_FIELD_NUMBER: _ClassVar[int]
    ACL_TIME_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    acl_time: float
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., acl_time: _Optional[float] = ...) -> None: ...

class ManipulatorMiddleSetAccelTimeCartesianResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetAccelTimeJointRequest(_message.Message):
    __slots__ = ("arm", "acl_time")
    ARM_FIELD_NUMBER: _ClassVar[int]
    ACL_TIME_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    acl_time: float
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., acl_time: _Optional[float] = ...) -> None: ...

class ManipulatorMiddleSetAccelTimeJointResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetBaseOffsetRequest(_message.Message):
    __slots__ = ("arm", "offset")
    ARM_FIELD_NUMBER: _ClassVar[int]
    OFFSET_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    offset: HgMatrix
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., offset: _Optional[_Union[HgMatrix, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetBaseOffsetResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetControlPointOffsetRequest(_message.Message):
    __slots__ = ("arm", "offset")
    ARM_FIELD_NUMBER: _ClassVar[int]
    OFFSET_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    offset: HgMatrix
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., offset: _Optional[_Union[HgMatrix, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetControlPointOffsetResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetMaxSpeedCartesianRequest(_message.Message):
    __slots__ = ("arm", "speed")
    ARM_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    speed: CartesianSpeed
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., speed: _Optional[_Union[CartesianSpeed, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetMaxSpeedCartesianResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetMaxSpeedJointRequest(_message.Message):
    __slots__ = ("arm", "speed")
    ARM_FIELD_NUMBER: _ClassVar[int]
    SPEED_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    speed: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., speed: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorMiddleSetMaxSpeedJointResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetMinAccelTimeCartesianRequest(_message.Message):
    __slots__ = ("arm", "acl_time")
    ARM_FIELD_NUMBER: _ClassVar[int]
    ACL_TIME_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    acl_time: float
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., acl_time: _Optional[float] = ...) -> None: ...

class ManipulatorMiddleSetMinAccelTimeCartesianResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetMinAccelTimeJointRequest(_message.Message):
    __slots__ = ("arm", "acl_time")
    ARM_FIELD_NUMBER: _ClassVar[int]
    ACL_TIME_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    acl_time: float
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., acl_time: _Optional[float] = ...) -> None: ...

class ManipulatorMiddleSetMinAccelTimeJointResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetSoftLimitCartesianRequest(_message.Message):
    __slots__ = ("arm", "x_limit", "y_limit", "z_limit")
    ARM_FIELD_NUMBER: _ClassVar[int]
    X_LIMIT_FIELD_NUMBER: _ClassVar[int]
    Y_LIMIT_FIELD_NUMBER: _ClassVar[int]
    Z_LIMIT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    x_limit: LimitValue
    y_limit: LimitValue
    z_limit: LimitValue
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., x_limit: _Optional[_Union[LimitValue, _Mapping]] = ..., y_limit: _Optional[_Union[LimitValue, _Mapping]] = ..., z_limit: _Optional[_Union[LimitValue, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetSoftLimitCartesianResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetSpeedCartesianRequest(_message.Message):
    __slots__ = ("arm", "spd_ratio")
    ARM_FIELD_NUMBER: _ClassVar[int]
    SPD_RATIO_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    spd_ratio: int
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., spd_ratio: _Optional[int] = ...) -> None: ...

class ManipulatorMiddleSetSpeedCartesianResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetSpeedJointRequest(_message.Message):
    __slots__ = ("arm", "spd_ratio")
    ARM_FIELD_NUMBER: _ClassVar[int]
    SPD_RATIO_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    spd_ratio: int
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., spd_ratio: _Optional[int] = ...) -> None: ...

class ManipulatorMiddleSetSpeedJointResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveCircularCartesianAbsRequest(_message.Message):
    __slots__ = ("arm", "car_point_r", "car_point_t")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_R_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_T_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point_r: CarPosWithElbow
    car_point_t: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point_r: _Optional[_Union[CarPosWithElbow, _Mapping]] = ..., car_point_t: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveCircularCartesianAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveCircularCartesianRelRequest(_message.Message):
    __slots__ = ("arm", "car_point_r", "car_point_t")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_R_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_T_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point_r: CarPosWithElbow
    car_point_t: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point_r: _Optional[_Union[CarPosWithElbow, _Mapping]] = ..., car_point_t: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveCircularCartesianRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleSetHomeRequest(_message.Message):
    __slots__ = ("arm", "joint_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    JOINT_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    joint_point: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., joint_point: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorMiddleSetHomeResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleGetHomeRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetHomeResponse(_message.Message):
    __slots__ = ("return_id", "joint_point")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    JOINT_POINT_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    joint_point: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., joint_point: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorMiddleGoHomeRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGoHomeResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleGetSpeedCartesianRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetSpeedCartesianResponse(_message.Message):
    __slots__ = ("return_id", "spd_ratio")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    SPD_RATIO_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    spd_ratio: int
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., spd_ratio: _Optional[int] = ...) -> None: ...

class ManipulatorMiddleGetSpeedJointRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetSpeedJointResponse(_message.Message):
    __slots__ = ("return_id", "spd_ratio")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    SPD_RATIO_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    spd_ratio: int
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., spd_ratio: _Optional[int] = ...) -> None: ...

class ManipulatorMiddleSetGraspForceRequest(_message.Message):
    __slots__ = ("arm", "force_ratio")
    ARM_FIELD_NUMBER: _ClassVar[int]
    FORCE_RATIO_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    force_ratio: int
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., force_ratio: _Optional[int] = ...) -> None: ...

class ManipulatorMiddleSetGraspForceResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleGetGraspForceRequest(_message.Message):
    __slots__ = ("arm",)
    ARM_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ...) -> None: ...

class ManipulatorMiddleGetGraspForceResponse(_message.Message):
    __slots__ = ("return_id", "force_ratio")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    FORCE_RATIO_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    force_ratio: int
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., force_ratio: _Optional[int] = ...) -> None: ...

class ManipulatorMiddleMoveLinearCartesianAbsCmdCycleRequest(_message.Message):
    __slots__ = ("arm", "car_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveLinearCartesianAbsCmdCycleResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveLinearCartesianRelCmdCycleRequest(_message.Message):
    __slots__ = ("arm", "car_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMoveLinearCartesianRelCmdCycleResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPCartesianAbsCmdCycleRequest(_message.Message):
    __slots__ = ("arm", "car_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPCartesianAbsCmdCycleResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPCartesianRelCmdCycleRequest(_message.Message):
    __slots__ = ("arm", "car_point")
    ARM_FIELD_NUMBER: _ClassVar[int]
    CAR_POINT_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    car_point: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., car_point: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPCartesianRelCmdCycleResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPJointAbsCmdCycleRequest(_message.Message):
    __slots__ = ("arm", "joint_points")
    ARM_FIELD_NUMBER: _ClassVar[int]
    JOINT_POINTS_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    joint_points: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., joint_points: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorMiddleMovePTPJointAbsCmdCycleResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class ManipulatorMiddleMovePTPJointRelCmdCycleRequest(_message.Message):
    __slots__ = ("arm", "joint_points")
    ARM_FIELD_NUMBER: _ClassVar[int]
    JOINT_POINTS_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    joint_points: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., joint_points: _Optional[_Iterable[float]] = ...) -> None: ...

class ManipulatorMiddleMovePTPJointRelCmdCycleResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorCommonServoOFFArmRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class DualManipulatorCommonServoOFFArmResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorCommonServoOFFHandRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class DualManipulatorCommonServoOFFHandResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorCommonServoONArmRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class DualManipulatorCommonServoONArmResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorCommonServoONHandRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class DualManipulatorCommonServoONHandResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleCloseGripperRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: int
    l_arm: int
    def __init__(self, r_arm: _Optional[int] = ..., l_arm: _Optional[int] = ...) -> None: ...

class DualManipulatorMiddleCloseGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleGetRelativePositionRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class DualManipulatorMiddleGetRelativePositionResponse(_message.Message):
    __slots__ = ("return_id", "rel_pos")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    REL_POS_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    rel_pos: HgMatrix
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., rel_pos: _Optional[_Union[HgMatrix, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMoveGripperRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: int
    l_arm: int
    def __init__(self, r_arm: _Optional[int] = ..., l_arm: _Optional[int] = ...) -> None: ...

class DualManipulatorMiddleMoveGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMoveLinearCartesianAbsRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: CarPosWithElbow
    l_arm: CarPosWithElbow
    def __init__(self, r_arm: _Optional[_Union[CarPosWithElbow, _Mapping]] = ..., l_arm: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMoveLinearCartesianAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMoveLinearCartesianRelRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: CarPosWithElbow
    l_arm: CarPosWithElbow
    def __init__(self, r_arm: _Optional[_Union[CarPosWithElbow, _Mapping]] = ..., l_arm: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMoveLinearCartesianRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMovePTPCartesianAbsRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: CarPosWithElbow
    l_arm: CarPosWithElbow
    def __init__(self, r_arm: _Optional[_Union[CarPosWithElbow, _Mapping]] = ..., l_arm: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMovePTPCartesianAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMovePTPCartesianRelRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: CarPosWithElbow
    l_arm: CarPosWithElbow
    def __init__(self, r_arm: _Optional[_Union[CarPosWithElbow, _Mapping]] = ..., l_arm: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMovePTPCartesianRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMovePTPJointAbsRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: _containers.RepeatedScalarFieldContainer[float]
    l_arm: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, r_arm: _Optional[_Iterable[float]] = ..., l_arm: _Optional[_Iterable[float]] = ...) -> None: ...

class DualManipulatorMiddleMovePTPJointAbsResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleMovePTPJointRelRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: _containers.RepeatedScalarFieldContainer[float]
    l_arm: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, r_arm: _Optional[_Iterable[float]] = ..., l_arm: _Optional[_Iterable[float]] = ...) -> None: ...

class DualManipulatorMiddleMovePTPJointRelResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class DualManipulatorMiddleOpenGripperRequest(_message.Message):
    __slots__ = ("r_arm", "l_arm")
    R_ARM_FIELD_NUMBER: _ClassVar[int]
    L_ARM_FIELD_NUMBER: _ClassVar[int]
    r_arm: int
    l_arm: int
    def __init__(self, r_arm: _Optional[int] = ..., l_arm: _Optional[int] = ...) -> None: ...

class DualManipulatorMiddleOpenGripperResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class StreamStateRequest(_message.Message):
    __slots__ = ("rate_hz",)
    RATE_HZ_FIELD_NUMBER: _ClassVar[int]
    rate_hz: float
    def __init__(self, rate_hz: _Optional[float] = ...) -> None: ...

class UnitJointPositions(_message.Message):
    __slots__ = ("unit", "position", "commanded", "names", "limits")
    UNIT_FIELD_NUMBER: _ClassVar[int]
    POSITION_FIELD_NUMBER: _ClassVar[int]
    COMMANDED_FIELD_NUMBER: _ClassVar[int]
    NAMES_FIELD_NUMBER: _ClassVar[int]
    LIMITS_FIELD_NUMBER: _ClassVar[int]
    unit: UnitType
    position: _containers.RepeatedScalarFieldContainer[float]
    commanded: _containers.RepeatedScalarFieldContainer[float]
    names: _containers.RepeatedScalarFieldContainer[str]
    limits: _containers.RepeatedCompositeFieldContainer[LimitValue]
    def __init__(self, unit: _Optional[_Union[UnitType, str]] = ..., position: _Optional[_Iterable[float]] = ..., commanded: _Optional[_Iterable[float]] = ..., names: _Optional[_Iterable[str]] = ..., limits: _Optional[_Iterable[_Union[LimitValue, _Mapping]]] = ...) -> None: ...

class ControlPointPose(_message.Message):
    __slots__ = ("arm", "pose")
    ARM_FIELD_NUMBER: _ClassVar[int]
    POSE_FIELD_NUMBER: _ClassVar[int]
    arm: RightLeft
    pose: CarPosWithElbow
    def __init__(self, arm: _Optional[_Union[RightLeft, str]] = ..., pose: _Optional[_Union[CarPosWithElbow, _Mapping]] = ...) -> None: ...

class LatencyStats(_message.Message):
    __slots__ = ("p50_us", "p99_us", "max_us")
    P50_US_FIELD_NUMBER: _ClassVar[int]
    P99_US_FIELD_NUMBER: _ClassVar[int]
    MAX_US_FIELD_NUMBER: _ClassVar[int]
    p50_us: float
    p99_us: float
    max_us: float
    def __init__(self, p50_us: _Optional[float] = ..., p99_us: _Optional[float] = ..., max_us: _Optional[float] = ...) -> None: ...

class LoopStats(_message.Message):
    __slots__ = ("cycles", "overruns", "compute", "wake_latency")
    CYCLES_FIELD_NUMBER: _ClassVar[int]
    OVERRUNS_FIELD_NUMBER: _ClassVar[int]
    COMPUTE_FIELD_NUMBER: _ClassVar[int]
    WAKE_LATENCY_FIELD_NUMBER: _ClassVar[int]
    cycles: int
    overruns: int
    compute: LatencyStats
    wake_latency: LatencyStats
    def __init__(self, cycles: _Optional[int] = ..., overruns: _Optional[int] = ..., compute: _Optional[_Union[LatencyStats, _Mapping]] = ..., wake_latency: _Optional[_Union[LatencyStats, _Mapping]] = ...) -> None: ...

class StateSample(_message.Message):
    __slots__ = ("sequence", "stamp_s", "status_id", "status_message", "joints", "control_points", "alarms", "loop", "wall_time_s", "motion")
    SEQUENCE_FIELD_NUMBER: _ClassVar[int]
    STAMP_S_FIELD_NUMBER: _ClassVar[int]
    STATUS_ID_FIELD_NUMBER: _ClassVar[int]
    STATUS_MESSAGE_FIELD_NUMBER: _ClassVar[int]
    JOINTS_FIELD_NUMBER: _ClassVar[int]
    CONTROL_POINTS_FIELD_NUMBER: _ClassVar[int]
    ALARMS_FIELD_NUMBER: _ClassVar[int]
    LOOP_FIELD_NUMBER: _ClassVar[int]
    WALL_TIME_S_FIELD_NUMBER: _ClassVar[int]
    MOTION_FIELD_NUMBER: _ClassVar[int]
    sequence: int
    stamp_s: float
    status_id: int
    status_message: str
    joints: _containers.RepeatedCompositeFieldContainer[UnitJointPositions]
    control_points: _containers.RepeatedCompositeFieldContainer[ControlPointPose]
    alarms: _containers.RepeatedCompositeFieldContainer[Alarm]
    loop: LoopStats
    wall_time_s: float
    motion: MotionStatus
    def __init__(self, sequence: _Optional[int] = ..., stamp_s: _Optional[float] = ..., status_id: _Optional[int] = ..., status_message: _Optional[str] = ..., joints: _Optional[_Iterable[_Union[UnitJointPositions, _Mapping]]] = ..., control_points: _Optional[_Iterable[_Union[ControlPointPose, _Mapping]]] = ..., alarms: _Optional[_Iterable[_Union[Alarm, _Mapping]]] = ..., loop: _Optional[_Union[LoopStats, _Mapping]] = ..., wall_time_s: _Optional[float] = ..., motion: _Optional[_Union[MotionStatus, _Mapping]] = ...) -> None: ...

class MotionStatus(_message.Message):
    __slots__ = ("active", "queued", "queue_depth", "started", "finished")
    ACTIVE_FIELD_NUMBER: _ClassVar[int]
    QUEUED_FIELD_NUMBER: _ClassVar[int]
    QUEUE_DEPTH_FIELD_NUMBER: _ClassVar[int]
    STARTED_FIELD_NUMBER: _ClassVar[int]
    FINISHED_FIELD_NUMBER: _ClassVar[int]
    active: bool
    queued: int
    queue_depth: int
    started: int
    finished: int
    def __init__(self, active: _Optional[bool] = ..., queued: _Optional[int] = ..., queue_depth: _Optional[int] = ..., started: _Optional[int] = ..., finished: _Optional[int] = ...) -> None: ...

class TestingInjectFaultRequest(_message.Message):
    __slots__ = ("kind", "target", "params")
    class ParamsEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: str
        def __init__(self, key: _Optional[str] = ..., value: _Optional[str] = ...) -> None: ...
    KIND_FIELD_NUMBER: _ClassVar[int]
    TARGET_FIELD_NUMBER: _ClassVar[int]
    PARAMS_FIELD_NUMBER: _ClassVar[int]
    kind: str
    target: str
    params: _containers.ScalarMap[str, str]
    def __init__(self, kind: _Optional[str] = ..., target: _Optional[str] = ..., params: _Optional[_Mapping[str, str]] = ...) -> None: ...

class TestingInjectFaultResponse(_message.Message):
    __slots__ = ("return_id",)
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ...) -> None: ...

class TestingClearFaultsRequest(_message.Message):
    __slots__ = ("kind", "target")
    KIND_FIELD_NUMBER: _ClassVar[int]
    TARGET_FIELD_NUMBER: _ClassVar[int]
    kind: str
    target: str
    def __init__(self, kind: _Optional[str] = ..., target: _Optional[str] = ...) -> None: ...

class TestingClearFaultsResponse(_message.Message):
    __slots__ = ("return_id", "cleared")
    RETURN_ID_FIELD_NUMBER: _ClassVar[int]
    CLEARED_FIELD_NUMBER: _ClassVar[int]
    return_id: ReturnID
    cleared: int
    def __init__(self, return_id: _Optional[_Union[ReturnID, _Mapping]] = ..., cleared: _Optional[int] = ...) -> None: ...
