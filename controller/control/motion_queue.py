"""The JARA_ARM motion queue: planned motions waiting behind the running one.

Spec A never queues (a motion command is accepted only when Ready); JARA_ARM commands queue
up to ``depth`` motions (FULL_MOTION_QUEUE_ERR beyond, state bit 0x08 when full). The loop
starts the next one when the core is Ready and idle, and drops them all on servo off, an
alarm or a stop.
"""

from __future__ import annotations

from collections import deque

from controller.contract.motion_specs import MotionSpec
from controller.errors import Refused
from controller.vocabulary import ReturnCode


class MotionQueue:
    """Motions accepted but not started yet, oldest first."""

    def __init__(self, depth: int):
        self.depth = depth
        self._specs: deque[MotionSpec] = deque()

    def __len__(self) -> int:
        return len(self._specs)

    def __bool__(self) -> bool:
        return bool(self._specs)

    @property
    def full(self) -> bool:
        return len(self._specs) >= self.depth

    def append(self, spec: MotionSpec) -> None:
        """Queue ``spec``; FULL_MOTION_QUEUE_ERR when ``depth`` motions already wait."""
        if self.full:
            raise Refused(
                ReturnCode.FULL_MOTION_QUEUE_ERR,
                f"the motion queue is full ({self.depth} waiting): wait or stop",
            )
        self._specs.append(spec)

    def pop(self) -> MotionSpec:
        """The oldest waiting motion (the queue must not be empty)."""
        return self._specs.popleft()

    def clear(self) -> None:
        self._specs.clear()
