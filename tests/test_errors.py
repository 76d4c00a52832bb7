"""controller.errors: every ImotionError survives pickling with its class, code and comment
(the planning worker raises them in another process, issue 17.12)."""

from __future__ import annotations

import pickle

import pytest

from controller.errors import (
    ArgumentError,
    ChannelError,
    ConfigError,
    ImotionError,
    Refused,
    StateError,
    UnreachableError,
)
from controller.vocabulary import ReturnCode


@pytest.mark.parametrize(
    "error",
    [
        Refused(ReturnCode.CANNOT_REACH_TARGET_ERR, "beyond its reach"),
        Refused(-2, "busy"),
        ArgumentError("speed: must be > 0"),
        StateError("servo off"),
        UnreachableError("too far"),
        ChannelError("no control process"),
        ConfigError("bad key"),
        ImotionError("plain"),
    ],
)
def test_an_error_crosses_a_process_boundary_unchanged(error: ImotionError):
    again = pickle.loads(pickle.dumps(error))
    assert type(again) is type(error)
    assert again.code == error.code and isinstance(again.code, ReturnCode)
    assert again.comment == error.comment == str(again)
    assert again.args == error.args


def test_notes_go_along():
    error = ArgumentError("x")
    error.add_note("where")
    assert pickle.loads(pickle.dumps(error)).__notes__ == ["where"]
