"""The CAN backend: CiA 402 drives in cyclic synchronous position mode over python-can.

This module is the lifecycle (see :mod:`hal.interface`) and the order of a cycle; the parts
are modules of their own: bus set-up :mod:`hal.can.ports`, SDO/NMT set-up
:mod:`hal.can.setup`, cycle I/O (encode, send, receive, decode) :mod:`hal.can.cycle`, joints
<-> drives :mod:`hal.can.joints`, per-cycle checks :mod:`hal.can.supervision`, lockstep with
an emulator :mod:`hal.can.lockstep`.

* ``configure()`` opens every bus of the drive profile and sets every drive up over SDO
  (:mod:`hal.can.setup`), then sends a first SYNC so the first ``read()`` has feedback.
* ``activate()`` is a bounded blocking sequence (it runs while the control loop waits for
  it): up to ``enable_timeout`` [s] of cycles, each sending RPDO1 with target := actual and
  the controlword of the per-drive state machine (:class:`hal.can.cia402.DriveMaster`), a
  SYNC and the heartbeat, until every drive is Operation enabled. A drive that does not get
  there raises :class:`~hal.can.supervision.DriveError` (code 0x407 naming the drive) and
  leaves the backend in FAULT with every drive quick-stopped.
* ``deactivate()``: every drive's goal becomes OFF: the next cycles send quick stop (0x02),
  the drives decelerate and end in Switch on disabled (0x00 from then on). Non-blocking;
  also valid in FAULT.
* ``reset_faults()``: bounded blocking (``reset_timeout``): fault reset as a bit-7 edge, then
  True (INACTIVE) once no drive is faulted, every heartbeat and TPDO1 is fresh and no new
  fault came in; otherwise False and still FAULT.
* ``shutdown()``: quick stop on every drive, buses closed. The drives then miss the master's
  heartbeat and stay quick-stopped (0x6007).

Cycle: ``read()`` (lockstep wait if any) drains every bus without blocking (optionally waits
up to ``feedback_wait`` [s] for the TPDO1 of every drive), decodes, converts to SI and runs
the checks; ``write()`` encodes every drive's RPDO1, sends it, then one SYNC per bus, and the
master heartbeat when due. Feedback is one cycle old: what ``read()`` returns was sampled by
the drives at the previous cycle's SYNC; its ``stamp`` is that SYNC's time, and the
following-error check compares it with the set-point sent *before* that SYNC.

Supervision runs in every read (:mod:`hal.can.supervision`); any fault puts the backend in
FAULT and every drive's goal to OFF (quick stop), so nothing further is commanded. The TPDO
timeout is ``tpdo_timeout_cycles`` (and ``tpdo_timeout_ms``) of the profile, per bus where
the bus sets its own (profile or ``bus_options``).

Thread safety: read/write and the lifecycle calls take one lock, so a ``read()`` from another
thread (e.g. a status query) is safe; a second ``read()`` without a ``write()`` in between
returns the same state without touching the buses.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from controller.model.alarms import AlarmCode
from controller.model.robot import Robot
from hal.can import ports as _ports
from hal.can.cia402 import Goal, State
from hal.can.cycle import CycleIO
from hal.can.drive_profile import DriveProfile
from hal.can.joints import JointMap, joint_names
from hal.can.lockstep import Lockstep, LockstepGate
from hal.can.ports import BusFactory, Port, bus_kwargs, close_ports, open_ports
from hal.can.setup import interpolation_period, set_up_drives
from hal.can.supervision import DriveError, Supervisor, tpdo_timeouts
from hal.interface import (
    HardwareFault,
    HardwareInterface,
    HardwareState,
    JointCommand,
    JointState,
)

log = logging.getLogger(__name__)

__all__ = ["CanBackend", "Lockstep", "Port", "default_joint_names", "interpolation_period"]

_OFF_STATES = (HardwareState.UNCONFIGURED, HardwareState.FINALIZED)


class CanBackend(HardwareInterface):
    """CiA 402 drives of ``profile`` for ``robot`` at loop period ``dt`` [s] (module doc).

    ``bus_options``: per bus, python-can settings over the profile's and the supervision
    keys of :data:`hal.can.ports.SUPERVISION_KEYS`. ``bus_factory(name, kwargs)`` opens a
    bus (default python-can). ``lockstep``: a partner answering SYNCs (``--hal hil``)."""

    def __init__(
        self,
        robot: Robot,
        dt: float,
        profile: DriveProfile,
        directory: Path | None = None,
        bus_options: dict[str, dict[str, Any]] | None = None,
        *,
        feedback_wait: float = 0.0,
        enable_timeout: float = 0.5,
        reset_timeout: float = 0.5,
        sdo_timeout: float = 0.3,
        lockstep: Lockstep | None = None,
        lockstep_timeout: float = 1.0,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        bus_factory: BusFactory | None = None,
    ):
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        interpolation_period(dt)
        self.robot = robot
        self.profile = profile
        self.directory = directory or robot.directory
        self.dt = float(dt)
        self.feedback_wait = feedback_wait
        self.enable_timeout = enable_timeout
        self.reset_timeout = reset_timeout
        self.sdo_timeout = sdo_timeout
        self._gate = LockstepGate(lockstep, self.dt, lockstep_timeout)
        self._clock = clock
        self._sleep = sleep
        self._bus_factory = bus_factory or _ports.open_bus
        #: The in-process drive emulator of ``--hal hil`` (None otherwise).
        self.emulator: Any = None
        #: Called after the buses are closed in :meth:`shutdown` (e.g. to stop an emulator).
        self.on_shutdown: list[Callable[[], None]] = []
        self._bus_options = dict(bus_options or {})
        for name in self._bus_options:
            if name not in profile.buses:
                raise ValueError(
                    f"bus option for unknown bus {name!r}: "
                    f"{robot.id} has {', '.join(profile.buses)}"
                )
        self.joints = JointMap(robot, profile, self.dt)
        self.joint_names = self.joints.joint_names
        self.drive_names = self.joints.drive_names
        cfgs = [profile.drives[n] for n in self.drive_names]
        self.node_ids = [d.node_id for d in cfgs]
        self.drive_bus = [d.bus for d in cfgs]
        extra = {b: _ports.split_supervision(o)[1] for b, o in self._bus_options.items()}
        cycles, seconds = tpdo_timeouts(profile, self.drive_bus, extra)
        self._supervisor = Supervisor(
            self.drive_names,
            self.node_ids,
            self.drive_bus,
            self.dt,
            np.array([profile.following_window(d) for d in self.drive_names]),
            profile.following_error.time_ms / 1000.0,
            profile.heartbeat.master_consumer_ms / 1000.0,
            cycles,
            seconds,
        )
        self.io = CycleIO(
            [],
            self.node_ids,
            self._supervisor,
            self._enter_fault,
            clock,
            profile.heartbeat.master_producer_ms / 1e3,
        )
        #: Set-point [SI] per drive sent before the last SYNC (the following-error check).
        self._checked = np.zeros(len(self.drive_names))
        self._stamp = 0.0
        self._sync_stamp = 0.0
        self._pending = False  # a SYNC went out since the last drain
        self._ports: list[Port] = []
        self._counted: list[Port] = []  # the last ports opened (counters survive shutdown)
        self._state = HardwareState.UNCONFIGURED
        self._faults: list[HardwareFault] = []
        self._new_faults: list[HardwareFault] = []
        self._lock = threading.RLock()
        self._keepalive: threading.Thread | None = None
        self._keepalive_stop = threading.Event()
        #: Set while not ACTIVE: the heartbeat thread sleeps on it (no wake-up while the
        #: loop runs; each would take the GIL the loop may be waiting for).
        self._idle = threading.Event()
        self._idle.set()

    # ----------------------------------------------------------------------------- queries
    @property
    def state(self) -> HardwareState:
        return self._state

    def faults(self) -> list[HardwareFault]:
        return list(self._faults)

    def drive_states(self) -> dict[str, State]:
        """Each drive's last decoded CiA 402 state."""
        return dict(zip(self.drive_names, self.io.states, strict=True))

    def bus_kwargs(self, name: str) -> dict[str, Any]:
        """python-can keyword arguments of bus ``name`` (profile, then the overrides)."""
        return bus_kwargs(self.profile, name, self._bus_options.get(name))

    def _count(self, what: str) -> dict[str, int]:
        counts = dict.fromkeys(self.profile.buses, 0)
        for port in self._counted:
            counts[port.name] = getattr(port, what)
        return counts

    @property
    def frames_sent(self) -> dict[str, int]:
        """Frames sent per bus since configure."""
        return self._count("frames_sent")

    @property
    def frames_received(self) -> dict[str, int]:
        """Frames received per bus since configure."""
        return self._count("frames_received")

    @property
    def syncs_sent(self) -> dict[str, int]:
        """SYNC frames sent per bus since configure (the lockstep count)."""
        return self._count("syncs_sent")

    @property
    def bits(self) -> dict[str, int]:
        """Worst-case length [bit] of the frames sent and received per bus (classic CAN, bit
        stuffing; :mod:`hal.can.busload`), for benchmarks."""
        return self._count("bits")

    # ---------------------------------------------------------------------------- lockstep
    @property
    def lockstep(self) -> Lockstep | None:
        """The partner answering SYNCs (``--hal hil``), or None."""
        return self._gate.partner

    @lockstep.setter
    def lockstep(self, partner: Lockstep | None) -> None:
        self._gate.partner = partner

    @property
    def lockstep_timeout(self) -> float:
        """[s] longest wait for the partner to answer a round of SYNCs."""
        return self._gate.timeout

    @property
    def lockstep_stalled(self) -> bool:
        """The last lockstep wait timed out (the next waits are two periods at most)."""
        return self._gate.stalled

    @property
    def lockstep_timeouts(self) -> int:
        """Lockstep waits that timed out since construction."""
        return self._gate.timeouts

    @property
    def lockstep_waited(self) -> float:
        """Time [s] ``read()``/``write()`` spent waiting for the lockstep partner since
        construction: subtracted from their time, what remains is the master's own work."""
        return self._gate.waited

    def _wait_lockstep(self) -> None:
        if self._gate.partner is not None:
            self._gate.wait(self.syncs_sent)

    # --------------------------------------------------------------------------- lifecycle
    def configure(self) -> None:
        """Open the buses and set every drive up over SDO. UNCONFIGURED -> INACTIVE."""
        with self._lock:
            if self._state is not HardwareState.UNCONFIGURED:
                raise RuntimeError(
                    f"configure() needs UNCONFIGURED, backend is {self._state.value}"
                )
            self._ports = open_ports(
                self.profile,
                list(self.profile.buses),
                self.node_ids,
                self.drive_bus,
                self._bus_options,
                self._bus_factory,
            )
            self._counted = self._ports
            self.io.ports = self._ports
            try:
                for port in self._ports:
                    set_up_drives(
                        port.bus,
                        port.name,
                        [self.drive_names[i] for i in port.drives],
                        self.profile,
                        self.directory,
                        self.dt,
                        self.sdo_timeout,
                        self.send_heartbeat,
                    )
            except BaseException:
                self._close()
                raise
            now = self._clock()
            self._supervisor.reset(now)
            self.io.send_heartbeat(now, force=True)
            self._state = HardwareState.INACTIVE
            self._send_cycle(None)  # a first SYNC: the first read() has feedback
            self._keepalive_stop.clear()
            self._keepalive = threading.Thread(
                target=self._keep_alive, name="can-heartbeat", daemon=True
            )
            self._keepalive.start()

    def send_heartbeat(self) -> None:
        """The master heartbeat on every bus if one period passed (thread-safe)."""
        with self._lock:
            self.io.send_heartbeat(self._clock())

    def activate(self) -> None:
        """Enable every drive holding its position (bounded blocking). INACTIVE -> ACTIVE."""
        with self._lock:
            if self._state is HardwareState.ACTIVE:
                return
            if self._state is not HardwareState.INACTIVE:
                raise RuntimeError(f"activate() needs INACTIVE, backend is {self._state.value}")
            io = self.io
            io.set_goal(Goal.ENABLED)
            start = self._clock()
            while True:
                self._send_cycle(None)
                self._sleep(self.dt)
                self._drain()
                if self._state is HardwareState.FAULT:
                    raise DriveError(self.faults())
                if io.all_enabled:
                    break
                if self._clock() - start > self.enable_timeout:
                    refused = [
                        self._supervisor.enable_refused(i, s, self.enable_timeout)
                        for i, s in enumerate(io.states)
                        if s is not State.OPERATION_ENABLED
                    ]
                    self._enter_fault(refused)
                    self._send_cycle(None)
                    raise DriveError(refused)
            self._hold()
            self._supervisor.outside[:] = 0
            self._state = HardwareState.ACTIVE
            self._idle.clear()

    def deactivate(self) -> None:
        """Quick stop, then disable, from the next cycle on. ACTIVE -> INACTIVE."""
        with self._lock:
            self.io.set_goal(Goal.OFF, keep_reset=True)
            if self._state is HardwareState.ACTIVE:
                self._state = HardwareState.INACTIVE
                self._idle.set()

    def reset_faults(self) -> bool:
        """Fault reset (bit-7 edge); True once everything is healthy again (INACTIVE)."""
        with self._lock:
            if self._state is not HardwareState.FAULT:
                return self._state is HardwareState.INACTIVE
            io = self.io
            io.set_goal(Goal.RESET)
            for port in self._ports:
                port.failed = False
            self._supervisor.reported[:] = False
            start = self._clock()
            healthy = 0
            while self._clock() - start <= self.reset_timeout:
                self._new_faults.clear()
                self._send_cycle(None)
                self._sleep(self.dt)
                self._drain()
                ok = (
                    not self._new_faults
                    and not io.any_faulted
                    and State.UNKNOWN not in io.states
                    and bool(io.fresh.all())
                    and self._supervisor.alive(self._clock())
                    and not any(p.failed for p in self._ports)
                )
                healthy = healthy + 1 if ok else 0
                if healthy >= 2:
                    self._faults.clear()
                    self._supervisor.reset(self._clock())
                    io.set_goal(Goal.OFF)
                    self._state = HardwareState.INACTIVE
                    return True
            io.set_goal(Goal.OFF)
            return False

    def shutdown(self) -> None:
        """Quick stop every drive and close the buses. Any state -> FINALIZED."""
        self._keepalive_stop.set()
        self._idle.set()
        if self._keepalive is not None:
            self._keepalive.join(timeout=1.0)
            self._keepalive = None
        with self._lock:
            if self._ports:
                self.io.set_goal(Goal.OFF)
                try:
                    self._send_cycle(None)
                except Exception as exc:  # closing anyway
                    log.warning("quick stop at shutdown failed: %s", exc)
            self._close()
            self._state = HardwareState.FINALIZED
            for hook in self.on_shutdown:
                hook()
            self.on_shutdown.clear()

    def _close(self) -> None:
        close_ports(self._ports)
        self._ports = []
        self.io.ports = []

    def _keep_alive(self) -> None:
        """Master heartbeat while the drives are not enabled and no cycle sends it (between
        configure() and the loop's first cycle, in a paused loop). Never in ACTIVE: a stalled
        loop must let the enabled drives time out and stop; the thread then sleeps until the
        backend leaves ACTIVE, without waking (a thread of the loop's process that wakes
        takes the GIL, and preempted while holding it, makes the loop wait)."""
        period = self.profile.heartbeat.master_producer_ms / 1e3
        while self._idle.wait() and not self._keepalive_stop.wait(period / 2):
            if self._state is HardwareState.ACTIVE or not self._lock.acquire(blocking=False):
                continue
            try:
                if self._state in (HardwareState.INACTIVE, HardwareState.FAULT):
                    self.io.send_heartbeat(self._clock())
            finally:
                self._lock.release()

    # ------------------------------------------------------------------------------ cycle
    def read(self) -> JointState:
        """Measured state (sampled at the previous SYNC; ``stamp`` = that SYNC's time)."""
        with self._lock:
            if self._state in _OFF_STATES:
                raise RuntimeError(f"read() needs a configured backend, it is {self._state.value}")
            if self._pending:
                self._drain()
            joints = self.joints
            return JointState(joints.position.copy(), joints.velocity.copy(), self._stamp)

    def write(self, command: JointCommand) -> None:
        """Send every drive's RPDO1 (set-point in ACTIVE, else hold), SYNC and heartbeat."""
        with self._lock:
            if self._state in _OFF_STATES:
                return
            position = np.asarray(command.position, dtype=float)
            n = len(self.joint_names)
            if position.shape != (n,):
                raise ValueError(f"command.position has shape {position.shape}, expected ({n},)")
            active = self._state is HardwareState.ACTIVE
            if active and not np.isfinite(position).all():
                i = int(np.argmin(np.isfinite(position)))
                self._enter_fault(
                    [
                        HardwareFault(
                            int(AlarmCode.HARDWARE_INVALID_COMMAND),
                            self.joint_names[i],
                            f"non-finite set-point {float(position[i])!r}",
                        )
                    ]
                )
            self._send_cycle(position if self._state is HardwareState.ACTIVE else None)

    def _send_cycle(self, position: np.ndarray | None) -> None:
        """Encode and send one round (RPDO1s, SYNCs, heartbeat when due). ``position``:
        joint set-points [SI], None = hold (target := actual).

        In lockstep a round never goes out before the last one is answered (activate(),
        reset_faults() and shutdown() may follow a write() without a read())."""
        if self._pending:
            self._wait_lockstep()
        if position is not None and self._state is HardwareState.ACTIVE:
            self.joints.command(position, self.io.target)
        else:
            self._hold()
        self._checked[:] = self.joints.target
        self.io.send()
        now = self._clock()
        self._sync_stamp = now
        self._pending = True
        self.io.send_heartbeat(now)

    def _hold(self) -> None:
        """Target := actual for every drive."""
        self.io.hold_targets()
        self.joints.hold()

    def _drain(self) -> None:
        """Decode every frame waiting on the buses, update the state, run supervision."""
        io = self.io
        io.clear_fresh()
        now = self._clock()
        self._wait_lockstep()
        io.receive(now + self.feedback_wait if self.feedback_wait > 0 else None)
        self._pending = False
        io.decode_states()
        self.joints.update(io.position, io.velocity, io.fresh, io.seen)
        self._stamp = self._sync_stamp
        if self._state not in _OFF_STATES:
            self._check(now)

    def _check(self, now: float) -> None:
        """The per-cycle checks (:meth:`Supervisor.check`)."""
        io = self.io
        faults = self._supervisor.check(
            now,
            io.fresh,
            io.states,
            io.statusword,
            self._state is HardwareState.ACTIVE,
            io.all_enabled,
            io.any_faulted,
            self.joints.pos,
            self._checked,
        )
        if faults:
            self._enter_fault(faults)

    def _enter_fault(self, faults: list[HardwareFault]) -> None:
        """Record ``faults`` (once per code and source), quick-stop every drive, FAULT."""
        known = {(f.code, f.source) for f in self._faults}
        for f in faults:
            self._new_faults.append(f)
            if (f.code, f.source) not in known:
                known.add((f.code, f.source))
                self._faults.append(f)
                log.warning("hardware fault 0x%03X %s: %s", f.code, f.source, f.description)
        self.io.set_goal(Goal.OFF, keep_reset=True)
        if self._state is not HardwareState.UNCONFIGURED:
            self._state = HardwareState.FAULT
            self._idle.set()


def default_joint_names(robot: Robot) -> Sequence[str]:
    """The joints a CAN backend exposes: unit joints in unit order, then grippers."""
    return joint_names(robot)
