"""hal.can.lockstep: bounded waits on the partner, two periods after a stall."""

from __future__ import annotations

from collections.abc import Mapping

from hal.can.lockstep import LockstepGate


class Partner:
    def __init__(self) -> None:
        self.answer = True
        self.calls: list[tuple[dict[str, int], float]] = []

    def wait_answered(self, sent: Mapping[str, int], timeout: float) -> bool:
        self.calls.append((dict(sent), timeout))
        return self.answer


def test_no_partner_never_waits():
    assert LockstepGate(None, 0.002).wait({"a": 3})


def test_full_wait_then_two_periods_while_stalled_then_full_again():
    partner = Partner()
    gate = LockstepGate(partner, 0.002, timeout=1.0)
    assert gate.wait({"a": 1}) and not gate.stalled
    partner.answer = False
    assert not gate.wait({"a": 2}) and gate.stalled
    assert not gate.wait({"a": 3})
    partner.answer = True
    assert gate.wait({"a": 4}) and not gate.stalled
    assert gate.wait({"a": 5})
    assert [t for _, t in partner.calls] == [1.0, 1.0, 0.004, 0.004, 1.0]
    assert gate.timeouts == 2 and partner.calls[0][0] == {"a": 1}
    assert gate.waited >= 0.0
