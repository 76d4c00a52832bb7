"""hal.emulator.bank: a drive's attributes live in its bank row, one source of truth."""

from __future__ import annotations

import math

from hal.emulator.bank import FLOAT, INT, DriveBank
from hal.emulator.drive_state import DriveStateMachine, PowerState


def test_state_machine_attributes_are_its_row():
    bank = DriveBank(2)
    sm = DriveStateMachine(bank.ints[1])
    sm.boot()
    assert bank.ints[1, INT["state"]] == PowerState.SWITCH_ON_DISABLED.pattern
    sm.controlword(0x06)
    assert sm.state is PowerState.READY_TO_SWITCH_ON
    assert bank.ints[1, INT["sm_controlword"]] == 0x06
    bank.ints[1, INT["warning"]] = 1  # what the compiled round reads and writes
    assert sm.warning is True and sm.statusword & 0x80
    assert not bank.ints[0].any() or bank.ints[0, INT["csp_rpdo"]] == -1  # row 0 untouched


def test_a_machine_alone_has_a_row_of_its_own():
    a, b = DriveStateMachine(), DriveStateMachine()
    a.boot()
    assert a.state is PowerState.SWITCH_ON_DISABLED
    assert b.state is PowerState.NOT_READY_TO_SWITCH_ON


def test_a_new_bank_says_no_csp_rpdo_and_no_following_error_timing():
    bank = DriveBank(3)
    assert (bank.ints[:, INT["csp_rpdo"]] == -1).all()
    assert all(math.isnan(v) for v in bank.floats[:, FLOAT["outside_since"]])
    ints, floats = bank.rows(2)
    ints[INT["target"]] = 7
    floats[FLOAT["fe_time"]] = 0.5
    assert bank.ints[2, INT["target"]] == 7 and bank.floats[2, FLOAT["fe_time"]] == 0.5
