"""The CORBA reply guard: every failure becomes a ReturnID with the spec code and a comment,
the out parameters get values the ORB can marshal, enum in parameters arrive as numbers."""

from __future__ import annotations

from typing import Any

import pytest

pytest.importorskip("omniORB")

import omniORB
from omniORB import tcInternal

from controller.corba.stubs import _GlobalIDL as A
from controller.errors import ArgumentError, ChannelError, Refused
from controller.gateway.corba.dual import DualCommonServant, DualMiddleServant
from controller.gateway.corba.guard import (
    Reply,
    boolean_op,
    default_value,
    enum_value,
    lenient_ops,
    op,
)
from controller.gateway.corba.jara import _CLASSES
from controller.gateway.corba.spec_a import SpecAServant
from controller.vocabulary import ReturnCode
from tests.corba_support import client_orb

SERVANTS = [SpecAServant, DualCommonServant, DualMiddleServant, *_CLASSES.values()]


@pytest.mark.parametrize("cls", SERVANTS, ids=lambda c: c.__name__)
def test_every_operation_is_guarded_and_its_default_outs_marshal(cls: type) -> None:
    client_orb()  # cdrMarshal needs an ORB
    for name, (_, outs, _) in ((n, d[:3]) for n, d in cls._omni_op_d.items()):
        method = getattr(cls, name)
        assert hasattr(method, "__wrapped__"), f"{cls.__name__}.{name} has no guard"
        for desc in outs[1:]:
            omniORB.cdrMarshal(tcInternal.createTypeCode(desc), default_value(desc))


@pytest.mark.parametrize("cls", SERVANTS, ids=lambda c: c.__name__)
def test_no_enum_in_parameter_is_left_to_the_orb(cls: type) -> None:
    for ins, _, _ in (d[:3] for d in cls._omni_op_d.values()):
        for desc in ins:
            while isinstance(desc, tuple) and desc[0] == tcInternal.tv_alias:
                desc = desc[3]
            assert not (isinstance(desc, tuple) and desc[0] == tcInternal.tv_enum)


class _Fake:
    _family = "IntegratedMotionInterface"
    _return_id = A.ReturnID
    _omni_op_d = SpecAServant._omni_op_d

    def __init__(self, exc: Exception | None = None, result: Any = None):
        self.exc, self.result = exc, result

    @op
    def getState(self) -> Any:
        if self.exc is not None:
            raise self.exc
        return self.result

    @boolean_op
    def isMoving(self) -> bool:
        if self.exc is not None:
            raise self.exc
        return True


@pytest.mark.parametrize(
    ("exc", "code", "comment"),
    [
        (ArgumentError("x: bad"), ReturnCode.VALUE_ERR, "x: bad"),
        (Refused(ReturnCode.STATUS_ERR, "busy"), ReturnCode.STATUS_ERR, "busy"),
        (ChannelError("gone"), ReturnCode.NG, "the control loop is not reachable: gone"),
        (ZeroDivisionError("boom"), ReturnCode.NG, "internal error in getState"),
    ],
)
def test_failures_become_codes_and_neutral_outs(exc: Exception, code: int, comment: str) -> None:
    ret, status, message = _Fake(exc).getState()
    assert (ret.id, status, message) == (code, 0, "")
    assert ret.comment.startswith(comment)


def test_ok_with_outs_and_comment() -> None:
    ret, status, message = _Fake(result=Reply(18, "Ready", comment="OK (fine)")).getState()
    assert (ret.id, ret.comment, status, message) == (0, "OK (fine)", 18, "Ready")


def test_booleans_never_raise() -> None:
    assert _Fake().isMoving() is True
    assert _Fake(RuntimeError("x")).isMoving() is False


def test_enum_values() -> None:
    assert enum_value(A.LEFT) == 1 and enum_value(7) == 7
    d = lenient_ops(SpecAServant._omni_op_d)["closeGripper"]
    assert d[0] == (tcInternal.tv_ulong,)
