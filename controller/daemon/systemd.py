"""systemd integration without libsystemd: sd_notify datagrams and the watchdog period.

``notify("READY=1")`` etc. send to ``$NOTIFY_SOCKET`` (a path, or ``@name`` for the abstract
namespace); outside systemd they do nothing. :func:`watchdog_period` reads
``$WATCHDOG_USEC`` (and ``$WATCHDOG_PID``, which must be ours when set).
"""

from __future__ import annotations

import os
import socket


def notify(*lines: str) -> bool:
    """Send ``KEY=VALUE`` lines to systemd; False when not run by systemd (or on error)."""
    address = os.environ.get("NOTIFY_SOCKET")
    if not address:
        return False
    if address.startswith("@"):
        address = "\0" + address[1:]
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
            sock.connect(address)
            sock.sendall("\n".join(lines).encode())
        return True
    except OSError:
        return False


def watchdog_period() -> float | None:
    """systemd's watchdog interval [s] for this process, or None when there is none."""
    usec = os.environ.get("WATCHDOG_USEC")
    if not usec:
        return None
    pid = os.environ.get("WATCHDOG_PID")
    if pid and pid.isdigit() and int(pid) != os.getpid():
        return None
    try:
        value = int(usec)
    except ValueError:
        return None
    return value / 1e6 if value > 0 else None
