"""controller.logs: one logfmt line per event on stderr; journald priorities."""

from __future__ import annotations

import logging
import sys
import threading
from collections.abc import Iterator

import pytest

from controller import logs
from controller.logs import (
    LogfmtFormatter,
    flush_logs,
    get_logger,
    setup_logging,
    stop_logging,
)


@pytest.fixture
def restore_root() -> Iterator[None]:
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    yield
    stop_logging()
    root.handlers[:] = handlers
    root.setLevel(level)


def _record(msg: str, level: int = logging.INFO, exc: bool = False) -> logging.LogRecord:
    exc_info = None
    if exc:
        try:
            raise ValueError("boom")
        except ValueError:
            exc_info = sys.exc_info()
    return logging.LogRecord("imotiond.test", level, __file__, 1, msg, (), exc_info)


def test_plain_lines_carry_time_level_process_logger_message():
    line = LogfmtFormatter(journal=False, process="imotiond").format(_record("ready"))
    assert line.startswith("ts=")
    assert line.endswith(" level=info proc=imotiond logger=imotiond.test msg=ready")


@pytest.mark.parametrize(
    "msg, shown",
    [
        ("a b", 'msg="a b"'),
        ('say "hi"', r'msg="say \"hi\""'),
        ("k=v", 'msg="k=v"'),
        ("two\nlines", r'msg="two\nlines"'),
        ("", 'msg=""'),
    ],
)
def test_values_are_quoted_when_needed(msg: str, shown: str):
    line = LogfmtFormatter(journal=False, process="p").format(_record(msg))
    assert line.endswith(shown)
    assert "\n" not in line


def test_journal_lines_start_with_the_priority_and_have_no_time():
    fmt = LogfmtFormatter(journal=True, process="gateway")
    assert fmt.format(_record("x", logging.ERROR)).startswith("<3>level=error proc=gateway")
    assert fmt.format(_record("x", logging.WARNING)).startswith("<4>")
    assert fmt.format(_record("x", logging.DEBUG)).startswith("<7>")
    assert "ts=" not in fmt.format(_record("x"))


def test_exceptions_stay_on_one_line():
    line = LogfmtFormatter(journal=False, process="p").format(_record("failed", exc=True))
    assert "\n" not in line and "exc=" in line and "ValueError: boom" in line


def test_setup_logging_writes_logfmt_to_stderr(
    capsys: pytest.CaptureFixture[str], restore_root: None
):
    setup_logging("warning", "imotiond")
    logging.getLogger("imotiond.x").info("hidden")
    logging.getLogger("imotiond.x").warning("shown %d", 3)
    assert flush_logs()
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].endswith(
        'level=warning proc=imotiond logger=imotiond.x msg="shown 3"'
    )


def test_structlog_fields_follow_the_standard_keys(
    capsys: pytest.CaptureFixture[str], restore_root: None
):
    setup_logging("info", "gateway")
    get_logger("imotiond.commands").info(
        "command accepted", op="Stop", peer="ipv4:127.0.0.1:5", ratio=0.125, ok=True, none=None
    )
    get_logger("imotiond.commands").debug("hidden", op="x")
    assert flush_logs()
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("ts=")
    assert line.endswith(
        'level=info proc=gateway logger=imotiond.commands msg="command accepted" op=Stop '
        "peer=ipv4:127.0.0.1:5 ratio=0.125 ok=true none=null"
    )


def test_structlog_exceptions_are_rendered_where_caught(
    capsys: pytest.CaptureFixture[str], restore_root: None
):
    setup_logging("info", "imotiond")
    try:
        raise ValueError("boom")
    except ValueError:
        get_logger("imotiond.x").exception("failed", op="y")
    assert flush_logs()
    (line,) = capsys.readouterr().err.splitlines()
    assert "msg=failed op=y exc=" in line and "ValueError: boom" in line


class _Blocked(logging.Handler):
    """A target that blocks like a full stderr pipe until released."""

    def __init__(self) -> None:
        super().__init__()
        self.go = threading.Event()
        self.entered = threading.Event()
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.entered.set()
        self.go.wait(30)
        self.lines.append(record.getMessage())


def test_a_blocked_writer_never_blocks_the_logging_thread(monkeypatch: pytest.MonkeyPatch):
    """The writer thread is stuck on its output: log calls still return at once; what does
    not fit in the queue is dropped, counted, and reported once the output moves again."""
    monkeypatch.setattr(logs, "QUEUE_SIZE", 5)
    target = _Blocked()
    writer = logs._Writer(target)
    logger = logging.getLogger("imotiond.blocked")
    logger.propagate = False
    logger.addHandler(writer.handler)
    try:
        logger.warning("first")
        assert target.entered.wait(10)  # the writer now hangs in emit()
        for i in range(20):
            logger.warning("record %d", i)  # would hang here if logging waited for output
        assert writer.handler.dropped == 15
        target.go.set()
        assert writer.flush(10)
    finally:
        logger.removeHandler(writer.handler)
        logger.propagate = True
        writer.stop(5)
    assert target.lines[0] == "first"
    assert "15 log records dropped (queue full)" in target.lines
    assert target.lines[-1] == "record 4"
