"""controller.control.events and the operator log lines of a running daemon: every command
with its client and arguments, motion start/end/result/duration, state changes, alarms
raised and cleared, the loop-health line."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import pytest

from controller.control.core import CoreState
from controller.control.events import LoopEvents
from controller.daemon.health import LoopHealth
from controller.gateway.grpc.base import LOG_REPEATED
from controller.model.alarms import Alarm, AlarmCode, AlarmType
from controller.rpc import imotion_pb2 as pb
from tests.daemon_support import TestDaemon


def events(caplog: pytest.LogCaptureFixture, msg: str | None = None) -> list[dict[str, Any]]:
    """The structlog event dicts logged so far (optionally only those with ``msg``)."""
    out = []
    for record in caplog.records:
        if isinstance(record.msg, dict):
            event = {**record.msg, "level": record.levelname.lower(), "logger": record.name}
            if msg is None or event["event"] == msg:
                out.append(event)
    return out


# ---------------------------------------------------------------- LoopEvents, fake core


def _core(**kw: Any) -> SimpleNamespace:
    return SimpleNamespace(**{"state": CoreState.READY, "motion": None, "alarms": [], **kw})


def test_state_changes_are_logged_once(caplog: pytest.LogCaptureFixture):
    caplog.set_level(logging.INFO)
    ev, core = LoopEvents(), _core()
    ev.observe(core)  # the first state seen is not a change
    core.state = CoreState.BUSY
    ev.observe(core)
    ev.observe(core)
    core.state = CoreState.ALARM
    ev.observe(core)
    assert ev.flush()
    changes = [(e["from"], e["to"], e["level"]) for e in events(caplog, "state changed")]
    assert changes == [("ready", "busy", "info"), ("busy", "alarm", "warning")]


@pytest.mark.parametrize(
    "ending, state, result",
    [
        (None, CoreState.READY, "done"),
        ("stopped", CoreState.READY, "stopped"),
        ("aborted", CoreState.READY, "aborted"),
        (None, CoreState.ALARM, "alarm"),
    ],
)
def test_motion_end_carries_result_and_duration(
    caplog: pytest.LogCaptureFixture, ending: str | None, state: CoreState, result: str
):
    caplog.set_level(logging.INFO)
    ev, motion = LoopEvents(), object()
    core = _core(state=CoreState.BUSY, motion=motion)
    ev.motion_started("RIGHT linear move", motion)
    ev.observe(core)
    if ending:
        ev.ending(ending)
    core.motion, core.state = None, state
    ev.observe(core)
    assert ev.flush()
    (started,) = events(caplog, "motion started")
    (ended,) = events(caplog, "motion ended")
    assert started["motion"] == ended["motion"] == "RIGHT linear move"
    assert started["id"] == ended["id"] == 1
    assert ended["result"] == result and ended["duration_s"] >= 0.0


def test_a_motion_replaced_by_the_next_is_ended_first(caplog: pytest.LogCaptureFixture):
    caplog.set_level(logging.INFO)
    ev = LoopEvents()
    ev.motion_started("a", object())
    ev.motion_started("b", object())
    assert ev.flush()
    assert [(e["motion"], e["result"]) for e in events(caplog, "motion ended")] == [
        ("a", "replaced")
    ]


def test_every_alarm_raised_and_cleared_is_logged(caplog: pytest.LogCaptureFixture):
    caplog.set_level(logging.INFO)
    ev, core = LoopEvents(), _core()
    first = Alarm(0x411, AlarmType.FAULT, "cycles overran", "loop")
    second = Alarm(0x412, AlarmType.FAULT, "no time law", "queue")
    core.alarms = [first]
    ev.observe(core)
    core.alarms = [first, second]
    ev.observe(core)
    ev.observe(core)
    core.alarms = []
    ev.observe(core)
    assert ev.flush()
    raised = [(e["code"], e["source"], e["description"]) for e in events(caplog, "alarm raised")]
    assert raised == [("0x0411", "loop", "cycles overran"), ("0x0412", "queue", "no time law")]
    assert all(e["level"] == "warning" for e in events(caplog, "alarm raised"))
    cleared = [e["code"] for e in events(caplog, "alarm cleared")]
    assert cleared == ["0x0411", "0x0412"]


# ---------------------------------------------------------------- LoopHealth


def _controller(overruns: int) -> SimpleNamespace:
    import numpy as np

    return SimpleNamespace(
        loop=SimpleNamespace(stats=SimpleNamespace(overruns=overruns)),
        publisher=SimpleNamespace(writer=SimpleNamespace(values=np.arange(16, dtype=float))),
        core=SimpleNamespace(cycles=1000),
    )


def test_loop_health_line_every_period_and_a_warning_on_overruns(
    caplog: pytest.LogCaptureFixture,
):
    caplog.set_level(logging.INFO)
    ctl = _controller(0)
    health = LoopHealth(ctl, period=10.0)  # type: ignore[arg-type]
    t0 = health.last
    health.tick(t0 + 1.0)  # nothing new, not due
    assert events(caplog, "loop health") == []
    health.tick(t0 + 10.0)  # due, clean
    ctl.loop.stats.overruns = 3
    health.tick(t0 + 11.0)  # overruns: warned at once
    ctl.loop.stats.overruns = 5
    health.tick(t0 + 12.0)  # more, but already warned in this period
    health.tick(t0 + 20.0)  # due: a warning with the overruns since
    lines = [(e["level"], e["new_overruns"]) for e in events(caplog, "loop health")]
    assert lines == [("info", 0), ("warning", 3), ("warning", 2)]
    assert events(caplog, "loop health")[0]["overruns"] == 0


# ---------------------------------------------------------------- a running daemon


@pytest.fixture(scope="module")
def daemon() -> Iterator[TestDaemon]:
    d = TestDaemon(robot="pa10", hal="ideal")
    yield d
    d.close()


def test_daemon_logs_commands_motions_states_and_alarms(
    daemon: TestDaemon, caplog: pytest.LogCaptureFixture
):
    caplog.set_level(logging.INFO)
    daemon.reset()
    assert daemon.wait_for(lambda: daemon.state() == 0x012)
    rel = pb.HgMatrix(m=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 20])
    reply = daemon.spec_a.MoveLinearCartesianRel(
        pb.MoveLinearCartesianRelRequest(
            type=pb.RIGHT,
            frame_type=pb.BASE_FRAME,
            rel_hg_mat=rel,
            speed=pb.CartesianSpeed(translation=50, rotation=30),
            accel=pb.CartesianAccel(translation=200, rotation=100),
        )
    )
    assert reply.return_id.id == 0, reply.return_id.comment
    assert daemon.wait_for(lambda: bool(events(caplog, "motion ended")))
    refused = daemon.spec_a.MoveLinearCartesianRel(
        pb.MoveLinearCartesianRelRequest(
            type=pb.RIGHT,
            frame_type=pb.BASE_FRAME,
            rel_hg_mat=rel,
            speed=pb.CartesianSpeed(translation=-1, rotation=30),
            accel=pb.CartesianAccel(translation=200, rotation=100),
        )
    )
    assert refused.return_id.id != 0
    daemon.controller.core.raise_alarm(AlarmCode.LOOP_OVERRUN, "loop", "injected by the test")
    assert daemon.wait_for(lambda: bool(events(caplog, "alarm raised")))
    daemon.spec_a.ClearAlarms(pb.ClearAlarmsRequest())
    assert daemon.wait_for(lambda: bool(events(caplog, "alarm cleared")))

    accepted = events(caplog, "command accepted")
    (move,) = [e for e in accepted if e["op"] == "MoveLinearCartesianRel"]
    assert move["peer"].startswith("ipv4:127.0.0.1:")
    assert "m: 20" in move["args"] and "translation: 50" in move["args"]
    assert move["service"] == "IntegratedMotion" and move["result"] == "OK"
    (bad,) = events(caplog, "command refused")
    assert bad["op"] == "MoveLinearCartesianRel" and bad["result"] == "VALUE_ERR"
    assert "speed.translation" in bad["comment"] and "translation: -1" in bad["args"]
    assert not [e for e in events(caplog) if str(e.get("op", "")).startswith(("Get", "Is"))]
    (ended,) = events(caplog, "motion ended")
    assert ended["result"] == "done" and ended["duration_s"] > 0
    states = [(e["from"], e["to"]) for e in events(caplog, "state changed")]
    assert ("ready", "busy") in states and ("busy", "ready") in states
    assert states[-2:] == [("ready", "alarm"), ("alarm", "servo off")]
    (alarm,) = events(caplog, "alarm raised")
    assert (alarm["code"], alarm["source"], alarm["description"]) == (
        "0x0411",
        "loop",
        "injected by the test",
    )
    assert events(caplog, "alarm cleared")[0]["code"] == "0x0411"


def test_a_huge_request_is_logged_cut(daemon: TestDaemon, caplog: pytest.LogCaptureFixture):
    """100 000 numbers in one field (refused): the command line names the field and its
    length, with its first LOG_REPEATED numbers only (not a megabyte of text)."""
    caplog.set_level(logging.INFO)
    request = pb.MoveLinearCartesianRelRequest(
        type=pb.RIGHT,
        speed=pb.CartesianSpeed(translation=50, rotation=30),
        accel=pb.CartesianAccel(translation=200, rotation=100),
    )
    request.rel_hg_mat.m.extend([0.5] * 100_000)
    reply = daemon.spec_a.MoveLinearCartesianRel(request)
    assert reply.return_id.id != 0
    (bad,) = events(caplog, "command refused")
    assert bad["args"].endswith("(cut: rel_hg_mat.m x100000)"), bad["args"][-200:]
    assert bad["args"].count("m: 0.5") == LOG_REPEATED
    assert "translation: 50" in bad["args"] and len(bad["args"]) < 1000
