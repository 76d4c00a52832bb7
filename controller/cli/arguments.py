"""Command-line arguments of an operation, derived from its request message.

Rules (the same for every operation; see docs/client.md):

- Each request field ``F`` (original lowerCamel name) is an option ``--F`` taking the field's
  values, or is given positionally: fields not given as options take the positional values in
  field order.
- Value layouts: a number, enum name (a unique prefix will do: ``base`` = ``BASE_FRAME``) or
  boolean (true/false/1/0/yes/no/on/off) is one word; a struct is its fields' values in order,
  flattened (``CartesianSpeed`` = TRANSLATION ROTATION); an ``HgMatrix`` is six numbers
  X Y Z ROLL PITCH YAW [mm, deg] (roll-pitch-yaw about fixed x, y, z); a list takes every
  value up to the end or up to a lone ``,``. Boolean fields default to false.
- Pose fields (HgMatrix, CarPosWithElbow) may also be given in parts: ``--xyz X Y Z``,
  ``--rpy R P Y`` (each defaults to zeros), ``--matrix`` + 12 numbers (row-major ``[R | p]``)
  and, for CarPosWithElbow, ``--elbow DEG`` and ``--structFlag N`` (default 0). With several
  pose fields the parts carry the field name: ``--rArm-xyz``, ``--carPointT-rpy``.
- Aliases: ``--side`` for the RightLeft field, ``--frame`` for a frame field, ``--unit`` for
  the UnitType field.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import Any

from google.protobuf.descriptor import Descriptor, FieldDescriptor, MethodDescriptor

from controller.cli.protodoc import comment
from controller.client.convert import resolve_enum
from controller.client.errors import ArgumentError
from controller.client.poses import pose
from controller.client.service import operation_name
from controller.rpc import imotion_pb2

HG = "HgMatrix"
CAR_POS = "CarPosWithElbow"
POSE_TYPES = (HG, CAR_POS)
SEPARATOR = ","
_TRUE = {"true", "1", "yes", "on", "t", "y"}
_FALSE = {"false", "0", "no", "off", "f", "n"}
_ALIASES = {"RightLeft": "--side", "FrameType": "--frame", "CommandFrameType": "--frame"}
_ALIASES["UnitType"] = "--unit"

#: Options of the command line itself (never taken by an operation's argument).
RESERVED = {"--address", "--token", "--tls-ca", "--timeout", "--json", "--wait"}
RESERVED |= {"--wait-timeout", "--version", "--help"}

#: How arguments are given, for ``imotion OPERATION --help`` (docs/client.md has the same).
RULES = """\
how to give the arguments:
  Each field is --FIELD VALUES, or positional: fields not given as options take the
  positional values in field order. A struct is its numbers in field order, or its parts by
  name (--elbow -30 --elbow-speed 20: parts not given are 0, except in an absolute target).
  A pose (HgMatrix) is X Y Z ROLL PITCH YAW (mm, deg; roll-pitch-yaw about fixed x, y, z),
  or --xyz X Y Z / --rpy R P Y (each 0 when left out) or --matrix with 12 numbers
  (row-major [R | p], p in mm); a CarPosWithElbow also takes --elbow DEG, --structFlag N.
  A list takes the values up to the end or up to a lone ",". Enum names are
  case-insensitive, a unique prefix will do (base = BASE_FRAME). Booleans:
  true/false/1/0/yes/no/on/off, false when left out. --side, --frame and --unit stand for
  the RightLeft, frame and UnitType fields.
"""

#: Command groups: name -> (services, request fields bound by the group).
GROUPS: dict[str, tuple[list[str], tuple[str, ...]]] = {
    "integrated": (["IntegratedMotion"], ()),
    "arm": (["ManipulatorCommon", "ManipulatorMiddle"], ("arm",)),
    "dual": (["DualManipulatorCommon", "DualManipulatorMiddle"], ()),
}


def message_arity(d: Descriptor) -> int:
    """Number of words of a struct in its flattened layout."""
    if d.name == HG:
        return 6
    return sum(field_arity(f) or 0 for f in d.fields)


def field_arity(f: FieldDescriptor) -> int | None:
    """Words of one field value; None for a list (variable)."""
    if f.is_repeated:
        return None
    if f.type == FieldDescriptor.TYPE_MESSAGE:
        return message_arity(f.message_type)
    return 1


def layout(f: FieldDescriptor) -> str:
    """The words a field takes, for usage texts (``TRANSLATION ROTATION``)."""
    if f.type == FieldDescriptor.TYPE_MESSAGE:
        d = f.message_type
        words = "X Y Z ROLL PITCH YAW" if d.name == HG else " ".join(layout(s) for s in d.fields)
        return f"[{words}] ..." if f.is_repeated else words
    if f.type == FieldDescriptor.TYPE_ENUM:
        word = "|".join(v.name for v in f.enum_type.values)
    elif f.type == FieldDescriptor.TYPE_BOOL:
        word = "true|false"
    else:
        word = f.json_name.upper()
    return f"{word} ..." if f.is_repeated else word


def units(d: Descriptor, hint: str = "") -> str:
    """Units of a struct's fields, from the .proto comments (``translation mm/s, ...``);
    ``hint``: the unit of the field holding the struct, for fields without their own."""
    if d.name == HG:
        return "x y z mm, roll pitch yaw deg"
    parts = []
    for f in d.fields:
        text = comment(d.name, f.name).split(";")[0].strip()
        if f.type == FieldDescriptor.TYPE_MESSAGE:
            inner = units(f.message_type, text or hint)
            parts.append(f"{f.json_name}: {inner}" if inner else f"{f.json_name} {text}")
        elif text or hint:
            parts.append(f"{f.json_name} {text or hint}")
    return ", ".join(parts)


@dataclass(frozen=True)
class Leaf:
    """One number (or boolean) of a struct argument, given by name: ``--elbow-speed 20``."""

    field: FieldDescriptor  #: the request field holding the struct
    path: tuple[FieldDescriptor, ...]  #: struct fields down to the leaf
    unit: str

    @property
    def key(self) -> str:
        return "-".join(p.json_name for p in self.path)

    @property
    def option(self) -> str:
        return f"--{self.key}-{self.field.json_name}"

    @property
    def dest(self) -> str:
        return f"l_{self.field.name}__{'__'.join(p.name for p in self.path)}"


def leaves(f: FieldDescriptor) -> list[Leaf]:
    """The named parts of a struct field (none for lists, poses and plain values)."""
    if not is_struct(f):
        return []
    out: list[Leaf] = []

    def walk(d: Descriptor, path: tuple[FieldDescriptor, ...], hint: str) -> None:
        for sub in d.fields:
            text = comment(d.name, sub.name).split(";")[0].strip() or hint
            if sub.type == FieldDescriptor.TYPE_MESSAGE:
                walk(sub.message_type, (*path, sub), text)
            elif not sub.is_repeated:
                out.append(Leaf(f, (*path, sub), text))

    walk(f.message_type, (), comment(f.containing_type.name, f.name).split(";")[0].strip())
    return out


def is_struct(f: FieldDescriptor) -> bool:
    """A single struct other than a pose (those have --xyz/--rpy parts)."""
    return (
        f.type == FieldDescriptor.TYPE_MESSAGE
        and not f.is_repeated
        and f.message_type.name not in POSE_TYPES
    )


@dataclass
class CliOperation:
    """One operation as the CLI sees it."""

    group: str
    service: str
    method: MethodDescriptor
    fields: list[FieldDescriptor]
    pose_fields: list[FieldDescriptor] = field(default_factory=list)

    @property
    def name(self) -> str:
        return operation_name(self.method.name)

    def pose_prefix(self, f: FieldDescriptor) -> str:
        return "--" if len(self.pose_fields) == 1 else f"--{f.json_name}-"

    def usage(self) -> str:
        words = []
        for f in self.fields:
            text = f"{f.json_name}: {layout(f)}"
            words.append(f"[{text}]" if f.type == FieldDescriptor.TYPE_BOOL else f"<{text}>")
        return " ".join(words)


def operations(group: str) -> dict[str, CliOperation]:
    """The operations of a command group, by original name, in proto order."""
    services, bound = GROUPS[group]
    out: dict[str, CliOperation] = {}
    for service in services:
        for method in imotion_pb2.DESCRIPTOR.services_by_name[service].methods:
            fields = [f for f in method.input_type.fields if f.name not in bound]
            poses = [
                f
                for f in fields
                if not f.is_repeated
                and f.type == FieldDescriptor.TYPE_MESSAGE
                and f.message_type.name in POSE_TYPES
            ]
            op = CliOperation(group, service, method, fields, poses)
            out[op.name] = op
    return out


def find(group: str, name: str) -> CliOperation | None:
    """An operation by exact name, else by a unique case-insensitive match."""
    ops = operations(group)
    if name in ops:
        return ops[name]
    matches = [op for n, op in ops.items() if n.lower() == name.lower()]
    return matches[0] if len(matches) == 1 else None


def add_arguments(parser: argparse.ArgumentParser, op: CliOperation) -> None:
    """Options for every field of ``op`` plus the positional ``values``."""
    request = op.method.input_type.name
    for f in op.fields:
        names = [f"--{f.json_name}"]
        alias = _ALIASES.get(f.enum_type.name) if f.type == FieldDescriptor.TYPE_ENUM else None
        if alias and alias not in names:
            names.append(alias)
        arity = field_arity(f)
        text = comment(request, f.name)
        if f.type == FieldDescriptor.TYPE_MESSAGE:
            unit_text = units(f.message_type, text.split(";")[0].strip())
            text = f"{text} ({unit_text})" if text else unit_text
        if f.type == FieldDescriptor.TYPE_BOOL:
            text = f"{text} (default false)" if text else "default false"
        parser.add_argument(
            *names,
            dest=f"f_{f.name}",
            nargs=arity if arity and arity > 1 else ("+" if arity is None else None),
            metavar=tuple(layout(f).split()) if arity and arity > 1 else layout(f),
            help=_escape(text) or None,
        )
    for f in op.pose_fields:
        prefix = op.pose_prefix(f)
        group = parser.add_argument_group(f"{f.json_name} in parts")
        for part, nargs, kind, metavar, text in _POSE_PARTS:
            if part in ("elbow", "structFlag") and f.message_type.name != CAR_POS:
                continue
            group.add_argument(
                f"{prefix}{part}",
                dest=f"p_{f.name}_{part}",
                nargs=nargs,
                type=_integer if kind is int else _number,
                metavar=metavar,
                help=text,
            )
    for f in op.fields:
        _add_leaves(parser, op, f)
    parser.add_argument("values", nargs="*", metavar="VALUE", help="fields given positionally")


def _add_leaves(parser: argparse.ArgumentParser, op: CliOperation, f: FieldDescriptor) -> None:
    parts = leaves(f)
    if not parts:
        return
    group = parser.add_argument_group(
        f"{f.json_name} by name",
        "parts not given are 0 (false)"
        + (", except in an absolute target: give them all" if is_target(op, f) else ""),
    )
    for leaf in parts:
        names = [leaf.option]
        short = f"--{leaf.key}"  # the first struct with this part also answers to --part
        first = next(g for g in op.fields if any(x.key == leaf.key for x in leaves(g)))
        if first is f and short not in parser._option_string_actions and short not in RESERVED:
            names.insert(0, short)
        kind = leaf.path[-1].type
        word = "true|false" if kind == FieldDescriptor.TYPE_BOOL else "N"
        if leaf.unit and " " not in leaf.unit and kind != FieldDescriptor.TYPE_BOOL:
            word = leaf.unit.upper()
        group.add_argument(
            *names,
            dest=leaf.dest,
            metavar=word,
            help=_escape(
                f"{f.json_name}.{leaf.key.replace('-', '.')}"
                + (f", {leaf.unit}" if leaf.unit else "")
            ),
        )


def _escape(text: str) -> str:
    """argparse help texts are %-templates: a literal % (ratios) must be doubled."""
    return text.replace("%", "%%")


def is_target(op: CliOperation, f: FieldDescriptor) -> bool:
    """The first struct of an absolute move (every part must be given: a part left out
    would silently become a target of 0)."""
    structs = [g for g in op.fields if is_struct(g)]
    return op.name.endswith("Abs") and bool(structs) and structs[0] is f


#: Pose parts: (name, nargs, type, metavar, help).
_POSE_PARTS: list[tuple[str, int | None, type, Any, str]] = [
    ("xyz", 3, float, ("X", "Y", "Z"), "position, mm (default 0 0 0)"),
    ("rpy", 3, float, ("ROLL", "PITCH", "YAW"), "deg, about fixed x, y, z (default 0 0 0)"),
    ("matrix", 12, float, "M", "12 numbers, row-major [R | p], p in mm"),
    ("elbow", None, float, "DEG", "elbow angle, deg (default 0)"),
    ("structFlag", None, int, "N", "configuration flags (default 0)"),
]


def _number(token: str) -> float:
    try:
        return float(token)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{token!r} is not a number") from None


def _integer(token: str) -> int:
    try:
        return int(token, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{token!r} is not a whole number") from None


def bind(op: CliOperation, ns: argparse.Namespace) -> dict[str, Any]:
    """The operation's arguments (by lowerCamel name) from the parsed command line."""
    values: dict[str, Any] = {}
    pending: list[FieldDescriptor] = []
    for f in op.fields:
        given = getattr(ns, f"f_{f.name}", None)
        parts = {
            part: getattr(ns, f"p_{f.name}_{part}", None)
            for part in ("xyz", "rpy", "matrix", "elbow", "structFlag")
        }
        parts = {k: v for k, v in parts.items() if v is not None}
        named: dict[Leaf, str] = {
            leaf: getattr(ns, leaf.dest)
            for leaf in leaves(f)
            if getattr(ns, leaf.dest, None) is not None
        }
        if given is not None and (parts or named):
            raise ArgumentError(f"{f.json_name}: give --{f.json_name} or its parts, not both")
        if given is not None:
            tokens = given if isinstance(given, list) else [given]
            values[f.json_name] = parse_field(f, tokens, f.json_name)
        elif parts:
            values[f.json_name] = _from_parts(f, parts)
        elif named:
            values[f.json_name] = _from_leaves(op, f, named)
        else:
            pending.append(f)
    tokens = list(ns.values or [])
    for f in pending:
        while tokens and tokens[0] == SEPARATOR:
            tokens.pop(0)
        arity = field_arity(f)
        if arity is None:
            end = tokens.index(SEPARATOR) if SEPARATOR in tokens else len(tokens)
            taken, tokens = tokens[:end], tokens[end:]
            if not taken:
                raise _missing(op, f)
        elif len(tokens) >= arity:
            taken, tokens = tokens[:arity], tokens[arity:]
        elif not tokens and f.type == FieldDescriptor.TYPE_BOOL:
            values[f.json_name] = False
            continue
        else:
            raise _missing(op, f, len(tokens))
        values[f.json_name] = parse_field(f, taken, f.json_name)
    extra = [t for t in tokens if t != SEPARATOR]
    if extra:
        raise ArgumentError(f"unexpected extra values: {' '.join(extra)}")
    return values


def _missing(op: CliOperation, f: FieldDescriptor, have: int = 0) -> ArgumentError:
    got = f" (only {have} value{'s' if have != 1 else ''} left)" if have else ""
    hint = f"--{f.json_name} or positionally"
    if f in op.pose_fields:
        hint += f", or {op.pose_prefix(f)}xyz/{op.pose_prefix(f)}rpy/{op.pose_prefix(f)}matrix"
    return ArgumentError(f"missing {f.json_name}: {layout(f)}{got}; give it as {hint}")


def _from_leaves(op: CliOperation, f: FieldDescriptor, named: dict[Leaf, str]) -> Any:
    """A struct from its parts given by name; the others 0 / false (see :func:`is_target`)."""
    missing = [leaf.option for leaf in leaves(f) if leaf not in named]
    if missing and is_target(op, f):
        raise ArgumentError(
            f"{f.json_name} is an absolute target: give every part, missing {' '.join(missing)}"
        )
    out: dict[str, Any] = {}
    for leaf in leaves(f):
        node = out
        for p in leaf.path[:-1]:
            node = node.setdefault(p.json_name, {})
        last = leaf.path[-1]
        if leaf in named:
            where = f"{f.json_name}.{leaf.key.replace('-', '.')}"
            node[last.json_name] = parse_scalar(last, named[leaf], where)
        else:
            node[last.json_name] = False if last.type == FieldDescriptor.TYPE_BOOL else 0
    return out


def _from_parts(f: FieldDescriptor, parts: dict[str, Any]) -> Any:
    if "matrix" in parts and ({"xyz", "rpy"} & parts.keys()):
        raise ArgumentError(f"{f.json_name}: give a matrix or xyz/rpy, not both")
    if "matrix" in parts:
        hg: Any = [parts["matrix"][4 * i : 4 * i + 4] for i in range(3)]
    else:
        hg = pose(parts.get("xyz", (0.0, 0.0, 0.0)), parts.get("rpy", (0.0, 0.0, 0.0)))
    if f.message_type.name == HG:
        if {"elbow", "structFlag"} & parts.keys():
            raise ArgumentError(f"{f.json_name}: an HgMatrix has no elbow or structFlag")
        return hg
    return {
        "carPos": hg,
        "elbow": parts.get("elbow", 0.0),
        "structFlag": parts.get("structFlag", 0),
    }


def parse_field(f: FieldDescriptor, tokens: list[str], where: str) -> Any:
    """A field's Python value from its words (see the module docstring)."""
    if f.is_repeated:
        if f.type != FieldDescriptor.TYPE_MESSAGE:
            return [parse_scalar(f, t, f"{where}[{i}]") for i, t in enumerate(tokens)]
        size = message_arity(f.message_type)
        if len(tokens) % size:
            raise ArgumentError(
                f"{where}: expected groups of {size} ({layout(f)}), got {len(tokens)} values"
            )
        return [
            parse_message(f.message_type, tokens[i : i + size], f"{where}[{i // size}]")
            for i in range(0, len(tokens), size)
        ]
    arity = field_arity(f) or 0
    if len(tokens) != arity:
        raise ArgumentError(f"{where}: expected {arity} values ({layout(f)}), got {len(tokens)}")
    if f.type == FieldDescriptor.TYPE_MESSAGE:
        return parse_message(f.message_type, tokens, where)
    return parse_scalar(f, tokens[0], where)


def parse_message(d: Descriptor, tokens: list[str], where: str) -> Any:
    """A struct from its flattened words: HgMatrix -> 3 x 4 array, else a dict by field."""
    if d.name == HG:
        numbers = [_float(t, where) for t in tokens]
        return pose(numbers[:3], numbers[3:])
    out: dict[str, Any] = {}
    rest = list(tokens)
    for f in d.fields:
        n = field_arity(f) or 0
        out[f.json_name] = parse_field(f, rest[:n], f"{where}.{f.json_name}")
        rest = rest[n:]
    return out


def parse_scalar(f: FieldDescriptor, token: str, where: str) -> Any:
    kind = f.type
    if kind == FieldDescriptor.TYPE_ENUM:
        resolve_enum(f.enum_type, token, where)  # raises with the valid names
        return token
    if kind == FieldDescriptor.TYPE_BOOL:
        word = token.strip().lower()
        if word in _TRUE | _FALSE:
            return word in _TRUE
        raise ArgumentError(f"{where}: {token!r} is not a boolean (true/false)")
    if kind == FieldDescriptor.TYPE_STRING:
        return token
    if kind in (FieldDescriptor.TYPE_DOUBLE, FieldDescriptor.TYPE_FLOAT):
        return _float(token, where)
    try:
        return int(token, 0)
    except ValueError:
        raise ArgumentError(f"{where}: {token!r} is not a whole number") from None


def _float(token: str, where: str) -> float:
    try:
        return float(token)
    except ValueError:
        raise ArgumentError(f"{where}: {token!r} is not a number") from None
