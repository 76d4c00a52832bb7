"""``imotion``: every operation of the imotion daemon from the shell.

    imotion [global options] OPERATION [arguments]          Spec A (IntegratedMotion)
    imotion [global options] arm RIGHT|LEFT OPERATION [...]  JARA_ARM (Common + Middle)
    imotion [global options] dual OPERATION [...]            JARA_ARM_DUAL
    imotion [global options] watch [--rate HZ] [--once]      live state view
    imotion list                                             every operation and its arguments
    imotion record FILE.mcap [--seconds N] | plot FILE.mcap | view   see controller/cli/observe.py

Arguments follow the request fields of the contract (see controller/cli/arguments.py and
docs/client.md); exit codes are listed in controller/cli/output.py. Any error prints one line
on stderr and exits 2 (1 for a gRPC error status from the daemon), never a traceback.
"""

from __future__ import annotations

import argparse
import difflib
import os
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from rich.console import Console

from controller.cli import arguments, observe, output, watch
from controller.cli.arguments import CliOperation
from controller.cli.wait import Waiter, is_motion
from controller.client.client import DEFAULT_ADDRESS, DEFAULT_CONNECT_TIMEOUT, Client
from controller.client.convert import resolve_enum
from controller.client.errors import ArgumentError, ClientError, RpcFailed
from controller.client.types import RightLeft
from controller.rpc import imotion_pb2, imotion_pb2_grpc
from controller.version import add_version_argument

PROG = "imotion"


class UsageError(Exception):
    """A command line that cannot be run (exit 2)."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (raised, so that main() decides the output) and a
    did-you-mean for unknown options."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message}{self._suggestion(message)}")

    def _suggestion(self, message: str) -> str:
        if not message.startswith("unrecognized arguments:"):
            return ""
        known = [o for o in self._option_string_actions if o.startswith("--")]
        hints = []
        for word in message.split(":", 1)[1].split():
            flag = word.split("=", 1)[0]
            if flag.startswith("--"):
                close = difflib.get_close_matches(flag, known, n=1, cutoff=0.6)
                if close:
                    hints.append(close[0])
        return f"; did you mean {', '.join(hints)}?" if hints else ""


def add_global_options(parser: argparse.ArgumentParser, suppress: bool) -> None:
    """Connection and output options; accepted before and after the operation."""

    def default(value: Any) -> Any:
        return argparse.SUPPRESS if suppress else value

    env = os.environ
    group = parser.add_argument_group("connection and output")
    group.add_argument(
        "--address",
        default=default(env.get("IMOTION_ADDRESS") or DEFAULT_ADDRESS),
        help="daemon address, host:port or unix:/path (env IMOTION_ADDRESS; "
        f"default {DEFAULT_ADDRESS})",
    )
    group.add_argument(
        "--token",
        default=default(env.get("IMOTION_TOKEN") or None),
        help="bearer token (env IMOTION_TOKEN)",
    )
    group.add_argument(
        "--tls-ca",
        metavar="FILE",
        default=default(env.get("IMOTION_TLS_CA") or None),
        help="PEM root certificate of the daemon's TLS certificate; TLS is always used on "
        "non-loopback addresses (env IMOTION_TLS_CA)",
    )
    group.add_argument(
        "--timeout",
        type=float,
        metavar="SEC",
        default=default(DEFAULT_CONNECT_TIMEOUT),
        help=f"connection timeout, s (default {DEFAULT_CONNECT_TIMEOUT:g})",
    )
    group.add_argument(
        "--json", action="store_true", default=default(False), help="print one JSON object"
    )
    group.add_argument(
        "--wait",
        action="store_true",
        default=default(False),
        help="motion commands: wait for the end, with a progress bar on stderr",
    )
    group.add_argument(
        "--wait-timeout",
        type=float,
        metavar="SEC",
        default=default(None),
        help="give up waiting after SEC s (exit 3; the motion goes on)",
    )


def _command_list() -> str:
    lines = ["commands:"]
    for title, group, prefix in (
        ("Spec A, IntegratedMotion", "integrated", ""),
        ("JARA_ARM, one arm (RIGHT is the only arm of a one-arm robot)", "arm", "arm RIGHT|LEFT "),
        ("JARA_ARM_DUAL, both arms", "dual", "dual "),
    ):
        lines.append(f"  {title}: {PROG} {prefix}OPERATION")
        names = list(arguments.operations(group))
        row = "    "
        for name in names:
            if len(row) + len(name) > 96:
                lines.append(row.rstrip())
                row = "    "
            row += name + " "
        lines.append(row.rstrip())
    lines += [
        f"  {PROG} watch [--rate HZ] [--once]   live view of state, joints, poses, alarms",
        f"  {PROG} list                         every operation with its arguments",
        f"  {PROG} record FILE.mcap [--seconds N] record the state stream to MCAP",
        f"  {PROG} plot FILE.mcap               PNG plots of a recording or black-box file",
        f"  {PROG} view [--url URL]             check the live view, print how to open it",
        f"  {PROG} inject KIND [TARGET] [K=V ...] inject a drive fault (--hal hil, test only)",
        f"  {PROG} OPERATION --help              arguments of one operation, with units",
        "",
        "exit status: 0 OK; 11..16 ReturnID NG, STATUS_ERR, VALUE_ERR, NOT_SV_ON_ERR,",
        "FULL_MOTION_QUEUE_ERR, CANNOT_REACH_TARGET_ERR (10 + |id|); 2 bad usage, daemon",
        "unreachable or token refused; 1 gRPC error; 3 --wait timed out; 4 motion ended in",
        "alarm; 130 interrupted.",
    ]
    return "\n".join(lines)


def top_parser() -> Parser:
    parser = Parser(
        prog=PROG,
        description="Command line of the imotion motion-controller daemon.",
        epilog=_command_list(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
        allow_abbrev=False,
    )
    add_global_options(parser, suppress=False)
    add_version_argument(parser)
    parser.add_argument("command", nargs="?", help="an operation, arm, dual, watch or list")
    parser.add_argument("args", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    return parser


def operation_parser(op: CliOperation, prog: str) -> Parser:
    method = op.method
    servicer = getattr(imotion_pb2_grpc, f"{op.service}Servicer")
    doc = (getattr(servicer, method.name).__doc__ or "").strip()
    parser = Parser(
        prog=prog,
        description=" ".join(doc.split()),
        usage=f"{prog} [options] {op.usage()}".rstrip(),
        epilog=arguments.RULES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        allow_abbrev=False,
    )
    arguments.add_arguments(parser, op)
    add_global_options(parser, suppress=True)
    return parser


def _lookup(group: str, name: str | None, prog: str) -> CliOperation:
    if not name:
        raise UsageError(f"{prog}: missing OPERATION ({', '.join(arguments.operations(group))})")
    op = arguments.find(group, name)
    if op is None:
        names = list(arguments.operations(group))
        if group == "integrated":
            names += ["arm", "dual", "watch", "list", "record", "plot", "view", "inject"]
        close = difflib.get_close_matches(name, names, n=1)
        hint = f"; did you mean {close[0]}?" if close else f" (see {PROG} list)"
        raise UsageError(f"{prog}: unknown operation {name!r}{hint}")
    return op


def print_list() -> int:
    for group, prefix in (("integrated", ""), ("arm", "arm RIGHT|LEFT "), ("dual", "dual ")):
        for op in arguments.operations(group).values():
            print(f"{PROG} {prefix}{op.name} {op.usage()}".rstrip())
    return 0


def connect(ns: argparse.Namespace) -> Client:
    return Client.connect(ns.address, token=ns.token, root_certificates=ns.tls_ca,
                          timeout=ns.timeout)  # fmt: skip


def run_watch(rest: list[str], ns: argparse.Namespace) -> int:
    parser = Parser(prog=f"{PROG} watch", description=watch.__doc__, allow_abbrev=False)
    add_global_options(parser, suppress=True)
    parser.add_argument("--rate", type=float, default=10.0, metavar="HZ",
                        help="samples per second (default 10)")  # fmt: skip
    parser.add_argument("--once", action="store_true", help="print one frame and exit")
    parser.parse_args(rest, namespace=ns)
    if not ns.rate >= 0.0 or ns.rate == float("inf"):
        raise UsageError(f"{PROG} watch: --rate must be a finite number >= 0, got {ns.rate}")
    with connect(ns) as client:
        return watch.run(client, ns.rate, ns.once, Console())


INJECT_HELP = """Fault injection into the drive emulator of `imotiond --hal hil` (the daemon
needs `testing.fault_injection: true`; a motion call: the motion token applies).

kinds: emcy [code=0x8110 fault=true], silent, heartbeat_loss, following_error,
refuse_enable, bus_off [bus=NAME], delayed_tpdo [cycles=1]; TARGET is the drive's joint
name (a bus name for bus_off). `--clear [KIND] [TARGET]` ends lasting faults.
Example: imotion inject emcy r_arm_j2 code=0x8110"""


def run_inject(rest: list[str], ns: argparse.Namespace) -> int:
    parser = Parser(prog=f"{PROG} inject", description=INJECT_HELP, allow_abbrev=False,
                    formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    add_global_options(parser, suppress=True)
    parser.add_argument("--clear", action="store_true", help="clear lasting faults instead")
    parser.add_argument("kind", nargs="?", default="", help="fault kind (see above)")
    parser.add_argument("target", nargs="?", default="", help="joint (drive) or bus name")
    parser.add_argument("params", nargs="*", metavar="KEY=VALUE", help="fault parameters")
    parser.parse_intermixed_args(rest, namespace=ns)
    params: dict[str, str] = {}
    for item in ns.params:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"{PROG} inject: parameter {item!r} is not KEY=VALUE")
        params[key] = value
    with connect(ns) as client:
        if ns.clear:
            if params:
                raise UsageError(f"{PROG} inject --clear takes no KEY=VALUE parameters")
            rid, cleared = client.clear_faults(ns.kind, ns.target)
            data: dict[str, object] = {"cleared": cleared}
        else:
            if not ns.kind:
                raise UsageError(f"{PROG} inject: missing KIND (see {PROG} inject --help)")
            rid = client.inject_fault(ns.kind, ns.target, **params)
            data = {}
    if ns.json:
        print(output.json.dumps({"returnId": {"id": rid.id, "comment": rid.comment}, **data}))
    else:
        print(rid)
    return 0 if rid.ok else output.exit_code(rid.id)


def run_observe(command: str, rest: list[str], ns: argparse.Namespace) -> int:
    """record, plot, view (controller/cli/observe.py)."""
    parser = Parser(prog=f"{PROG} {command}", description=observe.__doc__, allow_abbrev=False,
                    formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    add_global_options(parser, suppress=True)
    {"record": observe.add_record_arguments, "plot": observe.add_plot_arguments,
     "view": observe.add_view_arguments}[command](parser)  # fmt: skip
    parser.parse_intermixed_args(rest, namespace=ns)
    try:
        if command == "record":
            observe._finite_positive("--seconds", ns.seconds)
            observe._finite_positive("--rate", ns.rate)
        if command == "view":
            observe._finite_positive("--timeout", ns.timeout)
    except ValueError as exc:
        raise UsageError(f"{PROG} {command}: {exc}") from None
    if command == "record":
        with connect(ns) as client:
            data = observe.record(client, ns.file, ns.seconds, ns.rate, ns.address)
        lines = [f"recorded {data['samples']} samples in {data['seconds']:.1f} s to {ns.file}"]
    elif command == "plot":
        if not ns.file.is_file():
            raise UsageError(f"{PROG} plot: {ns.file}: no such file")
        try:
            from controller.cli.plot import plot_file

            written = plot_file(ns.file, ns.out)
        except ImportError as exc:
            raise UsageError(f"{PROG} plot needs the plot extra "
                             f"(pip install 'imotion[plot]'): {exc}") from None  # fmt: skip
        except Exception as exc:  # an unreadable or foreign file: one line, no traceback
            raise UsageError(f"{PROG} plot: {ns.file}: cannot read it: {exc}") from None
        data = {"file": str(ns.file), "written": [str(p) for p in written]}
        lines = [f"wrote {p}" for p in written] or ["nothing to plot in this file"]
    else:
        try:
            data = observe.view_info(ns.url, ns.timeout, ns.listen)
        except (OSError, TimeoutError, ValueError) as exc:
            raise UsageError(f"{PROG} view: cannot open {ns.url}: {exc} (is view.listen set "
                             "in the daemon's configuration?)") from None  # fmt: skip
        lines = observe.view_lines(data)
    observe.print_result(data, ns.json, lines)
    return 0


def run_operation(group: str, side: RightLeft | None, op: CliOperation, rest: list[str],
                  ns: argparse.Namespace) -> int:  # fmt: skip
    label = {"integrated": op.name, "dual": f"dual {op.name}"}.get(group)
    label = label or f"arm {side.name if side is not None else ''} {op.name}"
    parser = operation_parser(op, f"{PROG} {label}")
    parser.parse_intermixed_args(rest, namespace=ns)
    try:
        values = arguments.bind(op, ns)
    except ArgumentError as exc:
        raise UsageError(f"{PROG} {label}: {exc}") from None
    stderr = Console(stderr=True)
    with connect(ns) as client:
        proxy = {"integrated": client.integrated, "dual": client.dual}.get(group)
        proxy = proxy or client.arm(side if side is not None else RightLeft.RIGHT)
        waiter = Waiter(client, op, values, side) if ns.wait and is_motion(op) else None
        result = getattr(proxy, op.name)(**values)
        code = output.exit_code(result.return_id.id)
        extra: dict[str, Any] = {"service": op.service}
        if group == "arm" and side is not None:
            extra["arm"] = side.name
        notes = []
        if waiter is not None and result.ok:
            outcome = waiter.wait(ns.wait_timeout, stderr, show=stderr.is_terminal)
            extra["wait"] = {
                "finished": outcome.finished,
                "alarm": outcome.alarm,
                "seconds": round(outcome.seconds, 3),
                "alarms": outcome.alarms,
            }
            if outcome.alarm:
                code = output.EXIT_ALARM
                notes.append(f"wait: the motion ended in alarm after {outcome.seconds:.1f} s")
                notes += [f"  {output.fmt_value('alarm', a)}" for a in outcome.alarms]
            elif not outcome.finished:
                code = output.EXIT_WAIT_TIMEOUT
                notes.append(f"wait: still moving after {outcome.seconds:.1f} s")
            else:
                notes.append(f"wait: done in {outcome.seconds:.1f} s")
    if ns.json:
        print(output.result_json(result, op.name, extra))
    else:
        print(output.result_text(result, op.name))
        for note in notes:
            print(note)
    return code


def run(argv: Sequence[str] | None) -> int:
    ns = top_parser().parse_args(argv)
    command: str | None = ns.command
    rest: list[str] = list(ns.args)
    if command is None:
        top_parser().print_help()
        return output.EXIT_USAGE
    if command == "list":
        return print_list()
    if command == "watch":
        return run_watch(rest, ns)
    if command in ("record", "plot", "view"):
        return run_observe(command, rest, ns)
    if command == "inject":
        return run_inject(rest, ns)
    if command == "arm":
        if not rest:
            raise UsageError(f"{PROG} arm: missing RIGHT|LEFT")
        try:
            number = resolve_enum(imotion_pb2.RightLeft.DESCRIPTOR, rest[0], "arm")
        except ArgumentError as exc:
            raise UsageError(f"{PROG} {exc}") from None
        side = RightLeft(number)
        op = _lookup("arm", rest[1] if len(rest) > 1 else None, f"{PROG} arm {side.name}")
        return run_operation("arm", side, op, rest[2:], ns)
    if command == "dual":
        op = _lookup("dual", rest[0] if rest else None, f"{PROG} dual")
        return run_operation("dual", None, op, rest[1:], ns)
    op = _lookup("integrated", command, PROG)
    return run_operation("integrated", None, op, rest, ns)


def _fail(message: str, code: int, as_json: bool) -> int:
    print(" ".join(message.split()), file=sys.stderr)
    if as_json:
        print(output.json.dumps({"error": message, "exitCode": code}))
    return code


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``imotion`` console script; returns the exit status."""
    args = list(sys.argv[1:] if argv is None else argv)
    as_json = "--json" in args
    try:
        return run(args)
    except UsageError as exc:
        return _fail(str(exc), output.EXIT_USAGE, as_json)
    except RpcFailed as exc:
        return _fail(f"{PROG}: {exc}", output.EXIT_RPC_ERROR, as_json)
    except ClientError as exc:  # unreachable, token refused, unreadable certificate, bad value
        return _fail(f"{PROG}: {exc}", output.EXIT_USAGE, as_json)
    except KeyboardInterrupt:
        return _fail(f"{PROG}: interrupted", output.EXIT_INTERRUPTED, as_json)
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
