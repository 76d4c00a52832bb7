"""Best-effort real-time setup of the control thread: SCHED_FIFO, locked memory, frozen GC.

:func:`apply_realtime` tries each measure and never raises for a missing privilege or
platform feature: what is not in effect is logged as one warning line (no traceback) and
recorded in the returned :class:`RealtimeReport`. :func:`restore` undoes what took effect.

* **SCHED_FIFO** via :func:`os.sched_setscheduler` with pid 0. On Linux the scheduling policy
  belongs to a thread, so this changes the *calling thread* only: call it from the control
  thread. Needs root, CAP_SYS_NICE or an rtprio limit (``LimitRTPRIO=`` in a systemd unit).
  With SCHED_RESET_ON_FORK: a thread the control thread starts later is an ordinary one,
  never a second thread at the loop's priority.
* **Helper threads at SCHED_FIFO** ``helper_priority`` (1 by default, 0: left alone): every
  other Python thread alive at the call (command channels, log writer, CAN heartbeat, ...).
  They share the loop's GIL: an ordinary thread that the kernel preempts for another process
  while it holds the GIL makes the loop wait until it runs again, milliseconds on a busy
  machine (``tools/bench_loop.py``, 30 s at load 2.5: compute p99 776 -> 536 µs, late
  cycles 5 -> 2). At the lowest real-time priority they still yield to the loop, but no
  ordinary process preempts them. With SCHED_RESET_ON_FORK too: what they start later
  (threads, and processes such as a restarted gateway) is ordinary. Start helper threads
  before the call.
* **mlockall(MCL_CURRENT | MCL_FUTURE)** through libc (ctypes): page faults no longer stall
  the loop. Process-wide. Needs CAP_IPC_LOCK or a large enough ``RLIMIT_MEMLOCK``
  (``LimitMEMLOCK=infinity``).
* **gc.freeze()**: moves every object alive now into the permanent generation, so the
  collector's passes during the loop only scan what the loop allocates. Process-wide.
* **GIL switch interval** (``switch_interval``, optional) via :func:`sys.setswitchinterval`:
  how long another thread of the process may keep the GIL once the loop thread asks for it
  (Python's default, 5 ms, shows up as late cycles whenever a helper thread runs Python).
  Process-wide.
* **CPU affinity** (``cpus``, optional) via :func:`os.sched_setaffinity` with pid 0: the
  calling thread only runs on those CPUs; it keeps its caches and never migrates. Meant for
  a core kept free of other work (``isolcpus=`` on the kernel command line, or the rest of
  the system moved off it with systemd's ``CPUAffinity=``). Threads the loop thread starts
  later inherit it. A CPU that is offline or outside the process's cpuset is refused
  (warning, affinity unchanged).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import errno
import gc
import logging
import os
import sys
import threading
from collections.abc import Collection
from dataclasses import dataclass, field
from typing import Any

_log = logging.getLogger(__name__)

#: mlockall flags (Linux generic values; x86, arm, riscv).
MCL_CURRENT = 1
MCL_FUTURE = 2


@dataclass
class RealtimeReport:
    """Which real-time measures are in effect, and one message per measure that is not."""

    #: The calling thread runs under SCHED_FIFO at :attr:`priority`.
    fifo: bool = False
    #: All current and future pages of the process are locked in RAM.
    memory_locked: bool = False
    #: gc.freeze() moved the objects alive at the call into the permanent generation.
    gc_frozen: bool = False
    #: Requested SCHED_FIFO priority (1..99).
    priority: int = 0
    #: One line per requested measure not in effect: what and why.
    messages: list[str] = field(default_factory=list)
    #: Scheduling policy and priority of the thread before the call, for :func:`restore`.
    previous_policy: int | None = None
    previous_priority: int | None = None
    #: Helper threads moved to SCHED_FIFO: (native thread id, name), back to normal on restore.
    helpers: list[tuple[int, str]] = field(default_factory=list)
    #: CPUs the calling thread is pinned to (None: not pinned), and its CPUs before.
    cpus: list[int] | None = None
    previous_cpus: list[int] | None = None
    #: The GIL switch interval set [s] (None: left alone), and the one before.
    switch_interval: float | None = None
    previous_switch_interval: float | None = None
    #: Set by :func:`restore`; the flags above keep saying what was in effect.
    restored: bool = False

    @property
    def all_in_effect(self) -> bool:
        """True when every requested measure took effect."""
        return not self.messages


def apply_realtime(
    priority: int = 80,
    lock_memory: bool = True,
    freeze_gc: bool = True,
    helper_priority: int = 1,
    cpus: Collection[int] | None = None,
    switch_interval: float | None = None,
) -> RealtimeReport:
    """Make the calling thread real-time as far as allowed; see the module docstring.

    ``priority`` is the SCHED_FIFO priority, 1 (lowest) to 99; ``helper_priority`` the other
    Python threads' (below ``priority``; 0: leave them alone); ``cpus``: pin the calling
    thread to these CPUs (None or empty: leave its affinity); ``switch_interval`` [s]: the
    process's GIL switch interval (None: leave it). Each measure that fails is logged as a
    warning and left out; the report says what is in effect.
    """
    if not 1 <= priority <= 99:
        raise ValueError(f"SCHED_FIFO priority must be 1..99, got {priority}")
    if not 0 <= helper_priority < priority:
        raise ValueError(
            f"helper SCHED_FIFO priority must be 0..{priority - 1} (below the loop's), "
            f"got {helper_priority}"
        )
    if switch_interval is not None and not 0.0 < switch_interval <= 1.0:
        raise ValueError(f"switch interval must be within (0, 1] s, got {switch_interval!r}")
    report = RealtimeReport(priority=priority)
    if switch_interval is not None:
        report.previous_switch_interval = sys.getswitchinterval()
        sys.setswitchinterval(switch_interval)
        report.switch_interval = sys.getswitchinterval()
    _set_fifo(report)
    if report.fifo and helper_priority:
        _set_helpers(report, helper_priority)
    if cpus:
        _pin(report, sorted(set(cpus)))
    if lock_memory:
        _lock_memory(report)
    if freeze_gc:
        gc.freeze()
        report.gc_frozen = True
    for message in report.messages:
        _log.warning("%s", message)
    return report


def restore(report: RealtimeReport) -> None:
    """Undo what ``report`` says took effect (once). Call from the thread that applied it."""
    if report.restored:
        return
    report.restored = True
    if report.fifo and report.previous_policy is not None:
        param = os.sched_param(report.previous_priority or 0)
        os.sched_setscheduler(0, report.previous_policy, param)
    for tid, _ in report.helpers:
        try:
            os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
        except OSError:  # ended meanwhile
            pass
    if report.previous_switch_interval is not None:
        sys.setswitchinterval(report.previous_switch_interval)
    if report.cpus is not None and report.previous_cpus is not None:
        try:
            os.sched_setaffinity(0, report.previous_cpus)
        except OSError as exc:  # a CPU went offline meanwhile
            _log.warning("real-time restore: CPU affinity not restored: %s", _reason(exc))
    if report.memory_locked:
        try:
            _libc().munlockall()
        except (OSError, AttributeError) as exc:
            _log.warning("real-time restore: munlockall failed: %s", _reason(exc))
    if report.gc_frozen:
        gc.unfreeze()


def _set_fifo(report: RealtimeReport) -> None:
    what = f"SCHED_FIFO priority {report.priority} not in effect"
    if not hasattr(os, "sched_setscheduler") or not hasattr(os, "SCHED_FIFO"):
        report.messages.append(f"real-time: {what}: not supported on this platform")
        return
    try:
        report.previous_policy = os.sched_getscheduler(0)
        report.previous_priority = os.sched_getparam(0).sched_priority
        policy = os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0)
        os.sched_setscheduler(0, policy, os.sched_param(report.priority))
    except OSError as exc:
        hint = ""
        if isinstance(exc, PermissionError):
            hint = " (needs root, CAP_SYS_NICE or an rtprio limit, e.g. LimitRTPRIO=)"
        report.messages.append(f"real-time: {what}: {_reason(exc)}{hint}")
        return
    report.fifo = True


def _set_helpers(report: RealtimeReport, priority: int) -> None:
    """Every other Python thread that runs under the normal policy: SCHED_FIFO ``priority``."""
    me = threading.get_ident()
    for thread in threading.enumerate():
        tid = thread.native_id
        if thread.ident == me or tid is None:
            continue
        try:
            if os.sched_getscheduler(tid) != os.SCHED_OTHER:
                continue
            policy = os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0)
            os.sched_setscheduler(tid, policy, os.sched_param(priority))
        except OSError as exc:  # ended meanwhile, or refused: it stays an ordinary thread
            if not isinstance(exc, ProcessLookupError):
                report.messages.append(
                    f"real-time: thread {thread.name!r} not at SCHED_FIFO {priority}: "
                    f"{_reason(exc)}"
                )
            continue
        report.helpers.append((tid, thread.name))


def _pin(report: RealtimeReport, cpus: list[int]) -> None:
    """The calling thread on ``cpus`` only."""
    what = f"loop thread not pinned to CPU {','.join(map(str, cpus))}"
    if not hasattr(os, "sched_setaffinity"):
        report.messages.append(f"real-time: {what}: not supported on this platform")
        return
    try:
        previous = sorted(os.sched_getaffinity(0))
        os.sched_setaffinity(0, cpus)
    except (OSError, ValueError, OverflowError) as exc:
        online = ",".join(map(str, sorted(os.sched_getaffinity(0))))
        report.messages.append(
            f"real-time: {what}: {_reason(exc)} (this process may run on CPU {online})"
        )
        return
    report.previous_cpus = previous
    report.cpus = sorted(os.sched_getaffinity(0))


def _lock_memory(report: RealtimeReport) -> None:
    what = "memory not locked (mlockall)"
    try:
        libc = _libc()
        result = libc.mlockall(MCL_CURRENT | MCL_FUTURE)
    except (OSError, AttributeError) as exc:
        report.messages.append(f"real-time: {what}: libc unavailable: {_reason(exc)}")
        return
    if result != 0:
        code = ctypes.get_errno()
        hint = ""
        if code in (errno.EPERM, errno.ENOMEM):
            hint = " (needs CAP_IPC_LOCK or a larger RLIMIT_MEMLOCK, e.g. LimitMEMLOCK=infinity)"
        report.messages.append(f"real-time: {what}: {os.strerror(code)}{hint}")
        return
    report.memory_locked = True


def _libc() -> Any:
    """The C library, loaded with errno capture. Raises OSError when it cannot be found."""
    name = ctypes.util.find_library("c")
    if name is None:
        raise OSError("the C library was not found")
    return ctypes.CDLL(name, use_errno=True)


def _reason(exc: BaseException) -> str:
    """A one-line reason for ``exc``: its strerror when it has one."""
    text = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
    return " ".join(str(text).split())
