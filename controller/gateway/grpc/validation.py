"""Every numeric field of every request, bounded before the servicer sees it.

:func:`check_request` walks a request message by its descriptor (so a field added to the
proto is covered without a change here) and checks each floating-point value against the
bound of its quantity (:mod:`controller.bounds`): finite, and not beyond the bound. Repeated
fields hold at most :data:`~controller.bounds.MAX_REPEATED` values (HgMatrix exactly 12).
Fields the robot does not use are checked too: a NaN in ``lumbar_rx`` of a robot without
a waist is as invalid as anywhere else. The servicer then checks what depends on the robot
(joint counts and ranges, hardware speeds, reach, vehicle workspace).

Which quantity a field holds is decided by its containing message and name (:data:`FIELDS`,
:data:`LIMIT_FIELDS`); a field the tables do not name is a plain :data:`~controller.bounds.NUMBER`
(test_validation asserts the tables name every field of every request).
"""

from __future__ import annotations

from typing import Any

from google.protobuf.descriptor import FieldDescriptor
from google.protobuf.message import Message

from controller.bounds import (
    ACCEL_TIME,
    ANGLE,
    ANGULAR_ACCEL,
    ANGULAR_SPEED,
    LENGTH,
    LINEAR_ACCEL,
    LINEAR_SPEED,
    MAX_REPEATED,
    NUMBER,
    ROTATION_ENTRY,
    TIME,
    Quantity,
    bounded,
)
from controller.errors import ArgumentError
from controller.vocabulary import UnitType

_DOUBLE = (FieldDescriptor.TYPE_DOUBLE, FieldDescriptor.TYPE_FLOAT)
_VEHICLE = int(UnitType.VEHICLE)  #: its value on the wire

_REDUNDANT_POS = {
    "elbow": ANGLE,
    "lumbar_rx": ANGLE,
    "lumbar_ry": ANGLE,
    "lumbar_rz": ANGLE,
    "vehicle_x": LENGTH,
    "vehicle_y": LENGTH,
    "vehicle_theta": ANGLE,
}

#: Quantity of each floating-point field, by containing message (short name) and field.
FIELDS: dict[str, dict[str, Quantity]] = {
    "CarPosWithElbow": {"elbow": ANGLE},
    "CartesianSpeed": {"translation": LINEAR_SPEED, "rotation": ANGULAR_SPEED},
    "CartesianAccel": {"translation": LINEAR_ACCEL, "rotation": ANGULAR_ACCEL},
    "RedundantPos": _REDUNDANT_POS,
    "RedundantSpeed": {
        "elbow": ANGULAR_SPEED,
        "lumbar_rx": ANGULAR_SPEED,
        "lumbar_ry": ANGULAR_SPEED,
        "lumbar_rz": ANGULAR_SPEED,
        "vehicle_translation": LINEAR_SPEED,
        "vehicle_rotation": ANGULAR_SPEED,
    },
    "RedundantAccel": {
        "elbow": ANGULAR_ACCEL,
        "lumbar_rx": ANGULAR_ACCEL,
        "lumbar_ry": ANGULAR_ACCEL,
        "lumbar_rz": ANGULAR_ACCEL,
        "vehicle_translation": LINEAR_ACCEL,
        "vehicle_rotation": ANGULAR_ACCEL,
    },
    "MovePTPCartesianAbsRequest": {"time": TIME},
    "MovePTPCartesianRelRequest": {"time": TIME},
    "ManipulatorMiddleSetAccelTimeCartesianRequest": {"acl_time": ACCEL_TIME},
    "ManipulatorMiddleSetAccelTimeJointRequest": {"acl_time": ACCEL_TIME},
    "ManipulatorMiddleSetMinAccelTimeCartesianRequest": {"acl_time": ACCEL_TIME},
    "ManipulatorMiddleSetMinAccelTimeJointRequest": {"acl_time": ACCEL_TIME},
    "ManipulatorMiddleSetMaxSpeedJointRequest": {"speed": ANGULAR_SPEED},
    "ManipulatorMiddleMovePTPJointAbsRequest": {"joint_points": ANGLE},
    "ManipulatorMiddleMovePTPJointRelRequest": {"joint_points": ANGLE},
    "ManipulatorMiddleMovePTPJointAbsCmdCycleRequest": {"joint_points": ANGLE},
    "ManipulatorMiddleMovePTPJointRelCmdCycleRequest": {"joint_points": ANGLE},
    "ManipulatorMiddleSetHomeRequest": {"joint_point": ANGLE},
    "DualManipulatorMiddleMovePTPJointAbsRequest": {"r_arm": ANGLE, "l_arm": ANGLE},
    "DualManipulatorMiddleMovePTPJointRelRequest": {"r_arm": ANGLE, "l_arm": ANGLE},
}

#: Quantity of a LimitValue (upper, lower), by the field that holds it.
LIMIT_FIELDS: dict[str, Quantity] = {
    "right_elbow": ANGLE,
    "left_elbow": ANGLE,
    "lumbar_rx": ANGLE,
    "lumbar_ry": ANGLE,
    "lumbar_rz": ANGLE,
    "vehicle_x": LENGTH,
    "vehicle_y": LENGTH,
    "vehicle_theta": ANGLE,
    "soft_limit": ANGLE,
    "x_limit": LENGTH,
    "y_limit": LENGTH,
    "z_limit": LENGTH,
}

#: moveUnit*: per-value quantities of the repeated fields, arm/waist (deg) or VEHICLE.
_UNIT_FIELDS = {
    "abs_pos": (ANGLE, (LENGTH, LENGTH, ANGLE)),
    "rel_pos": (ANGLE, (LENGTH, LENGTH, ANGLE)),
    "speed": (ANGULAR_SPEED, (LINEAR_SPEED, ANGULAR_SPEED)),
    "accel": (ANGULAR_ACCEL, (LINEAR_ACCEL, ANGULAR_ACCEL)),
}
_UNIT_REQUESTS = ("MoveUnitAbsRequest", "MoveUnitRelRequest")


def check_request(request: Message) -> None:
    """Raise ArgumentError (VALUE_ERR) naming the first field out of its bound."""
    _walk(request, "", None)


def quantity_of(message: str, field: str, limit_of: str | None) -> Quantity | None:
    """The quantity a floating-point field holds (None: the tables do not name it)."""
    if message == "LimitValue" and limit_of is not None:
        return LIMIT_FIELDS.get(limit_of)
    if message in _UNIT_REQUESTS and field in _UNIT_FIELDS:
        return _UNIT_FIELDS[field][0]
    return FIELDS.get(message, {}).get(field)


def _walk(msg: Message, prefix: str, limit_of: str | None) -> None:
    message = msg.DESCRIPTOR.name
    for fd, value in msg.ListFields():
        name = f"{prefix}{fd.name}"
        repeated = fd.is_repeated
        if repeated:
            _check_length(message, fd.name, name, len(value))
        if fd.type == FieldDescriptor.TYPE_MESSAGE and fd.message_type.GetOptions().map_entry:
            continue  # map<string, string> (Testing params): no numbers, read by the servicer
        if fd.type == FieldDescriptor.TYPE_MESSAGE:
            parts = value if repeated else [value]
            for i, part in enumerate(parts):
                sub = f"{name}[{i}]." if repeated else f"{name}."
                _walk(part, sub, fd.name)
        elif fd.type in _DOUBLE:
            values = list(value) if repeated else [value]
            for i, x in enumerate(values):
                shown = f"{name}[{i}]" if repeated else name
                bounded(float(x), _value_quantity(msg, message, fd.name, i, limit_of), shown)


def _value_quantity(msg: Any, message: str, field: str, i: int, limit_of: str | None) -> Quantity:
    if message == "HgMatrix":
        return LENGTH if i % 4 == 3 else ROTATION_ENTRY
    if message in _UNIT_REQUESTS and field in _UNIT_FIELDS:
        joint, vehicle = _UNIT_FIELDS[field]
        if msg.unit == _VEHICLE and i < len(vehicle):
            return vehicle[i]
        return joint
    return quantity_of(message, field, limit_of) or NUMBER


def _check_length(message: str, field: str, name: str, n: int) -> None:
    if message == "HgMatrix":
        if n != 12:
            raise ArgumentError(f"{name}: expected 12 numbers (3x4 row-major [R | p]), got {n}")
    elif n > MAX_REPEATED:
        raise ArgumentError(f"{name}: {n} values is too many (at most {MAX_REPEATED})")
