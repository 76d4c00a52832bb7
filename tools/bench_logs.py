#!/usr/bin/env python3
"""What operator logging costs the control-loop thread.

Measures, in this process: :meth:`LoopEvents.observe` on a quiet cycle (nothing changed:
the per-cycle cost), one event handed over by the loop thread (a queue put), the logger
call the ``loop-events`` thread then makes (structlog processors + the record queued for the
writer thread, which formats and writes), and a log call while the writer is stuck on a
blocked output (must stay as cheap: nobody waits for stderr).

Usage: python tools/bench_logs.py [--n 20000]. Prints figures, then one JSON line.
"""

from __future__ import annotations

import argparse
import io
import json
import logging
import threading
import time
from collections.abc import Callable
from types import SimpleNamespace

import numpy as np

from controller import logs
from controller.control.events import LoopEvents
from controller.vocabulary import CoreState


def _percentiles(samples: list[float]) -> dict[str, float]:
    a = np.array(samples) * 1e6
    return {"p50_us": round(float(np.percentile(a, 50)), 2),
            "p99_us": round(float(np.percentile(a, 99)), 2),
            "max_us": round(float(a.max()), 2)}  # fmt: skip


def _time(fn: Callable[[], object], n: int) -> dict[str, float]:
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return _percentiles(out)


class _Stuck(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.go = threading.Event()

    def emit(self, record: logging.LogRecord) -> None:
        self.go.wait(60)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20000)
    args = parser.parse_args()
    sink = io.StringIO()
    logs.setup_logging("info", "bench")
    logging.getLogger().handlers[:] = [logs._writer.handler]  # type: ignore[union-attr]
    logs._writer.target = logging.StreamHandler(sink)  # type: ignore[union-attr]
    ev = LoopEvents()
    core = SimpleNamespace(state=CoreState.READY, motion=None, alarms=[])
    ev.observe(core)  # type: ignore[arg-type]
    quiet = _time(lambda: ev.observe(core), args.n)  # type: ignore[arg-type]
    n_events = min(args.n, logs.QUEUE_SIZE // 2)
    event = _time(lambda: ev._emit("info", "state changed", **{"from": "ready", "to": "busy"}),
                  n_events)  # fmt: skip
    ev.flush(60)
    log = logs.get_logger("imotiond.events")
    call = _time(lambda: log.info("state changed", **{"from": "ready", "to": "busy"}), n_events)
    logs.flush_logs(30)
    stuck = _Stuck()
    logs._writer.target = stuck  # type: ignore[union-attr]
    log.info("first")  # the writer now hangs on it
    blocked = _time(lambda: log.info("while blocked", n=1), logs.QUEUE_SIZE * 2)
    dropped = logs.dropped()
    stuck.go.set()
    logs.stop_logging(30)
    result = {"observe_quiet": quiet, "loop_event": event, "logger_call": call,
              "log_while_output_blocked": blocked, "dropped_while_blocked": dropped}  # fmt: skip
    print(f"LoopEvents.observe, quiet cycle: p50 {quiet['p50_us']} us, p99 {quiet['p99_us']} us")
    print(f"one event from the loop thread: p50 {event['p50_us']} us, p99 {event['p99_us']} us")
    print(f"the logger call (loop-events thread): p50 {call['p50_us']} us, "
          f"p99 {call['p99_us']} us")  # fmt: skip
    print(f"log call, output blocked: p50 {blocked['p50_us']} us, p99 {blocked['p99_us']} us, "
          f"max {blocked['max_us']} us ({dropped} records dropped, none waited)")  # fmt: skip
    print(json.dumps(result))


if __name__ == "__main__":
    main()
