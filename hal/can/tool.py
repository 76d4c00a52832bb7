"""``imotion-can``: look at and move CiA 402 drives on the buses of a robot's drive profile.

Operations (``--robot ID`` picks ``config/robots/<id>/drives.yaml``; ``--bus NAME`` limits to
one bus; ``--interface``/``--channel`` override python-can settings of the selected bus, or
``--interface`` of every bus)::

    scan                       NMT state (heartbeat) and identity 0x1018 of every node
    state                      each drive's CiA 402 state, statusword and position (SDO)
    enable DRIVE [--hold S]    enable one drive holding its position, then quick stop + disable
    disable DRIVE              quick stop + disable one drive
    jog DRIVE DELTA [--speed]  move one axis slowly by DELTA ([deg] or [m]) within its limits
    sdo read DRIVE INDEX [SUB]           read an object (hex or decimal)
    sdo write DRIVE INDEX SUB VALUE      write an object
    record FILE --seconds N    record the bus(es) (.log candump, .asc, .blf by extension)
    replay FILE                send a recorded log with its timing (channel = bus name)
    load --seconds N           measure frames/s and load per bus from the traffic
    plan [--rate HZ]           worst-case bus-load table of the profile (no bus needed)

Global options go before or after the operation (``imotion-can plan --robot pa10``).
``enable`` and ``jog`` run a small master for the one drive (RPDO1 + SYNC + heartbeat at the
profile's rate); never use them while ``imotiond`` drives the same bus. canopen's own log
lines show with ``--verbose`` only. Exit status: 0 done, 1 a drive or bus failed, 2 bad
arguments or configuration. The operations are :mod:`hal.can.operations`.
"""

from __future__ import annotations

import argparse
import difflib
import logging
import re
import sys
from collections.abc import Sequence
from typing import NoReturn

import can
from rich.console import Console

from controller.model.yaml_source import ConfigError
from controller.version import version_line
from hal.can.operations import COMMANDS, Context, ToolError
from hal.can.setup import quiet_canopen
from hal.can.supervision import DriveError

PROG = "imotion-can"


class Parser(argparse.ArgumentParser):
    """argparse with did-you-mean: unknown operations, choices and options get the closest
    known spelling in the error message (exit status 2 as argparse)."""

    def error(self, message: str) -> NoReturn:
        hint = self._suggest(message)
        super().error(f"{message}{hint}")

    def _suggest(self, message: str) -> str:
        if m := re.search(r"invalid choice: '([^']*)'", message):
            words = [c for a in self._actions if a.choices for c in a.choices]
            wrong = m.group(1)
        elif m := re.search(r"unrecognized arguments: (\S+)", message):
            words = [o for p in _parsers(self) for a in p._actions for o in a.option_strings]
            wrong = m.group(1).split("=")[0]
        else:
            return ""
        close = difflib.get_close_matches(wrong, [str(w) for w in words], n=1, cutoff=0.6)
        return f" (did you mean {close[0]!r}?)" if close else ""


def _check_options(parser: argparse.ArgumentParser, argv: Sequence[str]) -> None:
    """An option no parser knows (nor abbreviates) is an error naming it, before argparse
    would take the value after it for the operation (``--robt pa10 plan``)."""
    known = {o for p in _parsers(parser) for a in p._actions for o in a.option_strings}
    for token in argv:
        if token == "--":
            return
        name = token.split("=", 1)[0]
        if not name.startswith("-") or name in known or _is_number(name):
            continue
        if name.startswith("--") and any(k.startswith(name) for k in known):
            continue  # an abbreviation argparse resolves (or reports as ambiguous)
        parser.error(f"unrecognized arguments: {token}")


def _is_number(text: str) -> bool:
    """A negative number (``jog J6 -2``, ``sdo write ... -0x10``), not an option."""
    for parse in (float, lambda t: int(t, 0)):
        try:
            parse(text)
        except ValueError:
            continue
        return True
    return False


def _parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """``parser`` and all its sub-parsers."""
    out: list[argparse.ArgumentParser] = [parser]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                out += _parsers(sub)
    return out


def _global_options(p: argparse.ArgumentParser, defaults: bool) -> None:
    """The options valid before and after the operation. On the sub-parsers they default to
    SUPPRESS so a value given before the operation is not overwritten."""

    def d(value: object) -> object:
        return value if defaults else argparse.SUPPRESS

    p.add_argument("--robot", default=d("smartpal5"), help="robot id or directory")
    p.add_argument("--drives", default=d(None), help="another drives.yaml (default: the robot's)")
    p.add_argument("--bus", default=d(None), help="only this bus of the profile")
    p.add_argument("--interface", default=d(None), help="python-can interface (over the profile)")
    p.add_argument("--channel", default=d(None), help="python-can channel of --bus")
    p.add_argument("--sdo-timeout", type=float, default=d(0.3), help="[s] per SDO request")
    p.add_argument("-v", "--verbose", action="store_true", default=d(False),
                   help="also canopen's and python-can's own log lines")  # fmt: skip


def _int(text: str) -> int:
    return int(text, 0)


def parser() -> argparse.ArgumentParser:
    assert __doc__ is not None
    p = Parser(prog=PROG, description=__doc__.split("\n")[0])
    p.add_argument("--version", action="version", version=version_line(PROG))
    _global_options(p, defaults=True)
    common = Parser(add_help=False)
    _global_options(common, defaults=False)
    sub = p.add_subparsers(dest="command", required=True, metavar="operation",
                           parser_class=Parser)  # fmt: skip

    def op(name: str, help: str) -> argparse.ArgumentParser:
        return sub.add_parser(name, help=help, parents=[common], description=help)

    plan = op("plan", "worst-case bus-load table of the profile")
    plan.add_argument("--rate", type=float, help="[Hz] loop rate (default: the profile's)")
    scan = op("scan", "NMT state and identity of every node")
    scan.add_argument("--listen", type=float, default=0.3, help="[s] to listen for heartbeats")
    op("state", "CiA 402 state of every drive")
    for name in ("enable", "disable", "jog"):
        sp = op(name, f"{name} one drive")
        sp.add_argument("drive")
        sp.add_argument("--timeout", type=float, default=1.0, help="[s] to reach the state")
        if name == "enable":
            sp.add_argument("--hold", type=float, default=1.0, help="[s] enabled before stopping")
        if name == "jog":
            sp.add_argument("delta", type=float, help="[deg] or [m] (relative)")
            sp.add_argument("--speed", type=float, help="[deg/s] or [m/s]")
    sdo = op("sdo", "read or write an object")
    sdo.add_argument("action", choices=("read", "write"))
    sdo.add_argument("drive")
    sdo.add_argument("index", type=_int)
    sdo.add_argument("subindex", type=_int, nargs="?")
    sdo.add_argument("value", type=_int, nargs="?")
    rec = op("record", "record the bus to a log file")
    rec.add_argument("file")
    rec.add_argument("--seconds", type=float, default=10.0)
    rep = op("replay", "replay a log file")
    rep.add_argument("file")
    rep.add_argument("--skip", type=float, default=60.0, help="[s] longest gap kept")
    load = op("load", "measure the bus load")
    load.add_argument("--seconds", type=float, default=5.0)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    p = parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    _check_options(p, argv)
    args = p.parse_args(argv)
    out = Console(width=120)
    err = Console(stderr=True, width=120)
    if args.verbose:
        logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
        logging.getLogger("canopen").setLevel(logging.INFO)
    else:
        quiet_canopen()
    if (
        args.command == "sdo"
        and args.action == "write"
        and (args.value is None or args.subindex is None)
    ):
        err.print("sdo write needs DRIVE INDEX SUB VALUE")
        return 2
    try:
        ctx = Context(args)
        return COMMANDS[args.command](ctx, args, out)
    except ConfigError as exc:
        err.print(str(exc), markup=False, highlight=False)
        return 2
    except (ToolError, DriveError, can.CanError, OSError) as exc:
        err.print(f"error: {exc}", markup=False, highlight=False)
        return 1


if __name__ == "__main__":
    sys.exit(main())
