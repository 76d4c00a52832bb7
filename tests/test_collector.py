"""controller.control.collector: the garbage collector runs only in the loop's slack."""

from __future__ import annotations

import gc
import weakref

import pytest

from controller.control import collector as collector_module
from controller.control.collector import (
    MIDDLE_EVERY,
    YOUNG_LIMIT,
    YOUNG_THRESHOLD,
    SlackCollector,
)

PLENTY = 10**9  # [ns] of slack: every collection fits


@pytest.fixture(autouse=True)
def _gc_as_found():
    """Each test leaves the collector enabled/disabled and unfrozen as it found it."""
    enabled, frozen = gc.isenabled(), gc.get_freeze_count()
    yield
    if gc.get_freeze_count() and not frozen:
        gc.unfreeze()
    (gc.enable if enabled else gc.disable)()


class _Cycle:
    """An object in a reference cycle with itself: freed by the collector only."""

    def __init__(self) -> None:
        self.me = self


def _cycle_garbage() -> weakref.ref:
    obj = _Cycle()
    ref = weakref.ref(obj)
    del obj
    return ref


def _allocate(n: int) -> list[list[int]]:
    """``n`` container objects kept alive (so they count as pending)."""
    return [[i] for i in range(n)]


def test_start_turns_automatic_collection_off_and_stop_gives_it_back():
    gc.enable()
    c = SlackCollector()
    c.start()
    c.start()  # idempotent: stop must still restore "enabled"
    assert c.active and not gc.isenabled()
    c.stop()
    assert not c.active and gc.isenabled()
    gc.disable()
    c.start()
    c.stop()
    assert not gc.isenabled()  # it was off before start: stays off


def test_a_young_collection_frees_cycles_when_due_and_the_slack_allows():
    c = SlackCollector()
    c.start()
    gc.collect()
    ref = _cycle_garbage()
    c(PLENTY)
    assert ref() is not None  # not due yet: nothing pending
    keep = _allocate(YOUNG_THRESHOLD)
    c(0)
    assert ref() is not None and c.collections == [0, 0]  # due, but no slack
    c(PLENTY)
    assert ref() is None and c.collections[0] == 1
    assert c.cost_ns[0] > 0
    del keep


def test_a_young_collection_runs_without_slack_past_the_limit():
    c = SlackCollector()
    c.start()
    gc.collect()
    ref = _cycle_garbage()
    keep = _allocate(YOUNG_LIMIT)
    c(0)
    assert ref() is None and c.forced == 1
    del keep


def test_the_middle_generation_is_collected_when_it_fits_and_frozen_when_not(monkeypatch):
    c = SlackCollector()
    c.start()
    gc.collect()
    keep = []
    for _ in range(MIDDLE_EVERY):  # ten young collections make generation 1 due
        keep.append(_allocate(YOUNG_THRESHOLD))
        c(PLENTY)
    assert gc.get_count()[1] >= MIDDLE_EVERY
    c.cost_ns[1] = 10**6
    frozen = gc.get_freeze_count()
    c(10**6)  # 1 ms of slack for 1.5 ms expected: frozen instead
    assert c.freezes == 1 and c.collections[1] == 0
    assert gc.get_freeze_count() > frozen
    assert gc.get_count()[1] == 0  # counted afresh: the next call does not freeze again
    assert c.cost_ns[1] == int(10**6 * collector_module.DECAY)
    c(10**6)
    assert c.freezes == 1
    for _ in range(MIDDLE_EVERY):
        keep.append(_allocate(YOUNG_THRESHOLD))
        c(PLENTY)
    c(PLENTY)
    assert c.collections[1] == 1 and c.freezes == 1


def test_stop_unfreezes_what_it_froze_but_not_what_was_frozen_before():
    gc.collect()
    c = SlackCollector()
    c.start()
    for _ in range(MIDDLE_EVERY):
        c(PLENTY)
        _allocate(YOUNG_THRESHOLD)
        gc.collect(0)
    c.cost_ns[1] = 10**9
    c(0)
    assert c.freezes == 1 and gc.get_freeze_count() > 0
    c.stop()
    assert gc.get_freeze_count() == 0
    gc.freeze()  # someone else's (the real-time setup's)
    frozen = gc.get_freeze_count()
    c = SlackCollector()
    c.start()
    c.cost_ns[1] = 10**9
    for _ in range(MIDDLE_EVERY):
        gc.collect(0)
    c(0)
    assert c.freezes == 1
    c.stop()
    assert gc.get_freeze_count() >= frozen  # left frozen: not this collector's to undo
