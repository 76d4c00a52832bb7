"""controller.control.realtime: fallbacks warn in one line and report; the real call in a
subprocess.

No test may leave the pytest process under SCHED_FIFO or with its memory locked: every
successful path here is either faked or run in a child process.
"""

from __future__ import annotations

import ctypes
import errno
import gc
import json
import logging
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from controller.control import realtime
from controller.control.realtime import RealtimeReport, apply_realtime, restore

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _process_stays_normal():
    policy = os.sched_getscheduler(0)
    freeze = gc.get_freeze_count()
    yield
    assert os.sched_getscheduler(0) == policy, "a test left the process with another policy"
    assert policy != os.SCHED_FIFO
    assert gc.get_freeze_count() == freeze, "a test left gc frozen"


def refuse(*_args):
    raise PermissionError(errno.EPERM, "Operation not permitted")


class FakeLibc:
    """A libc whose mlockall fails with ``code`` (0: succeeds)."""

    def __init__(self, code: int):
        self.code = code
        self.calls: list[str] = []

    def mlockall(self, flags: int) -> int:
        self.calls.append(f"mlockall({flags})")
        if self.code:
            ctypes.set_errno(self.code)
            return -1
        return 0

    def munlockall(self) -> int:
        self.calls.append("munlockall")
        return 0


def warnings_of(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    return [r for r in caplog.records if r.name == "controller.control.realtime"]


def assert_clean_one_line_warnings(records: list[logging.LogRecord], count: int) -> None:
    assert len(records) == count
    for record in records:
        assert record.levelno == logging.WARNING
        assert record.exc_info is None and record.exc_text is None
        assert "\n" not in record.getMessage()
        assert "not" in record.getMessage()


def test_refused_scheduler_and_memory_lock_warn_and_report(monkeypatch, caplog):
    libc = FakeLibc(errno.ENOMEM)
    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    monkeypatch.setattr(realtime, "_libc", lambda: libc)
    caplog.set_level(logging.WARNING, logger="controller.control.realtime")
    report = apply_realtime(priority=70)
    try:
        assert not report.fifo and not report.memory_locked and report.gc_frozen
        assert report.priority == 70
        assert not report.all_in_effect
        assert len(report.messages) == 2
        fifo, memory = report.messages
        assert "SCHED_FIFO priority 70 not in effect" in fifo
        assert "Operation not permitted" in fifo and "CAP_SYS_NICE" in fifo
        assert "memory not locked" in memory and os.strerror(errno.ENOMEM) in memory
        assert libc.calls == ["mlockall(3)"]
        records = warnings_of(caplog)
        assert_clean_one_line_warnings(records, 2)
        assert [r.getMessage() for r in records] == report.messages
    finally:
        restore(report)
    assert report.restored and report.gc_frozen  # still says what was in effect
    assert libc.calls == ["mlockall(3)"]  # nothing to unlock


def test_missing_libc_and_scheduler_api_are_reported(monkeypatch, caplog):
    def no_libc():
        raise OSError("the C library was not found")

    monkeypatch.delattr(os, "sched_setscheduler")
    monkeypatch.setattr(realtime, "_libc", no_libc)
    caplog.set_level(logging.WARNING, logger="controller.control.realtime")
    report = apply_realtime(freeze_gc=False)
    assert not report.fifo and not report.memory_locked and not report.gc_frozen
    assert "not supported on this platform" in report.messages[0]
    assert "libc unavailable" in report.messages[1]
    assert_clean_one_line_warnings(warnings_of(caplog), 2)
    restore(report)


def test_scheduler_os_error_other_than_permission(monkeypatch, caplog):
    def invalid(*_args):
        raise OSError(errno.EINVAL, "Invalid argument")

    monkeypatch.setattr(os, "sched_setscheduler", invalid)
    caplog.set_level(logging.WARNING, logger="controller.control.realtime")
    report = apply_realtime(lock_memory=False, freeze_gc=False)
    assert report.messages == ["real-time: SCHED_FIFO priority 80 not in effect: Invalid argument"]
    assert_clean_one_line_warnings(warnings_of(caplog), 1)


def test_success_is_reported_and_restored(monkeypatch, caplog):
    calls: list[tuple[int, int, int]] = []
    libc = FakeLibc(0)
    monkeypatch.setattr(
        os, "sched_setscheduler", lambda pid, pol, p: calls.append((pid, pol, p.sched_priority))
    )
    monkeypatch.setattr(realtime, "_libc", lambda: libc)
    caplog.set_level(logging.WARNING, logger="controller.control.realtime")
    previous = os.sched_getscheduler(0)
    report = apply_realtime(priority=90, helper_priority=0)
    assert report.fifo and report.memory_locked and report.gc_frozen and report.all_in_effect
    assert report.previous_policy == previous
    assert calls == [(0, os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 90)]
    assert warnings_of(caplog) == []
    restore(report)
    assert calls[-1] == (0, previous, report.previous_priority)
    assert libc.calls == ["mlockall(3)", "munlockall"]
    assert report.restored and report.fifo and report.memory_locked and report.gc_frozen


def test_nothing_requested_but_the_scheduler(monkeypatch):
    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    monkeypatch.setattr(realtime, "_libc", lambda: pytest.fail("libc must not be loaded"))
    report = apply_realtime(lock_memory=False, freeze_gc=False)
    assert len(report.messages) == 1
    assert not report.memory_locked and not report.gc_frozen


@pytest.mark.parametrize("priority", [0, 100, -5])
def test_priority_out_of_range(priority: int):
    with pytest.raises(ValueError, match=r"1\.\.99"):
        apply_realtime(priority=priority)


@pytest.mark.parametrize("helper", [-1, 80, 90])
def test_helper_priority_must_be_below_the_loops(helper: int):
    with pytest.raises(ValueError, match=r"below the loop's"):
        apply_realtime(priority=80, helper_priority=helper)


def _helper_thread() -> tuple[threading.Thread, threading.Event]:
    release = threading.Event()
    thread = threading.Thread(target=release.wait, name="helper-under-test", daemon=True)
    thread.start()
    return thread, release


def test_helper_threads_go_to_the_lowest_fifo_priority_and_back(monkeypatch):
    calls: list[tuple[int, int, int]] = []
    monkeypatch.setattr(
        os, "sched_setscheduler", lambda pid, pol, p: calls.append((pid, pol, p.sched_priority))
    )
    monkeypatch.setattr(realtime, "_libc", lambda: FakeLibc(0))
    thread, release = _helper_thread()
    try:
        report = apply_realtime(priority=80, freeze_gc=False)
        assert (thread.native_id, "helper-under-test") in report.helpers
        assert (thread.native_id, os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, 1) in calls
        assert all(tid != threading.get_native_id() for tid, _ in report.helpers)
        calls.clear()
        restore(report)
        assert (thread.native_id, os.SCHED_OTHER, 0) in calls
    finally:
        release.set()
        thread.join()


def test_refused_helper_threads_are_reported(monkeypatch, caplog):
    def only_self(pid, pol, p):
        if pid:
            refuse()

    monkeypatch.setattr(os, "sched_setscheduler", only_self)
    caplog.set_level(logging.WARNING, logger="controller.control.realtime")
    thread, release = _helper_thread()
    try:
        report = apply_realtime(lock_memory=False, freeze_gc=False)
        assert report.fifo and report.helpers == []
        assert any("'helper-under-test' not at SCHED_FIFO 1" in m for m in report.messages)
        assert_clean_one_line_warnings(warnings_of(caplog), len(report.messages))
        restore(report)
    finally:
        release.set()
        thread.join()


def _in_a_thread(fn):
    """``fn()``'s result, run in a throwaway thread (affinity belongs to a thread: the pytest
    thread's is never touched)."""
    out: list = []
    thread = threading.Thread(target=lambda: out.append(fn()))
    thread.start()
    thread.join()
    return out[0]


def test_the_loop_thread_is_pinned_and_restored(monkeypatch):
    monkeypatch.setattr(os, "sched_setscheduler", lambda *a: None)
    cpu = min(os.sched_getaffinity(0))

    def pin_and_restore():
        before = os.sched_getaffinity(0)
        report = apply_realtime(lock_memory=False, freeze_gc=False, cpus=[cpu])
        during = os.sched_getaffinity(0)
        restore(report)
        return before, report, during, os.sched_getaffinity(0)

    before, report, during, after = _in_a_thread(pin_and_restore)
    assert report.cpus == [cpu] and during == {cpu} and not report.messages
    assert report.previous_cpus == sorted(before) and after == before
    assert os.sched_getaffinity(0) == before  # this thread never moved


def test_the_switch_interval_is_set_and_restored(monkeypatch):
    monkeypatch.setattr(os, "sched_setscheduler", lambda *a: None)
    before = sys.getswitchinterval()
    report = apply_realtime(lock_memory=False, freeze_gc=False, switch_interval=2e-4)
    try:
        assert (
            report.switch_interval == pytest.approx(2e-4)
            and report.previous_switch_interval == before
        )
        assert sys.getswitchinterval() == pytest.approx(2e-4)
    finally:
        restore(report)
    assert sys.getswitchinterval() == before
    assert apply_realtime(lock_memory=False, freeze_gc=False).switch_interval is None


@pytest.mark.parametrize("interval", [0.0, -1.0, 2.0, float("nan")])
def test_a_switch_interval_out_of_range_is_refused(interval: float):
    before = sys.getswitchinterval()
    with pytest.raises(ValueError, match="switch interval"):
        apply_realtime(switch_interval=interval)
    assert sys.getswitchinterval() == before


@pytest.mark.parametrize("cpu", [-1, 4095])
def test_a_cpu_that_cannot_be_had_warns_and_leaves_the_affinity(monkeypatch, caplog, cpu):
    monkeypatch.setattr(os, "sched_setscheduler", lambda *a: None)
    caplog.set_level(logging.WARNING, logger="controller.control.realtime")

    def try_pin():
        before = os.sched_getaffinity(0)
        report = apply_realtime(lock_memory=False, freeze_gc=False, cpus=[cpu])
        return before, report, os.sched_getaffinity(0)

    before, report, after = _in_a_thread(try_pin)
    assert report.cpus is None and after == before
    (message,) = report.messages
    assert f"not pinned to CPU {cpu}" in message and "may run on CPU" in message
    assert_clean_one_line_warnings(warnings_of(caplog), 1)


@pytest.mark.parametrize("unprivileged", [False, True])
def test_real_call_in_a_child_process(unprivileged: bool):
    """The real system calls, whatever this machine allows, in a throwaway process.

    ``unprivileged``: as root, the child first drops to user ``nobody`` so the real refusal
    paths run too.
    """
    if unprivileged and os.geteuid() != 0:
        pytest.skip("dropping privileges needs root")
    code = (
        "import json, os, gc\n"
        "from controller.control.realtime import apply_realtime, restore\n"
        # Drop after the imports: the interpreter's files need not be readable by nobody.
        + ("os.setgid(65534); os.setuid(65534)\n" if unprivileged else "")
        + "import threading\n"
        "release = threading.Event()\n"
        "helper = threading.Thread(target=release.wait); helper.start()\n"
        "before = os.sched_getscheduler(0)\n"
        "r = apply_realtime(priority=10)\n"
        "during = os.sched_getscheduler(0) & ~os.SCHED_RESET_ON_FORK\n"
        "helper_policy = os.sched_getscheduler(helper.native_id)\n"
        "helper_during = helper_policy & ~os.SCHED_RESET_ON_FORK\n"
        "helper_resets = bool(helper_policy & os.SCHED_RESET_ON_FORK)\n"
        "started = []\n"
        "later = threading.Thread(target=lambda: started.append(os.sched_getscheduler(0)))\n"
        "later.start(); later.join()\n"
        "frozen = gc.get_freeze_count()\n"
        "flags = [r.fifo, r.memory_locked, r.gc_frozen]\n"
        "restore(r)\n"
        "helper_after = os.sched_getscheduler(helper.native_id)\n"
        "release.set(); helper.join()\n"
        "print(json.dumps({'flags': flags, 'messages': r.messages, 'before': before,\n"
        "  'during': during, 'after': os.sched_getscheduler(0), 'frozen': frozen,\n"
        "  'unfrozen': gc.get_freeze_count(), 'fifo': os.SCHED_FIFO,\n"
        "  'helper': [helper_during, helper_after], 'later': started[0],\n"
        "  'helper_resets': helper_resets}))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    fifo, locked, frozen = result["flags"]
    assert frozen and result["frozen"] > 0 and result["unfrozen"] == 0
    assert (result["during"] == result["fifo"]) == fifo
    assert result["after"] == result["before"]
    # The other thread at FIFO 1 while the loop is real-time, and back; a thread the loop
    # thread starts is an ordinary one (SCHED_RESET_ON_FORK), never at the loop's priority.
    assert result["helper"] == ([result["fifo"], 0] if fifo else [0, 0])
    # ...and what a helper starts (a restarted gateway process) is ordinary again.
    assert result["helper_resets"] == fifo
    assert result["later"] == 0
    # Every measure not in effect has its one-line message, and each was logged once.
    assert len(result["messages"]) == (not fifo) + (not locked)
    logged = [line for line in out.stderr.splitlines() if "real-time:" in line]
    assert len(logged) == len(result["messages"])
    assert "Traceback" not in out.stderr


def test_report_defaults():
    report = RealtimeReport()
    assert report.all_in_effect and not report.fifo and report.messages == []
