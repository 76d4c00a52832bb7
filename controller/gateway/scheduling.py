"""The gateway process's claim on the CPU: an ordinary (never real-time) process, its nice
value (``gateway_nice``), and its heap frozen out of the garbage collector's full
collections.

The control loop is real-time (SCHED_FIFO) and does not care; the gateway is an ordinary
(SCHED_OTHER) process, and on a machine that also runs other work its threads wait in the
run queue behind that work's threads: the reads' latency tail follows that wait
(docs/daemon.md, "Reads under client load"). A lower nice value gives the gateway a larger
CFS weight than ordinary processes (nice -5: ~3x, -10: ~9x a nice-0 process's share when
both want the CPU); never a real-time policy, which would let client load preempt the loop.
"""

from __future__ import annotations

import gc
import os
from pathlib import Path

#: Where Linux lists a process's threads: nice is a per-thread value there.
TASKS = Path("/proc/self/task")


def _threads() -> list[int]:
    """Ids of this process's threads (Linux), else ``[0]`` (the calling thread/process)."""
    try:
        return sorted(int(name) for name in os.listdir(TASKS))
    except OSError:
        return [0]


def apply_nice(nice: int) -> str | None:
    """Give every thread of this process the nice value ``nice`` [-20..19]; threads started
    afterwards inherit it from the thread that starts them (gRPC's, the worker pools').

    Returns None when in effect, else a warning saying why not (lowering nice needs root,
    CAP_SYS_NICE or an RLIMIT_NICE allowing it, e.g. ``LimitNICE=`` in the systemd unit); the
    threads then keep the nice value they had. Never raises.
    """
    if not hasattr(os, "setpriority"):
        return f"gateway_nice {nice} not in effect: not supported on this platform"
    try:
        before: int | None = os.getpriority(os.PRIO_PROCESS, 0)
    except OSError:
        before = None
    done: list[int] = []
    for tid in _threads():
        try:
            os.setpriority(os.PRIO_PROCESS, tid, nice)
        except ProcessLookupError:  # the thread ended meanwhile
            continue
        except OSError as exc:
            for back in done:  # all or nothing: one nice value for the whole process
                try:
                    os.setpriority(os.PRIO_PROCESS, back, before if before is not None else 0)
                except OSError:
                    pass
            hint = ""
            if isinstance(exc, PermissionError):
                hint = (
                    " (lowering nice needs root, CAP_SYS_NICE or a nice limit, e.g. "
                    f"LimitNICE={nice} in the systemd unit)"
                )
            reason = exc.strerror or exc.__class__.__name__
            return (
                f"gateway_nice {nice} not in effect, the gateway stays at nice {before}: "
                f"{reason}{hint}"
            )
        done.append(tid)
    return None


def leave_real_time() -> str | None:
    """Put every thread of this process back under SCHED_OTHER if it inherited a real-time
    policy, and say so (None when it had not).

    A child inherits the scheduling policy of the thread that forked it: imotiond restarts a
    dead gateway from its supervising thread, which runs at SCHED_FIFO 1 (the control
    process's helper threads share the loop's GIL), and the new gateway then ran every
    thread at SCHED_FIFO 1: under client load it would starve every ordinary process, nice
    values notwithstanding. Switching to SCHED_OTHER needs no privilege. Never raises.
    """
    if not hasattr(os, "sched_getscheduler"):
        return None
    changed: list[str] = []
    for tid in _threads():
        try:
            policy = os.sched_getscheduler(tid)
            if policy in (os.SCHED_OTHER, getattr(os, "SCHED_BATCH", -1)):
                continue
            os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
        except ProcessLookupError:
            continue
        except OSError as exc:
            return f"the gateway inherited a real-time policy and cannot leave it: {exc}"
        changed.append(str(tid))
    if not changed:
        return None
    return (
        f"the gateway inherited a real-time policy from the thread that started it: "
        f"{len(changed)} thread(s) back to SCHED_OTHER"
    )


def freeze_heap() -> int:
    """Collect once, then move every object alive now (the robot model, the planner, the
    modules, gRPC) into the permanent generation: the collector's full collections then
    traverse only what was made since, instead of the whole ~200 MB heap. A full collection
    of it held the GIL 130-200 ms in the gateway (measured in tools/bench_clients.py's paced
    phase): every read waited for it. Frozen objects are still freed by reference counting.
    Returns how many objects were frozen.
    """
    gc.collect()
    gc.freeze()
    return gc.get_freeze_count()
