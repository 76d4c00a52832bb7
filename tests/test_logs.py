"""controller.logs: one logfmt line per event on stderr; journald priorities."""

from __future__ import annotations

import logging
import sys

import pytest

from controller.logs import LogfmtFormatter, setup_logging


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


def test_setup_logging_writes_logfmt_to_stderr(capsys: pytest.CaptureFixture[str]):
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    try:
        setup_logging("warning", "imotiond")
        logging.getLogger("imotiond.x").info("hidden")
        logging.getLogger("imotiond.x").warning("shown %d", 3)
        err = capsys.readouterr().err.splitlines()
    finally:
        root.handlers[:] = handlers
        root.setLevel(level)
    assert len(err) == 1 and err[0].endswith(
        'level=warning proc=imotiond logger=imotiond.x msg="shown 3"'
    )
