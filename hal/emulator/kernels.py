"""A SYNC round of the drive emulator for every drive at once, compiled (numba).

The per-drive Python of a round (:meth:`EmulatedDrive.latch`, :meth:`EmulatedDrive.sample`,
:meth:`EmulatedDrive.setpoint`, :meth:`EmulatedDrive.move`, one ``struct`` call and one send
per TPDO) as calls on the emulator's :class:`hal.emulator.bank.DriveBank`:

* :func:`sync_drives`: the SYNC of one bus for its drives, in bus order: the controlword and
  target received (RPDO), the following-error supervision, and the TPDOs due, encoded
  straight into one buffer of ``unix`` wire frames (:mod:`hal.can.unix_wire`), for every
  drive whose round is *plain*: OPERATIONAL, no pending fault reaction or quick stop, no
  controlword that makes a transition, no following error that trips, no injected silence
  or TPDO delay, no RPDO but the CSP one, only TPDO mappings it knows (statusword +
  position, velocity). Every other drive is flagged and the caller runs the Python path
  for it (the state machine's transitions, EMCYs, faults, logs): same frames, same order.
* :func:`setpoints` / :func:`move`: what the power stages do before a physics step, and the
  new actual values after it (the plant's SI values to counts), for every drive.

The plant's own arithmetic is :mod:`hal.emulator.plant_kernels`.

Plain Python functions on NumPy arrays, compiled with :func:`controller.model.jit.jit`; the
emulator uses them where :func:`controller.model.jit.available` (not with
``IMOTION_JIT=0``), else its per-drive Python, which tests compare frame by frame
(``tests/test_emulator_kernels.py``).
"""

from __future__ import annotations

import math

import numpy as np

from controller.model import jit
from hal.emulator.bank import FLOAT, INT, TPDO_STATUS_POSITION, TPDO_VELOCITY
from hal.emulator.codes import FOLLOWING_ERROR_OFF, NMT_OPERATIONAL
from hal.emulator.drive_state import (
    CW_ENABLE_OPERATION,
    CW_ENABLE_VOLTAGE,
    CW_FAULT_RESET,
    CW_QUICK_STOP,
    CW_SWITCH_ON,
    SW_FOLLOWING_ERROR,
    SW_FOLLOWS_TARGET,
    SW_REMOTE,
    SW_VOLTAGE_ENABLED,
    SW_WARNING,
    PowerState,
)

I32_MIN = -(2**31)
I32_MAX = 2**31 - 1
_SPAN = 2**32
#: Bytes of a frame header on the ``unix`` wire (``<IBBBxd``).
HEADER_SIZE = 16
#: Most bytes one drive's TPDOs take (4 TPDOs of 8 bytes).
DRIVE_BYTES = 4 * (HEADER_SIZE + 8)

_NOT_READY = PowerState.NOT_READY_TO_SWITCH_ON.pattern
_DISABLED = PowerState.SWITCH_ON_DISABLED.pattern
_READY = PowerState.READY_TO_SWITCH_ON.pattern
_SWITCHED_ON = PowerState.SWITCHED_ON.pattern
_ENABLED = PowerState.OPERATION_ENABLED.pattern
_QUICK_STOP = PowerState.QUICK_STOP_ACTIVE.pattern
_REACTION = PowerState.FAULT_REACTION_ACTIVE.pattern
_FAULT = PowerState.FAULT.pattern
# decode_command's commands
_SHUTDOWN, _SWITCH_ON, _ENABLE, _DISABLE_VOLTAGE, _QUICK_STOP_CMD = 1, 2, 3, 4, 5

_STATE, _WARNING, _FE, _SM_CW = (
    INT["state"],
    INT["warning"],
    INT["following_error"],
    INT["sm_controlword"],
)
_LAST_STATE, _CW, _TARGET, _ACTUAL = (
    INT["last_state"],
    INT["controlword"],
    INT["target"],
    INT["actual"],
)
_VELOCITY, _HOLD, _SYNCS, _REACTIONS = (
    INT["velocity"],
    INT["hold"],
    INT["syncs"],
    INT["reaction_cycles"],
)
_NMT, _SILENT, _DELAY, _DELAYED = INT["nmt_state"], INT["silent"], INT["tpdo_delay"], INT["delayed"]
_FE_WINDOW, _WAITING, _RX_FRESH = INT["fe_window"], INT["waiting"], INT["rx_fresh"]
_RX_CW, _RX_TARGET, _FAST, _TPDOS = (
    INT["rx_controlword"],
    INT["rx_target"],
    INT["fast"],
    INT["tpdos"],
)
_KIND0, _COB0, _TYPE0 = INT["tpdo_kind0"], INT["tpdo_cob0"], INT["tpdo_type0"]
_FE_TIME, _OUTSIDE = FLOAT["fe_time"], FLOAT["outside_since"]


@jit.jit
def _command(controlword: int) -> int:
    """:func:`hal.emulator.drive_state.decode_command` as a number."""
    if not controlword & CW_ENABLE_VOLTAGE:
        return _DISABLE_VOLTAGE
    if not controlword & CW_QUICK_STOP:
        return _QUICK_STOP_CMD
    if not controlword & CW_SWITCH_ON:
        return _SHUTDOWN
    if controlword & CW_ENABLE_OPERATION:
        return _ENABLE
    return _SWITCH_ON


@jit.jit
def _transition(state: int, controlword: int, previous: int) -> bool:
    """Whether :meth:`DriveStateMachine.controlword` would change ``state`` (or may:
    anything but the plain states counts as a change)."""
    if state == _FAULT:
        return bool(controlword & CW_FAULT_RESET) and not previous & CW_FAULT_RESET
    command = _command(controlword)
    if state == _DISABLED:
        return command == _SHUTDOWN
    if state == _READY:
        return command != _SHUTDOWN
    if state == _SWITCHED_ON:
        return command != _SWITCH_ON
    if state == _ENABLED:
        return command != _ENABLE
    return True


@jit.jit
def _statusword(state: int, warning: int, following_error: int) -> int:
    """:attr:`DriveStateMachine.statusword`."""
    word = state | SW_REMOTE
    if state == _READY or state == _SWITCHED_ON or state == _ENABLED or state == _QUICK_STOP:
        word |= SW_VOLTAGE_ENABLED
    if warning:
        word |= SW_WARNING
    if state == _ENABLED:
        word |= SW_FOLLOWS_TARGET
    if following_error:
        word |= SW_FOLLOWING_ERROR
    return word


@jit.jit
def _frame(out: np.ndarray, at: int, cob_id: int, size: int, stamp: np.ndarray) -> int:
    """A classic frame's header at ``out[at:]`` (data follows); where its data starts."""
    out[at] = cob_id & 0xFF
    out[at + 1] = (cob_id >> 8) & 0xFF
    out[at + 2] = 0
    out[at + 3] = 0
    out[at + 4] = 0  # flags: a classic 11-bit data frame
    out[at + 5] = size  # dlc
    out[at + 6] = size  # data length
    out[at + 7] = 0
    for b in range(8):
        out[at + 8 + b] = stamp[b]
    return at + HEADER_SIZE


@jit.jit
def _int32(out: np.ndarray, at: int, value: int) -> None:
    raw = value & 0xFFFFFFFF
    for b in range(4):
        out[at + b] = (raw >> (8 * b)) & 0xFF


@jit.jit
def sync_drives(
    ints: np.ndarray,
    floats: np.ndarray,
    slots: np.ndarray,
    sim_time: float,
    stamp: np.ndarray,
    out: np.ndarray,
    ends: np.ndarray,
    slow: np.ndarray,
) -> int:
    """The SYNC of the drives ``slots`` (bank rows, bus order) at ``sim_time`` [s]: latch
    and sample of each plain one (module doc), its TPDOs due as frames stamped ``stamp``
    (the 8 bytes of a float64 [s]) into ``out`` (uint8), drive ``k``'s ending at
    ``ends[k]``; ``slow[k]`` True for a drive left to the Python path (nothing of it
    touched, no frame). Returns how many were left."""
    at = 0
    left = 0
    for k in range(slots.shape[0]):
        s = slots[k]
        row = ints[s]
        state = row[_STATE]
        fresh = row[_RX_FRESH] != 0
        plain = (
            row[_FAST] != 0
            and row[_NMT] == NMT_OPERATIONAL
            and row[_SILENT] == 0
            and row[_REACTIONS] == 0
            and row[_DELAY] == 0
            and row[_DELAYED] == 0
            and row[_WAITING] == 0
            and state == row[_LAST_STATE]
            and state != _NOT_READY
            and state != _QUICK_STOP
            and state != _REACTION
        )
        controlword = row[_RX_CW]
        if plain and fresh:
            plain = not _transition(state, controlword, row[_SM_CW])
        target = row[_RX_TARGET] if fresh else row[_TARGET]
        outside = math.nan
        if plain and state == _ENABLED:
            error = abs((target - row[_ACTUAL] - I32_MIN) % _SPAN + I32_MIN)
            window = row[_FE_WINDOW]
            if window != FOLLOWING_ERROR_OFF and error > window:
                outside = floats[s, _OUTSIDE]
                if math.isnan(outside):
                    outside = sim_time
                if sim_time - outside >= floats[s, _FE_TIME] - 1e-9:
                    plain = False  # the fault: EMCY, log, state machine
        if not plain:
            slow[k] = True
            ends[k] = at
            left += 1
            continue
        slow[k] = False
        if fresh:
            row[_TARGET] = target
            row[_CW] = controlword
            row[_SM_CW] = controlword
            row[_RX_FRESH] = 0
        floats[s, _OUTSIDE] = outside
        syncs = row[_SYNCS] + 1
        row[_SYNCS] = syncs
        for t in range(row[_TPDOS]):
            n = row[_TYPE0 + t]
            if 1 <= n <= 240 and syncs % n:
                continue
            kind = row[_KIND0 + t]
            cob_id = row[_COB0 + t]
            if kind == TPDO_STATUS_POSITION:
                at = _frame(out, at, cob_id, 6, stamp)
                word = _statusword(state, row[_WARNING], row[_FE])
                out[at] = word & 0xFF
                out[at + 1] = (word >> 8) & 0xFF
                _int32(out, at + 2, row[_ACTUAL])
                at += 6
            elif kind == TPDO_VELOCITY:
                at = _frame(out, at, cob_id, 4, stamp)
                _int32(out, at, row[_VELOCITY])
                at += 4
        ends[k] = at
    return left


@jit.jit
def setpoints(ints: np.ndarray, setpoint: np.ndarray, torque: np.ndarray) -> None:
    """Every drive's :meth:`EmulatedDrive.setpoint`: ``setpoint`` [counts], ``torque``."""
    for s in range(ints.shape[0]):
        state = ints[s, _STATE]
        if state == _ENABLED:
            setpoint[s] = ints[s, _TARGET]
            torque[s] = True
        elif state == _QUICK_STOP or state == _REACTION:
            setpoint[s] = ints[s, _HOLD]
            torque[s] = True
        else:
            setpoint[s] = ints[s, _ACTUAL]
            torque[s] = False


@jit.jit
def move(
    ints: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    factor: np.ndarray,
    offset: np.ndarray,
) -> None:
    """Every drive's :meth:`EmulatedDrive.move` from the plant's measured ``position``
    [rad, m] and ``velocity`` [rad/s, m/s] with the drives' scaling (``factor`` [counts per
    SI unit], ``offset`` [counts]) as :meth:`hal.can.scaling.ScalingArray.to_counts` rounds
    them: position [counts] wrapped to 32 bits, velocity [counts/s] clamped."""
    for s in range(ints.shape[0]):
        counts = np.int64(np.rint(position[s] * factor[s] + offset[s]))
        speed = np.int64(np.rint(velocity[s] * factor[s]))
        ints[s, _ACTUAL] = (counts - I32_MIN) % _SPAN + I32_MIN
        ints[s, _VELOCITY] = min(max(speed, I32_MIN), I32_MAX)
