"""tools/perf_cycles.py: perf samples parsed and cut to a cycle (canned perf output)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from perf_cycles import BEFORE, in_cycle, parse

PERF = """\
 4771  100.000100: cpu-clock:
\t          18d890 PyLong_AsLong (/usr/lib/libpython3.11.so.1.0)
\t    7ff1bea41810 [unknown] ([unknown])

 4771  100.003400: cpu-clock:
\tffffffff82252b63 unix_dgram_sendmsg ([kernel.kallsyms])
\tffffffff81000130 entry_SYSCALL_64_after_hwframe ([kernel.kallsyms])
\t          1019b3 __send (/usr/lib/x86_64-linux-gnu/libc.so.6)

 4802  100.003500: cpu-clock:
\t          194954 find_empty_slot (/usr/lib/libpython3.11.so.1.0)
"""


def test_samples_are_parsed_with_their_thread_time_event_and_frames():
    samples = parse(PERF)
    assert [(s.tid, s.time, s.event) for s in samples] == [
        (4771, 100.0001, "cpu-clock"), (4771, 100.0034, "cpu-clock"),
        (4802, 100.0035, "cpu-clock"),
    ]  # fmt: skip
    assert samples[0].frames == ["PyLong_AsLong", "[unknown]"]
    assert samples[1].frames == ["unix_dgram_sendmsg", "entry_SYSCALL_64_after_hwframe", "__send"]


def test_a_cycle_gets_its_samples_and_those_of_its_wake_up():
    samples = parse(PERF)
    assert BEFORE == 0.5e-3
    assert [s.time for s in in_cycle(samples, 100.0004, 100.0020)] == [100.0001]
    assert [s.time for s in in_cycle(samples, 100.0030, 100.0034)] == [100.0034]
    assert in_cycle(samples, 100.0041, 100.0050) == []
