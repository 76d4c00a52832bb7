"""One log format for every imotion process (imotiond's control and gateway processes,
imotion-sim): one logfmt line per event on stderr, journald-friendly, written off the
caller's thread.

Line: ``ts=... level=... proc=... logger=... msg=... key=value ...``. Under systemd
(``$JOURNAL_STREAM`` set) each line starts with the syslog priority (``<3>`` .. ``<7>``) and
carries no timestamp (journald adds one); elsewhere lines start with an ISO time.

Both kinds of call produce the same lines (rendered by structlog's ProcessorFormatter):

* the standard library, ``logging.getLogger("imotiond.x").info("ready on %s", address)``;
* structlog with fields, ``get_logger("imotiond.x").info("motion ended", result="done")``.

Nothing is written by the thread that logs: the record goes into a bounded queue (no lock
held while waiting, nothing formatted) and a writer thread formats and writes it, so the
control loop never waits for stderr (a full pipe, a slow journald). When the queue is full
the record is dropped and counted (:func:`dropped`); the next line written says how many.
"""

from __future__ import annotations

import atexit
import logging
import os
import queue
import sys
import threading
import time
from collections.abc import MutableMapping
from typing import Any

import structlog

_PRIORITY = {
    logging.DEBUG: 7,
    logging.INFO: 6,
    logging.WARNING: 4,
    logging.ERROR: 3,
    logging.CRITICAL: 2,
}
#: Records waiting for the writer thread before new ones are dropped.
QUEUE_SIZE = 10_000
#: Keys every line starts with, in this order.
_HEAD = ("ts", "level", "proc", "logger", "msg")


def _quote(value: str) -> str:
    if value and not any(c in value for c in ' "=\n\t'):
        return value
    escaped = value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{escaped}"'


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if value is None:
        return "null"
    return str(value)


class LogfmtFormatter(structlog.stdlib.ProcessorFormatter):
    """stdlib and structlog records as one logfmt line (see the module docstring)."""

    def __init__(self, journal: bool, process: str):
        self.journal = journal
        self.process = process
        super().__init__(
            processors=[self._standard_keys, structlog.processors.format_exc_info, self._render],
            foreign_pre_chain=[],
        )

    def _standard_keys(
        self, _logger: Any, _name: str, event: MutableMapping[str, Any]
    ) -> MutableMapping[str, Any]:
        record: logging.LogRecord = event.pop("_record")
        event.pop("_from_structlog", None)
        event.pop("level", None)  # structlog's own, same as the record's
        head: dict[str, Any] = {}
        if not self.journal:
            t = time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(record.created))
            head["ts"] = f"{t}.{int(record.msecs):03d}"
        head["level"] = record.levelname.lower()
        head["proc"] = self.process
        head["logger"] = record.name
        head["msg"] = event.pop("event", "")
        head["_levelno"] = record.levelno
        if record.exc_info and "exc_info" not in event:
            event["exc_info"] = record.exc_info
        return {**head, **event}

    def _render(self, _logger: Any, _name: str, event: MutableMapping[str, Any]) -> str:
        levelno = event.pop("_levelno", logging.INFO)
        if "exception" in event:
            event["exc"] = event.pop("exception")
        # journald takes "<N>" off the front; a space after it would stay in the message
        prefix = f"<{_PRIORITY.get(levelno, 6)}>" if self.journal else ""
        return prefix + " ".join(f"{k}={_quote(_text(v))}" for k, v in event.items())


class _QueueHandler(logging.Handler):
    """Hands records to the writer thread; never blocks and never formats."""

    def __init__(self, records: queue.Queue[Any]):
        super().__init__()
        self.records = records
        self.dropped = 0

    def handle(self, record: logging.LogRecord) -> bool:  # no handler lock: put is atomic
        if not self.filter(record):
            return False
        self.emit(record)
        return True

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self.records.put_nowait(record)
        except queue.Full:
            self.dropped += 1


class _Writer:
    """The thread that formats and writes queued records."""

    def __init__(self, target: logging.Handler):
        self.records: queue.Queue[Any] = queue.Queue(QUEUE_SIZE)
        self.handler = _QueueHandler(self.records)
        self.target = target
        self._reported = 0
        self.thread = threading.Thread(target=self._run, name="log-writer", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            self._loop()
        except Exception:  # e.g. the stream closed under it: nothing left to write to
            return

    def _loop(self) -> None:
        while True:
            item = self.records.get()
            if item is None:
                return
            if isinstance(item, threading.Event):
                try:
                    self.target.flush()
                finally:
                    item.set()
                continue
            try:
                lost = self.handler.dropped - self._reported
                if lost:
                    self._reported += lost
                    self.target.handle(_dropped_record(lost))
                self.target.handle(item)
            except Exception:  # the writer must outlive any bad record or handler
                continue

    def flush(self, timeout: float) -> bool:
        done = threading.Event()
        try:
            self.records.put(done, timeout=timeout)
        except queue.Full:
            return False
        return done.wait(timeout)

    def stop(self, timeout: float) -> None:
        self.flush(timeout)
        try:
            self.records.put(None, timeout=timeout)
        except queue.Full:
            return
        self.thread.join(timeout)


def _dropped_record(count: int) -> logging.LogRecord:
    return logging.LogRecord(
        "imotion.logs", logging.WARNING, __file__, 0, "%d log records dropped (queue full)",
        (count,), None,
    )  # fmt: skip


_writer: _Writer | None = None


def setup_logging(level: str = "info", process: str = "imotiond") -> None:
    """Route every log record of this process to stderr as logfmt, via the writer thread."""
    global _writer
    if _writer is not None:
        _writer.stop(1.0)
    target = logging.StreamHandler(sys.stderr)
    target.setFormatter(LogfmtFormatter("JOURNAL_STREAM" in os.environ, process))
    _writer = _Writer(target)
    root = logging.getLogger()
    root.handlers[:] = [_writer.handler]
    root.setLevel(level.upper())


def flush_logs(timeout: float = 2.0) -> bool:
    """Wait until every record logged so far is written (True) or ``timeout`` [s] passed."""
    return _writer.flush(timeout) if _writer is not None else True


def stop_logging(timeout: float = 2.0) -> None:
    """Write what is queued and end the writer thread (records logged later are dropped
    until the next :func:`setup_logging`)."""
    global _writer
    if _writer is not None:
        _writer.stop(timeout)
        _writer = None


def dropped() -> int:
    """Records dropped so far because the writer fell behind."""
    return _writer.handler.dropped if _writer is not None else 0


def get_logger(name: str) -> Any:
    """A structlog logger (``log.info("event", key=value)``) writing through the same path."""
    return structlog.stdlib.get_logger(name)


def _configure_structlog() -> None:
    """structlog loggers hand their event dicts to the standard library (done at import,
    so that :func:`get_logger` works before and without :func:`setup_logging`)."""
    structlog.configure(
        processors=[
            structlog.stdlib.filter_by_level,
            # an exception is rendered where it is caught (rare; the traceback is gone later)
            structlog.processors.format_exc_info,
            structlog.stdlib.ProcessorFormatter.wrap_for_formatter,
        ],
        logger_factory=structlog.stdlib.LoggerFactory(),
        wrapper_class=structlog.stdlib.BoundLogger,
        cache_logger_on_first_use=False,
    )


_configure_structlog()
atexit.register(flush_logs)
