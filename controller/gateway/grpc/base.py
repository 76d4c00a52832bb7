"""What every servicer shares: the gateway context, the reply guard, argument checks and
message conversions (spec units at the edge, SI inside).

Every RPC method is wrapped by :func:`rpc`: whatever goes wrong becomes a ReturnID with a
code and a comment, never an exception escaping to gRPC (bad input never crashes the daemon
and never moves the robot).
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Hashable
from typing import Any

import numpy as np
import pinocchio as pin
from google.protobuf import text_format

from controller.contract.snapshot import Snapshot
from controller.conversions import hg_to_se3, rad_to_deg, se3_to_hg
from controller.errors import ArgumentError, ChannelError, ImotionError
from controller.gateway.grpc.validation import check_request
from controller.gateway.services.arguments import (  # noqa: F401 (the servicers' imports)
    ratio_arg,
    require_gripper,
    side_arg,
    unit_arg,
)
from controller.gateway.services.jara_arm import CarPos, car_pos
from controller.logs import get_logger
from controller.rpc import imotion_pb2 as pb
from controller.vocabulary import ReturnCode

_log = logging.getLogger("imotiond.service")
_events = get_logger("imotiond.commands")


def rpc(response: type) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Wrap a servicer method ``fn(self, request) -> dict | str | None`` into a gRPC handler.

    The dict holds the response's out-fields; an optional ``"comment"`` key replaces "OK"; a
    string is the comment alone; a ``response`` message is the answer as it is (a ready
    reply from :class:`Replies`). An :class:`ImotionError` becomes its code and comment.
    Every numeric field of the request is bounded first (:func:`check_request`), before the
    servicer runs: nothing is planned from an absurd number.
    """

    def decorate(fn: Callable[..., Any]) -> Callable[..., Any]:
        logged = not fn.__name__.startswith(_READS)

        @functools.wraps(fn)
        def handler(self: Any, request: Any, context: Any) -> Any:
            try:
                check_request(request)
                outs = fn(self, request) or {}
                if isinstance(outs, response):
                    return outs
                if isinstance(outs, str):
                    outs = {"comment": outs}
                comment = outs.pop("comment", "OK")
                if logged:
                    _command_log(self, fn.__name__, request, context, ReturnCode.OK, comment)
                return response(return_id=pb.ReturnID(id=ReturnCode.OK, comment=comment), **outs)
            except ChannelError as exc:
                code, comment = ReturnCode.NG, f"the control loop is not reachable: {exc}"
            except ImotionError as exc:
                code, comment = exc.code, exc.comment
            except Exception as exc:  # never let a request take the gateway down
                _log.exception("%s failed", fn.__name__)
                code, comment = ReturnCode.NG, f"internal error in {fn.__name__}: {exc!r}"
            if logged:
                _command_log(self, fn.__name__, request, context, code, comment)
            return response(return_id=pb.ReturnID(id=code, comment=comment))

        return handler

    return decorate


#: Read-only operations (not logged: clients poll them).
_READS = ("Get", "Is")


class Replies:
    """Ready OK answers of a read, by what they depend on (e.g. getState's by the core
    state, the hardware state and the queue length): built once, then the same message is
    handed to every caller and gRPC only serialises it (~0.2 us instead of ~2 us to build
    it). The messages are never changed once here. Keeps at most ``limit`` (then starts
    over)."""

    def __init__(self, response: type, limit: int = 64):
        self.response = response
        self.limit = limit
        self._known: dict[Hashable, Any] = {}

    def get(self, key: Hashable, fields: Callable[[], dict[str, Any]]) -> Any:
        """The answer for ``key``; ``fields()`` gives its out-fields the first time."""
        reply = self._known.get(key)
        if reply is None:
            reply = self.response(return_id=pb.ReturnID(id=ReturnCode.OK, comment="OK"), **fields())
            if len(self._known) >= self.limit:
                self._known.clear()
            self._known[key] = reply
        return reply


def _command_log(
    servicer: Any, name: str, request: Any, context: Any, code: int, comment: str
) -> None:
    """One line per command: operation, client (gRPC peer), arguments, result. Never
    raises: a log problem must not change the reply."""
    try:
        _command_fields(servicer, name, request, context, code, comment)
    except Exception:
        _log.exception("cannot log command %s", name)


#: Repeated fields longer than this are cut in the command log line: a request may carry
#: 100 000 numbers (refused), and all of them in one line took the gateway ~20 ms of CPU and
#: flooded the log.
LOG_REPEATED = 16


def args_text(request: Any) -> str:
    """``request`` in protobuf text on one line, repeated fields longer than
    :data:`LOG_REPEATED` cut there (the line then ends with what was cut and its length)."""
    cut: list[str] = []
    if _too_long(request):
        request = _cut_copy(request, "", cut)
    text = text_format.MessageToString(request, as_one_line=True)
    return f"{text} (cut: {', '.join(cut)})" if cut else text


def _is_map(fd: Any) -> bool:
    return fd.message_type is not None and fd.message_type.GetOptions().map_entry


def _too_long(msg: Any) -> bool:
    """Whether a repeated field anywhere in ``msg`` is longer than LOG_REPEATED."""
    for fd, value in msg.ListFields():
        if _is_map(fd):
            continue
        if fd.is_repeated and len(value) > LOG_REPEATED:
            return True
        if fd.message_type is not None:
            if any(_too_long(item) for item in (value if fd.is_repeated else (value,))):
                return True
    return False


def _cut_copy(msg: Any, prefix: str, cut: list[str]) -> Any:
    """A copy of ``msg`` with its repeated fields cut at LOG_REPEATED (``cut`` gets
    ``name xLENGTH`` of each); built field by field: copying the whole message first would
    copy every number."""
    out = type(msg)()
    for fd, value in msg.ListFields():
        name = prefix + fd.name
        target = getattr(out, fd.name)
        if _is_map(fd):
            target.MergeFrom(value)
        elif fd.is_repeated:
            if len(value) > LOG_REPEATED:
                cut.append(f"{name} x{len(value)}")
            items = value[:LOG_REPEATED]
            if fd.message_type is None:
                target.extend(items)
            else:
                target.extend(_cut_copy(item, name + ".", cut) for item in items)
        elif fd.message_type is not None:
            target.CopyFrom(_cut_copy(value, name + ".", cut))
        else:
            setattr(out, fd.name, value)
    return out


def _command_fields(
    servicer: Any, name: str, request: Any, context: Any, code: int, comment: str
) -> None:
    peer = getattr(context, "peer", None)
    peer = peer() if callable(peer) else "-"
    code_name = ReturnCode(code).name if code in ReturnCode._value2member_map_ else str(code)
    fields = {
        "op": name,
        "service": type(servicer).__name__.removesuffix("Servicer"),
        "peer": peer,
        "args": args_text(request),
        "result": code_name,
    }
    if code == ReturnCode.OK:
        _events.info("command accepted", **fields)
    else:
        _events.info("command refused", **fields, comment=comment)


# ------------------------------------------------------------------ argument checks
def hg_arg(msg: pb.HgMatrix, name: str) -> pin.SE3:
    values = list(msg.m)
    if len(values) != 12:
        raise ArgumentError(
            f"{name}: expected 12 numbers (3x4 row-major [R | p]), got {len(values)}"
        )
    return hg_to_se3(np.array(values).reshape(3, 4), name)


def hg_msg(pose: pin.SE3) -> pb.HgMatrix:
    return pb.HgMatrix(m=se3_to_hg(pose).ravel().tolist())


def seq_arg(values: Any, n: int, name: str, what: str = "values") -> np.ndarray:
    arr = np.array(list(values), dtype=float)
    if arr.size != n:
        raise ArgumentError(f"{name}: expected {n} {what}, got {arr.size}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ArgumentError(f"{name}[{int(bad[0])}]: {arr[bad[0]]} is not a finite number")
    return arr


def car_pos_arg(msg: pb.CarPosWithElbow, name: str) -> CarPos:
    """A CarPosWithElbow message, checked and in SI."""
    return car_pos(list(msg.car_pos.m), msg.elbow, name)


def car_pos_msg(pose: pin.SE3, elbow: float) -> pb.CarPosWithElbow:
    return pb.CarPosWithElbow(car_pos=hg_msg(pose), elbow=float(rad_to_deg(elbow)), struct_flag=0)


def alarm_msgs(snap: Snapshot, with_module: bool = True) -> list[pb.Alarm]:
    return [
        pb.Alarm(
            code=a["code"],
            type=a["type"],
            description=a["description"],
            module_name=a["module"] if with_module else "",
        )
        for a in snap.alarms
    ]
