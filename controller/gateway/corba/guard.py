"""What every CORBA servant shares: the reply guard, the command log and the wire-level
enum handling.

Every operation is wrapped by :func:`op`: whatever goes wrong becomes the family's
ReturnID / RETURN_ID with the spec code and a comment (an :class:`ImotionError`'s ``code``
and ``comment``; the control loop unreachable: NG; anything unexpected: NG and one log
line), never a CORBA system exception, and the out parameters get neutral values. The
gRPC servicers' guard (:func:`controller.gateway.grpc.base.rpc`) does the same for gRPC.

Enums: omniORB refuses an out-of-range enum value with a MARSHAL exception before any
servant code runs. A CDR enum is an ``unsigned long`` on the wire, so :func:`lenient_ops`
makes the servant side decode enum *in* parameters as plain numbers (wire-identical) and
the servants answer an unknown value with VALUE_ERR, as over gRPC.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable
from typing import Any

from omniORB import tcInternal

from controller.errors import ChannelError, ImotionError
from controller.logs import get_logger
from controller.vocabulary import ReturnCode

_log = logging.getLogger("imotiond.corba")
_events = get_logger("imotiond.commands")

#: Operations not logged (clients poll them).
_READS = ("get", "is")


class Reply:
    """An OK answer with a comment other than "OK" and/or out parameters (in IDL order)."""

    __slots__ = ("comment", "outs")

    def __init__(self, *outs: Any, comment: str | None = None):
        self.outs = outs
        self.comment = comment


def op(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Wrap a servant method returning None, a comment string or a :class:`Reply`.

    The servant class has ``_return_id`` (its family's ReturnID struct), ``_family`` (for
    the log) and ``_omni_op_d`` (the operation descriptors, for the out parameters)."""
    name = fn.__name__
    logged = not name.startswith(_READS)

    @functools.wraps(fn)
    def handler(self: Any, *args: Any) -> Any:
        outs: tuple[Any, ...] = ()
        try:
            result = fn(self, *args)
            comment = "OK"
            if isinstance(result, str):
                comment = result
            elif isinstance(result, Reply):
                outs = result.outs
                comment = result.comment or "OK"
            code = ReturnCode.OK
        except ChannelError as exc:
            code, comment = ReturnCode.NG, f"the control loop is not reachable: {exc}"
        except ImotionError as exc:
            code, comment = exc.code, exc.comment
        except Exception as exc:  # never let a request take the gateway down
            _log.exception("CORBA %s.%s failed", self._family, name)
            code, comment = ReturnCode.NG, f"internal error in {name}: {exc!r}"
        if logged:
            command_log(self._family, name, args, int(code), comment)
        out_descs = self._omni_op_d[name][1][1:]
        if code != ReturnCode.OK or len(outs) != len(out_descs):
            outs = tuple(default_value(d) for d in out_descs)
        ret = self._return_id(int(code), comment)
        return (ret, *outs) if out_descs else ret

    return handler


def boolean_op(fn: Callable[..., bool]) -> Callable[..., bool]:
    """isMoving / isServoOn: a bare boolean; on any failure False and one log line."""

    @functools.wraps(fn)
    def handler(self: Any) -> bool:
        try:
            return bool(fn(self))
        except Exception:
            _log.exception("CORBA %s.%s failed (answered false)", self._family, fn.__name__)
            return False

    return handler


def command_log(family: str, name: str, args: tuple[Any, ...], code: int, comment: str) -> None:
    """One line per command: operation, interface, arguments, result (omniORBpy does not
    tell a servant its caller: no peer). Never raises."""
    try:
        code_name = ReturnCode(code).name if code in ReturnCode._value2member_map_ else str(code)
        fields = {
            "op": name,
            "service": f"corba:{family}",
            "peer": "-",
            "args": _show(args),
            "result": code_name,
        }
        if code == ReturnCode.OK:
            _events.info("command accepted", **fields)
        else:
            _events.info("command refused", **fields, comment=comment)
    except Exception:
        _log.exception("cannot log command %s", name)


def _show(args: tuple[Any, ...]) -> str:
    text = ", ".join(_plain(a) for a in args)
    return text if len(text) <= 400 else text[:400] + "..."


def _plain(value: Any) -> str:
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_plain(v) for v in value) + "]"
    if hasattr(value, "__dict__") and not isinstance(value, type):
        inner = ", ".join(f"{k}={_plain(v)}" for k, v in vars(value).items())
        return f"{type(value).__name__}({inner})"
    return repr(value)


# ------------------------------------------------------------------ descriptors
def _unalias(desc: Any) -> Any:
    while isinstance(desc, tuple) and desc[0] == tcInternal.tv_alias:
        desc = desc[3]
    return desc


def default_value(desc: Any) -> Any:
    """A neutral value of an IDL type (by its omniORBpy descriptor): 0, "", empty
    sequences, zero arrays, structs of those, an enum's first item."""
    desc = _unalias(desc)
    if not isinstance(desc, tuple):
        if desc in (tcInternal.tv_boolean,):
            return False
        if desc in (tcInternal.tv_float, tcInternal.tv_double):
            return 0.0
        if desc in (tcInternal.tv_string, tcInternal.tv_wstring):
            return ""
        return 0
    kind = desc[0]
    if kind == tcInternal.tv_string:
        return ""
    if kind == tcInternal.tv_sequence:
        return []
    if kind == tcInternal.tv_array:
        return [default_value(desc[1]) for _ in range(desc[2])]
    if kind == tcInternal.tv_enum:
        return desc[3][0]
    if kind == tcInternal.tv_struct:
        cls = desc[1]
        fields = desc[5::2]
        return cls(*(default_value(d) for d in fields))
    raise TypeError(f"no default for IDL type descriptor kind {kind}")


def lenient_ops(op_d: dict[str, Any]) -> dict[str, Any]:
    """Operation descriptors whose top-level enum *in* parameters decode as ``unsigned
    long`` (the same bytes on the wire), so a bad value reaches the servant."""

    def lenient(desc: Any) -> Any:
        base = _unalias(desc)
        if isinstance(base, tuple) and base[0] == tcInternal.tv_enum:
            return tcInternal.tv_ulong
        return desc

    return {
        name: (tuple(lenient(d) for d in ins), outs, excs)
        for name, (ins, outs, excs) in ((n, d[:3]) for n, d in op_d.items())
    }


def enum_value(value: Any) -> int:
    """An enum in parameter as its number (a plain number from the lenient descriptors, an
    EnumItem from a colocated caller)."""
    return int(getattr(value, "_v", value))
