"""Per-cycle supervision of the drives and buses, as :class:`~hal.interface.HardwareFault`.

Every cycle the CAN backend hands over what it decoded; :class:`Supervisor` turns problems
into faults with imotion's alarm codes (:class:`controller.model.alarms.AlarmCode`):

=======  =================  ===========================================================
code     name               raised when
=======  =================  ===========================================================
0x400    DRIVE_FAULT        a drive's statusword reports Fault (or Fault reaction active)
0x401    HEARTBEAT_LOST     no heartbeat from a drive within ``master_consumer_ms``, a
                            drive reports a stopped/boot-up NMT state, or a drive's EMCY
                            0x8130 says it lost the master's heartbeat
0x402    BUS_OFF            the CAN controller reports bus-off (error frame, bus state)
0x403    FOLLOWING_ERROR    |actual − set-point| above the window for ``time_ms``, or a
                            drive's EMCY 0x8611
0x404    EMCY               any other EMCY from a drive (code and name in the text)
0x405    TPDO_TIMEOUT       no TPDO1 from a drive for ``tpdo_timeout_cycles`` cycles in a
                            row and, where ``tpdo_timeout_ms`` is set, for that long
0x406    BUS_ERROR          a frame could not be sent
0x407    ENABLE_REFUSED     a drive did not reach Operation enabled in time
=======  =================  ===========================================================

``source`` is the drive (joint or wheel) name, or the bus name for bus faults; the
description names the node id, the bus and what happened.

:meth:`Supervisor.check` counts with one compiled call (:func:`hal.can.kernels.supervise`)
where :func:`controller.model.jit.available`, else with NumPy (:meth:`Supervisor.tpdo`,
:meth:`~Supervisor.heartbeats`, :meth:`~Supervisor.following`); the faults are the same.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from controller.model import jit
from controller.model.alarms import AlarmCode
from hal.can import kernels
from hal.can.cia402 import State
from hal.can.drive_profile import DriveProfile
from hal.can.pdo import emcy_name
from hal.interface import HardwareFault

EMCY_FOLLOWING_ERROR = 0x8611
EMCY_HEARTBEAT = 0x8130


def tpdo_timeouts(
    profile: DriveProfile,
    drive_bus: Sequence[str],
    overrides: dict[str, dict[str, object]] | None = None,
) -> tuple[list[int], list[float]]:
    """TPDO timeout per drive (on bus ``drive_bus[i]``): cycles and [s] (0 = cycles only).
    Per bus: ``overrides[bus]`` (``tpdo_timeout_cycles``, ``tpdo_timeout_ms``), else the bus's
    own settings in the profile, else the profile's. ValueError on a bad value."""
    cycles, seconds = [], []
    for bus in drive_bus:
        cfg = profile.buses[bus]
        extra = (overrides or {}).get(bus, {})
        n = extra.get("tpdo_timeout_cycles", cfg.tpdo_timeout_cycles)
        ms = extra.get("tpdo_timeout_ms", cfg.tpdo_timeout_ms)
        n = profile.tpdo_timeout_cycles if n is None else n
        ms = profile.tpdo_timeout_ms if ms is None else ms
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise ValueError(f"bus {bus}: tpdo_timeout_cycles must be an integer >= 1, got {n!r}")
        if ms is not None and (not isinstance(ms, int | float) or isinstance(ms, bool) or ms < 0):
            raise ValueError(f"bus {bus}: tpdo_timeout_ms must be a number >= 0, got {ms!r}")
        cycles.append(n)
        seconds.append(float(ms or 0.0) / 1e3)
    return cycles, seconds


class DriveError(RuntimeError):
    """A lifecycle step failed because of the drives; ``faults`` says which and why."""

    def __init__(self, faults: list[HardwareFault]):
        super().__init__("; ".join(f"0x{f.code:03X} {f.source}: {f.description}" for f in faults))
        self.faults = faults


class Supervisor:
    """Counters and checks of every drive (index ``i`` = position in ``names``)."""

    def __init__(
        self,
        names: list[str],
        node_ids: list[int],
        buses: list[str],
        dt: float,
        windows: np.ndarray,
        following_time: float,
        heartbeat_timeout: float,
        tpdo_timeout_cycles: int | Sequence[int],
        tpdo_timeout: float | Sequence[float] = 0.0,
    ):
        """``tpdo_timeout_cycles`` and ``tpdo_timeout`` [s] (0 = cycles only): one for all
        drives or one per drive (e.g. a slower bus bridged over a network)."""
        self.names = names
        self.node_ids = node_ids
        self.buses = buses
        self.windows = windows
        #: Cycles the following error may stay outside its window.
        self.following_cycles = max(1, math.ceil(following_time / dt - 1e-9))
        self.heartbeat_timeout = heartbeat_timeout
        n = len(names)
        self.tpdo_timeout_cycles = np.broadcast_to(np.asarray(tpdo_timeout_cycles, int), n).copy()
        self.tpdo_timeout = np.broadcast_to(np.asarray(tpdo_timeout, float), n).copy()
        if (self.tpdo_timeout_cycles < 1).any() or (self.tpdo_timeout < 0).any():
            raise ValueError("TPDO timeouts: at least 1 cycle and 0 s")
        self.missed = np.zeros(n, dtype=int)
        #: Time of each drive's last TPDO1 [s] (the cycle's clock).
        self.last_tpdo = np.zeros(n)
        #: TPDO timeout already reported (once per episode, until a TPDO1 comes in).
        self.tpdo_reported = np.zeros(n, dtype=bool)
        self.outside = np.zeros(n, dtype=int)
        self.last_heartbeat = np.zeros(n)
        #: Heartbeat loss already reported (once per episode).
        self.reported = np.zeros(n, dtype=bool)
        #: Count with the compiled kernel (:func:`hal.can.kernels.supervise`).
        self.compiled = jit.available()
        self._flags = np.zeros(n, dtype=np.int64)
        self._windows = np.ascontiguousarray(windows, dtype=float)

    def where(self, i: int) -> str:
        return f"node {self.node_ids[i]} on bus {self.buses[i]}"

    def reset(self, now: float) -> None:
        """Forget counters (after set-up, a fault reset, an enable)."""
        self.missed[:] = 0
        self.outside[:] = 0
        self.last_tpdo[:] = now
        self.tpdo_reported[:] = False
        self.last_heartbeat[:] = now
        self.reported[:] = False

    def alive(self, now: float) -> bool:
        """Every drive's heartbeat is within the consumer time."""
        return bool((now - self.last_heartbeat <= self.heartbeat_timeout).all())

    # ----------------------------------------------------------------------- checks
    def emcy(self, i: int, code: int, register: int) -> HardwareFault | None:
        """Fault for an EMCY frame (None for 0x0000, 'error reset')."""
        if code == 0:
            return None
        what = f"EMCY 0x{code:04X} ({emcy_name(code)}), error register 0x{register:02X}"
        if code == EMCY_FOLLOWING_ERROR:
            alarm = AlarmCode.FOLLOWING_ERROR
        elif code == EMCY_HEARTBEAT:
            alarm = AlarmCode.HEARTBEAT_LOST
        else:
            alarm = AlarmCode.EMCY
        return HardwareFault(int(alarm), self.names[i], f"{self.where(i)}: {what}")

    def state(self, i: int, state: State, statusword: int) -> HardwareFault | None:
        """Fault for a drive in Fault (reaction) state."""
        if state not in (State.FAULT, State.FAULT_REACTION_ACTIVE):
            return None
        return HardwareFault(
            int(AlarmCode.DRIVE_FAULT),
            self.names[i],
            f"{self.where(i)}: drive in state {state.value} (statusword 0x{statusword:04X})",
        )

    def nmt(self, i: int, nmt_state: int) -> HardwareFault | None:
        """Fault for a heartbeat that reports anything but OPERATIONAL (a reboot, a stop)."""
        if nmt_state == 0x05:
            return None
        what = {0x00: "booted (reset)", 0x04: "stopped", 0x7F: "pre-operational"}.get(
            nmt_state, f"NMT state 0x{nmt_state:02X}"
        )
        return HardwareFault(
            int(AlarmCode.HEARTBEAT_LOST), self.names[i], f"{self.where(i)}: heartbeat: {what}"
        )

    def tpdo(self, fresh: np.ndarray, now: float = 0.0) -> list[HardwareFault]:
        """Count cycles without TPDO1 (``fresh``: got one this cycle, at ``now`` [s]); a fault
        once a drive misses ``tpdo_timeout_cycles`` in a row and its last TPDO1 is at least
        ``tpdo_timeout`` old, once per episode."""
        missed = self.missed
        if fresh.all():
            missed[:] = 0
            self.last_tpdo[:] = now
            self.tpdo_reported[:] = False
            return []
        missed += 1
        missed[fresh] = 0
        self.last_tpdo[fresh] = now
        self.tpdo_reported[fresh] = False
        late = (missed >= self.tpdo_timeout_cycles) & ~self.tpdo_reported
        if not late.any():
            return []
        late &= now - self.last_tpdo >= self.tpdo_timeout - 1e-9  # clock rounding
        faults = []
        for i in np.flatnonzero(late):
            self.tpdo_reported[i] = True
            faults.append(self._tpdo_fault(int(i), now))
        return faults

    def _tpdo_fault(self, i: int, now: float) -> HardwareFault:
        return HardwareFault(
            int(AlarmCode.TPDO_TIMEOUT),
            self.names[i],
            f"{self.where(i)}: no TPDO1 (statusword, position) for {self.missed[i]} cycles"
            + (f" ({(now - self.last_tpdo[i]) * 1e3:.0f} ms)" if self.tpdo_timeout[i] > 0 else ""),
        )

    def heartbeats(self, now: float) -> list[HardwareFault]:
        """Faults for drives whose last heartbeat is older than the consumer time."""
        if now - self.last_heartbeat.min() <= self.heartbeat_timeout:
            return []
        late = (now - self.last_heartbeat > self.heartbeat_timeout) & ~self.reported
        if not late.any():
            return []
        faults = []
        for i in np.flatnonzero(late):
            faults.append(self._heartbeat_fault(int(i), now))
            self.reported[i] = True
        return faults

    def _heartbeat_fault(self, i: int, now: float) -> HardwareFault:
        age = now - self.last_heartbeat[i]
        return HardwareFault(
            int(AlarmCode.HEARTBEAT_LOST),
            self.names[i],
            f"{self.where(i)}: no heartbeat for {age * 1e3:.0f} ms "
            f"(consumer time {self.heartbeat_timeout * 1e3:.0f} ms)",
        )

    def following(self, error: np.ndarray, active: np.ndarray) -> list[HardwareFault]:
        """Count cycles with |error| [SI] above the window on ``active`` drives."""
        over = (np.abs(error) > self.windows) & active
        if not over.any():
            self.outside[:] = 0
            return []
        self.outside += 1
        self.outside[~over] = 0
        return [
            self._following_fault(int(i), float(error[i]))
            for i in np.flatnonzero(self.outside == self.following_cycles)
        ]

    def _following_fault(self, i: int, error: float) -> HardwareFault:
        return HardwareFault(
            int(AlarmCode.FOLLOWING_ERROR),
            self.names[i],
            f"{self.where(i)}: following error {error:.4g} exceeds the "
            f"window {float(self.windows[i]):.4g} for {self.following_cycles} cycles",
        )

    def check(
        self,
        now: float,
        fresh: np.ndarray,
        states: Sequence[State],
        statuswords: Sequence[int] | np.ndarray,
        active: bool,
        all_enabled: bool,
        any_faulted: bool,
        position: np.ndarray,
        setpoint: np.ndarray,
    ) -> list[HardwareFault]:
        """Every check of one cycle at ``now`` [s]: TPDO timeouts (``fresh``), heartbeats,
        drive states (``any_faulted``; with ``active`` every drive must be Operation
        enabled), following error ``position − setpoint`` [SI] of the enabled drives when
        ``active``."""
        if self.compiled:
            return self._check_compiled(
                now, fresh, states, statuswords, active, all_enabled, any_faulted, position,
                setpoint,
            )  # fmt: skip
        faults = self.tpdo(fresh, now)
        faults += self.heartbeats(now)
        faults += self._states(states, statuswords, active, all_enabled, any_faulted)
        if active:
            if not all_enabled:
                fresh = fresh & self._enabled(states)
            faults += self.following(position - setpoint, fresh)
        return faults

    def _check_compiled(
        self,
        now: float,
        fresh: np.ndarray,
        states: Sequence[State],
        statuswords: Sequence[int] | np.ndarray,
        active: bool,
        all_enabled: bool,
        any_faulted: bool,
        position: np.ndarray,
        setpoint: np.ndarray,
    ) -> list[HardwareFault]:
        """:meth:`check` with the counting in one kernel call."""
        mask = fresh if not active or all_enabled else fresh & self._enabled(states)
        flags = self._flags
        found = kernels.supervise(
            now, fresh, self.missed, self.tpdo_timeout_cycles, self.last_tpdo,
            self.tpdo_timeout, self.tpdo_reported, self.last_heartbeat,
            self.heartbeat_timeout, self.reported, active, mask, position, setpoint,
            self._windows, self.outside, self.following_cycles, flags,
        )  # fmt: skip
        if not found and not any_faulted and (all_enabled or not active):
            return []
        faults = [self._tpdo_fault(int(i), now) for i in np.flatnonzero(flags & kernels.LATE_TPDO)]
        faults += [
            self._heartbeat_fault(int(i), now)
            for i in np.flatnonzero(flags & kernels.LATE_HEARTBEAT)
        ]
        faults += self._states(states, statuswords, active, all_enabled, any_faulted)
        faults += [
            self._following_fault(int(i), float(position[i] - setpoint[i]))
            for i in np.flatnonzero(flags & kernels.FOLLOWING)
        ]
        return faults

    @staticmethod
    def _enabled(states: Sequence[State]) -> np.ndarray:
        return np.array([s is State.OPERATION_ENABLED for s in states])

    def _states(
        self,
        states: Sequence[State],
        statuswords: Sequence[int] | np.ndarray,
        active: bool,
        all_enabled: bool,
        any_faulted: bool,
    ) -> list[HardwareFault]:
        """Faults of drives in Fault (reaction), and with ``active`` of drives not
        Operation enabled."""
        faults: list[HardwareFault] = []
        if any_faulted or (active and not all_enabled):
            for i, state in enumerate(states):
                fault = self.state(i, state, statuswords[i])
                if fault is not None:
                    faults.append(fault)
                elif active and state is not State.OPERATION_ENABLED:
                    faults.append(
                        HardwareFault(
                            int(AlarmCode.DRIVE_FAULT),
                            self.names[i],
                            f"{self.where(i)}: left operation enabled (state: {state.value})",
                        )
                    )
        return faults

    @staticmethod
    def bus_off(bus: str, what: str) -> HardwareFault:
        return HardwareFault(int(AlarmCode.BUS_OFF), bus, f"bus {bus}: bus-off ({what})")

    @staticmethod
    def bus_error(bus: str, what: str) -> HardwareFault:
        return HardwareFault(int(AlarmCode.BUS_ERROR), bus, f"bus {bus}: {what}")

    def enable_refused(self, i: int, state: State, seconds: float) -> HardwareFault:
        return HardwareFault(
            int(AlarmCode.ENABLE_REFUSED),
            self.names[i],
            f"{self.where(i)}: not operation enabled after {seconds:.2f} s (state: {state.value})",
        )
