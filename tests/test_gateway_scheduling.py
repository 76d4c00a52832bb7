"""controller.gateway.scheduling: the gateway's nice value (every thread, or a warning and
nothing changed) and its heap frozen out of the full collections."""

from __future__ import annotations

import gc
import os
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from controller.gateway import scheduling

LINUX = Path("/proc/self/task").is_dir()


@pytest.fixture
def a_thread() -> Iterator[int]:
    """A second thread of this process, alive during the test; yields its id."""
    done = threading.Event()
    thread = threading.Thread(target=done.wait, daemon=True)
    thread.start()
    assert thread.native_id is not None
    yield thread.native_id
    done.set()
    thread.join()


class FakePriorities:
    """os.getpriority / os.setpriority on a dict (thread id -> nice); ``refuse`` makes
    setpriority raise that error for a value below the current one (as Linux does)."""

    def __init__(self, threads: list[int], nice: int = 0, refuse_after: int | None = None):
        self.nice = dict.fromkeys(threads, nice)
        self.nice[0] = nice
        self.calls: list[tuple[int, int]] = []
        self.refuse_after = refuse_after  #: lowering refused once this many calls succeeded

    def get(self, which: int, who: int) -> int:
        return self.nice[who]

    def set(self, which: int, who: int, value: int) -> None:
        lowering = value < self.nice[who]
        if lowering and self.refuse_after is not None and len(self.calls) >= self.refuse_after:
            raise PermissionError(13, "Permission denied")
        self.calls.append((who, value))
        self.nice[who] = value


def _install(monkeypatch: pytest.MonkeyPatch, fake: FakePriorities, threads: list[int]) -> None:
    monkeypatch.setattr(scheduling.os, "getpriority", fake.get)
    monkeypatch.setattr(scheduling.os, "setpriority", fake.set)
    monkeypatch.setattr(scheduling, "_threads", lambda: list(threads))


def test_every_thread_gets_the_nice_value_when_permitted(monkeypatch, a_thread):
    threads = scheduling._threads()
    assert a_thread in threads or not LINUX
    fake = FakePriorities(threads)
    _install(monkeypatch, fake, threads)
    assert scheduling.apply_nice(-5) is None
    assert sorted(fake.calls) == sorted((tid, -5) for tid in threads)


def test_not_permitted_warns_and_changes_nothing(monkeypatch):
    threads = [101, 102, 103]
    fake = FakePriorities(threads, refuse_after=0)
    _install(monkeypatch, fake, threads)
    warning = scheduling.apply_nice(-5)
    assert warning is not None
    assert "gateway_nice -5 not in effect" in warning
    assert "stays at nice 0" in warning and "Permission denied" in warning
    assert "LimitNICE=-5" in warning  # says how to permit it
    assert all(fake.nice[t] == 0 for t in threads)


def test_refused_part_way_puts_the_threads_back(monkeypatch):
    threads = [101, 102, 103]
    fake = FakePriorities(threads, refuse_after=1)
    _install(monkeypatch, fake, threads)
    assert scheduling.apply_nice(-10) is not None
    assert all(fake.nice[t] == 0 for t in threads)  # one nice value for the whole process


def test_a_thread_that_ended_meanwhile_is_skipped(monkeypatch):
    threads = [101, 102]
    fake = FakePriorities(threads)
    real_set = fake.set

    def gone_then_set(which: int, who: int, value: int) -> None:
        if who == 101:
            raise ProcessLookupError(3, "No such process")
        real_set(which, who, value)

    _install(monkeypatch, fake, threads)
    monkeypatch.setattr(scheduling.os, "setpriority", gone_then_set)
    assert scheduling.apply_nice(-5) is None
    assert fake.nice[102] == -5


@pytest.mark.skipif(not LINUX, reason="per-thread nice values: Linux")
def test_real_threads_and_those_started_later_get_it():
    """For real, in a child process: raising nice is always permitted. Threads alive before
    and a thread started afterwards all run at the value (Linux keeps nice per thread)."""
    code = """
import os, threading
from pathlib import Path
from controller.gateway.scheduling import apply_nice
ev = threading.Event()
before = threading.Thread(target=ev.wait); before.start()
assert apply_nice(os.getpriority(os.PRIO_PROCESS, 0) + 3) is None
after = threading.Thread(target=ev.wait); after.start()
nices = [int((t / "stat").read_text().rsplit(")", 1)[1].split()[16])
         for t in Path("/proc/self/task").iterdir()]
ev.set(); before.join(); after.join()
print(sorted(set(nices)), len(nices))
"""
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert out.returncode == 0, out.stderr
    values, count = out.stdout.split("]")
    expected = min(19, os.getpriority(os.PRIO_PROCESS, 0) + 3)
    assert values.strip("[ ") == str(expected)
    assert int(count) >= 3


def test_freeze_heap_leaves_the_full_collections_little_to_traverse():
    """A full collection traverses every tracked object: the gateway's whole heap (130-200
    ms holding the GIL, every read waiting). Frozen, they are out of its reach."""
    tracked = len(gc.get_objects())
    try:
        frozen = scheduling.freeze_heap()
        # Frozen objects that die are still freed (and leave the permanent generation), so
        # the count read again can only be lower: not equal (it was, flakily).
        assert frozen >= gc.get_freeze_count() >= tracked // 2
        assert len(gc.get_objects()) < tracked // 10
    finally:
        gc.unfreeze()


def _fifo_permitted() -> bool:
    code = "import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))"
    return subprocess.run([sys.executable, "-c", code], capture_output=True).returncode == 0


def test_an_inherited_real_time_policy_is_left(monkeypatch):
    fifo = {101: os.SCHED_FIFO, 102: os.SCHED_FIFO, 103: os.SCHED_OTHER}
    set_to: dict[int, int] = {}

    def setscheduler(tid: int, policy: int, param: object) -> None:
        set_to[tid] = policy

    monkeypatch.setattr(scheduling, "_threads", lambda: sorted(fifo))
    monkeypatch.setattr(scheduling.os, "sched_getscheduler", fifo.__getitem__)
    monkeypatch.setattr(scheduling.os, "sched_setscheduler", setscheduler)
    note = scheduling.leave_real_time()
    assert note is not None and "2 thread(s) back to SCHED_OTHER" in note
    assert set_to == {101: os.SCHED_OTHER, 102: os.SCHED_OTHER}


def test_an_ordinary_process_is_left_alone(monkeypatch):
    monkeypatch.setattr(scheduling, "_threads", lambda: [101, 102])
    monkeypatch.setattr(scheduling.os, "sched_getscheduler", lambda tid: os.SCHED_OTHER)

    def refuse(*_: object) -> None:
        raise AssertionError("nothing to change")

    monkeypatch.setattr(scheduling.os, "sched_setscheduler", refuse)
    assert scheduling.leave_real_time() is None


@pytest.mark.skipif(not LINUX or not _fifo_permitted(), reason="SCHED_FIFO not permitted here")
def test_real_fifo_threads_go_back_to_sched_other():
    """For real: a process started from a SCHED_FIFO thread (as imotiond's supervising
    thread restarts a gateway) leaves it, every thread and those started later."""
    code = """
import os, threading
from controller.gateway.scheduling import leave_real_time
os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
ev = threading.Event()
before = threading.Thread(target=ev.wait); before.start()
assert os.sched_getscheduler(before.native_id) == os.SCHED_FIFO
assert leave_real_time() is not None
after = threading.Thread(target=ev.wait); after.start()
policies = {os.sched_getscheduler(int(t)) for t in os.listdir("/proc/self/task")}
ev.set(); before.join(); after.join()
print(sorted(policies) == [os.SCHED_OTHER])
"""
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"
