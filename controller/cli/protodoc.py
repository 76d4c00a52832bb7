"""Field comments of controller/rpc/imotion.proto, for help texts (units, meanings).

The runtime descriptors carry no comments, so the shipped .proto is read once. A missing or
unreadable file gives empty texts, never an error.
"""

from __future__ import annotations

import functools
import re
from importlib import resources

_MESSAGE = re.compile(r"^\s*message\s+(\w+)\s*\{")
_FIELD = re.compile(r"^\s*(?:repeated\s+)?[\w.]+\s+(\w+)\s*=\s*\d+\s*;\s*(?://\s*(.*))?$")
_COMMENT = re.compile(r"^\s*//\s?(.*)$")


@functools.cache
def field_comments() -> dict[tuple[str, str], str]:
    """``(message, field) -> comment`` (trailing comment, else the comment lines above)."""
    try:
        text = (resources.files("controller.rpc") / "imotion.proto").read_text(encoding="utf-8")
    except (OSError, ModuleNotFoundError):
        return {}
    out: dict[tuple[str, str], str] = {}
    message = ""
    above: list[str] = []
    for line in text.splitlines():
        if m := _MESSAGE.match(line):
            message, above = m.group(1), []
        elif message and (m := _FIELD.match(line)):
            comment = (m.group(2) or " ".join(above)).strip()
            out[(message, m.group(1))] = comment
            above = []
        elif m := _COMMENT.match(line):
            above.append(m.group(1).strip())
        else:
            above = []
            if line.strip() == "}":
                message = ""
    return out


def comment(message: str, field: str) -> str:
    """The comment of ``message.field`` ("" when none)."""
    return field_comments().get((message, field), "")
