"""Structured logs to stderr: one ``key=value`` line per event (logfmt), journald-friendly.

Under systemd (``$JOURNAL_STREAM`` set) each line starts with the syslog priority
(``<3>`` .. ``<7>``) and carries no timestamp (journald adds one); elsewhere lines start
with an ISO time.
"""

from __future__ import annotations

import logging
import os
import sys
import time

_PRIORITY = {
    logging.DEBUG: 7,
    logging.INFO: 6,
    logging.WARNING: 4,
    logging.ERROR: 3,
    logging.CRITICAL: 2,
}


def _quote(value: str) -> str:
    if value and not any(c in value for c in ' "=\n\t'):
        return value
    escaped = value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{escaped}"'


class LogfmtFormatter(logging.Formatter):
    def __init__(self, journal: bool, process: str):
        super().__init__()
        self.journal = journal
        self.process = process

    def format(self, record: logging.LogRecord) -> str:
        parts = []
        # journald takes "<N>" off the front; a space after it would stay in the message
        prefix = f"<{_PRIORITY.get(record.levelno, 6)}>" if self.journal else ""
        if not self.journal:
            t = time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(record.created))
            parts.append(f"ts={t}.{int(record.msecs):03d}")
        parts.append(f"level={record.levelname.lower()}")
        parts.append(f"proc={self.process}")
        parts.append(f"logger={record.name}")
        parts.append(f"msg={_quote(record.getMessage())}")
        if record.exc_info:
            parts.append(f"exc={_quote(self.formatException(record.exc_info))}")
        return prefix + " ".join(parts)


def setup_logging(level: str = "info", process: str = "imotiond") -> None:
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(LogfmtFormatter("JOURNAL_STREAM" in os.environ, process))
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(level.upper())
