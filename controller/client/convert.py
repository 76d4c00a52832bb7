"""Conversion between Python values and imotion.v1 messages, driven by the proto descriptors.

Inputs are lenient about form and strict about meaning: a struct may be its NamedTuple, a
plain sequence in field order, a mapping by field name (lowerCamel or snake_case) or the proto
message itself; an HgMatrix is anything :func:`controller.client.poses.hg_matrix` accepts; an
enum is its Python enum, its number or its name (case-insensitive, a unique prefix will do:
``"base"`` -> ``BASE_FRAME``). Values are not range-checked beyond what the wire format needs:
NaN, 0 % or a non-rotation matrix reach the daemon, which answers VALUE_ERR with the reason.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from google.protobuf.descriptor import Descriptor, EnumDescriptor, FieldDescriptor
from google.protobuf.message import Message

from controller.client.errors import ArgumentError
from controller.client.poses import hg_matrix
from controller.client.types import ENUM_TYPES, MESSAGE_TYPES
from controller.rpc import imotion_pb2

HG_MATRIX = "HgMatrix"

_INT_RANGES = {
    FieldDescriptor.TYPE_INT32: (-(2**31), 2**31 - 1),
    FieldDescriptor.TYPE_INT64: (-(2**63), 2**63 - 1),
    FieldDescriptor.TYPE_UINT32: (0, 2**32 - 1),
    FieldDescriptor.TYPE_UINT64: (0, 2**64 - 1),
}
_FLOATS = (FieldDescriptor.TYPE_DOUBLE, FieldDescriptor.TYPE_FLOAT)


def message_class(descriptor: Descriptor) -> type[Message]:
    """The generated class of an imotion.v1 message."""
    cls: type[Message] = getattr(imotion_pb2, descriptor.name)
    return cls


def resolve_enum(descriptor: EnumDescriptor, value: object, where: str) -> int:
    """The number of an enum value given as enum member, number or (prefix of a) name."""
    names = [v.name for v in descriptor.values]
    if isinstance(value, enum.Enum):
        value = value.name
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
        if int(value) in descriptor.values_by_number:
            return int(value)
    elif isinstance(value, str):
        text = value.strip().upper()
        if text in descriptor.values_by_name:
            return int(descriptor.values_by_name[text].number)
        matches = [n for n in names if n.startswith(text)] if text else []
        if len(matches) == 1:
            return int(descriptor.values_by_name[matches[0]].number)
    raise ArgumentError(f"{where}: {value!r} is not a {descriptor.name} ({', '.join(names)})")


def _scalar(field: FieldDescriptor, value: object, where: str) -> Any:
    kind = field.type
    if kind == FieldDescriptor.TYPE_ENUM:
        return resolve_enum(field.enum_type, value, where)
    if kind == FieldDescriptor.TYPE_BOOL:
        if isinstance(value, (bool, np.bool_)) or (
            isinstance(value, (int, np.integer)) and int(value) in (0, 1)
        ):
            return bool(value)
        raise ArgumentError(f"{where}: expected a boolean, got {value!r}")
    if kind == FieldDescriptor.TYPE_STRING:
        if isinstance(value, str):
            return value
        raise ArgumentError(f"{where}: expected a string, got {value!r}")
    if isinstance(value, (str, bytes, bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise ArgumentError(f"{where}: expected a number, got {value!r}")
    if kind in _FLOATS:
        return float(value)
    number = float(value)
    if not math.isfinite(number) or number != int(number):
        raise ArgumentError(f"{where}: expected a whole number, got {value!r}")
    low, high = _INT_RANGES[kind]
    if not low <= int(number) <= high:
        raise ArgumentError(f"{where}: {int(number)} is outside {low}..{high}")
    return int(number)


def to_message(descriptor: Descriptor, value: object, where: str) -> Message:
    """``value`` as a message of type ``descriptor`` (see the module docstring for forms)."""
    cls = message_class(descriptor)
    if isinstance(value, Message):
        if value.DESCRIPTOR.full_name != descriptor.full_name:
            raise ArgumentError(
                f"{where}: expected {descriptor.name}, got {value.DESCRIPTOR.name} message"
            )
        return value
    if descriptor.name == HG_MATRIX:
        try:
            return cls(m=[float(x) for x in hg_matrix(value, where).ravel()])
        except ValueError as exc:
            raise ArgumentError(str(exc)) from None
    fields = list(descriptor.fields)
    if isinstance(value, Mapping):
        by_name = {f.json_name: f for f in fields} | {f.name: f for f in fields}
        unknown = [k for k in value if k not in by_name]
        if unknown:
            known = ", ".join(f.json_name for f in fields)
            raise ArgumentError(
                f"{where}: unknown field {unknown[0]!r} of {descriptor.name} ({known})"
            )
        items = [(by_name[k], v) for k, v in value.items()]
    elif isinstance(value, Iterable) and not isinstance(value, (str, bytes)):
        values = list(value)
        if len(values) != len(fields):
            names = ", ".join(f.json_name for f in fields)
            raise ArgumentError(
                f"{where}: {descriptor.name} needs {len(fields)} values ({names}), "
                f"got {len(values)}"
            )
        items = list(zip(fields, values, strict=True))
    else:
        raise ArgumentError(f"{where}: expected a {descriptor.name}, got {value!r}")
    return cls(**{f.name: to_field(f, v, f"{where}.{f.json_name}") for f, v in items})


def to_field(field: FieldDescriptor, value: object, where: str) -> Any:
    """A Python value converted for assignment to ``field`` of a message constructor."""

    def single(item: object, at: str) -> Any:
        if field.type == FieldDescriptor.TYPE_MESSAGE:
            return to_message(field.message_type, item, at)
        return _scalar(field, item, at)

    if field.is_repeated:
        scalar_array = isinstance(value, np.ndarray) and value.ndim == 0
        if (
            scalar_array
            or isinstance(value, (str, bytes, Mapping))
            or not isinstance(value, Iterable)
        ):
            raise ArgumentError(f"{where}: expected a sequence, got {value!r}")
        return [single(item, f"{where}[{i}]") for i, item in enumerate(value)]
    return single(value, where)


def from_message(message: Message) -> Any:
    """A message as its Python form: HgMatrix -> 3 x 4 array, structs -> NamedTuples."""
    descriptor = message.DESCRIPTOR
    if descriptor.name == HG_MATRIX:
        m = np.array(message.m, dtype=float)
        return m.reshape(3, 4) if m.size == 12 else m
    values = [from_field(f, getattr(message, f.name)) for f in descriptor.fields]
    cls = MESSAGE_TYPES.get(descriptor.name)
    if cls is None:
        return {f.json_name: v for f, v in zip(descriptor.fields, values, strict=True)}
    return cls(*values)


def from_field(field: FieldDescriptor, value: Any) -> Any:
    """The Python form of a field's value (lists for repeated fields)."""
    if field.is_repeated:
        return [_from_single(field, v) for v in value]
    return _from_single(field, value)


def _from_single(field: FieldDescriptor, value: Any) -> Any:
    if field.type == FieldDescriptor.TYPE_MESSAGE:
        return from_message(value)
    if field.type == FieldDescriptor.TYPE_ENUM:
        cls = ENUM_TYPES.get(field.enum_type.name)
        if cls is not None and value in cls._value2member_map_:
            return cls(value)
        return int(value)
    return value
