"""The CAN backend: CiA 402 drives in cyclic synchronous position mode over python-can.

Lifecycle (see :mod:`hal.interface`):

* ``configure()`` opens every bus of the drive profile, and per drive over SDO (canopen,
  EDS): NMT pre-operational, modes of operation 8 (CSP), interpolation period (0x60C2) = the
  loop period, following-error window and time (0x6065/0x6066), quick stop option 2 (0x605A),
  abort connection option (0x6007, default 3 = quick stop), heartbeat producer (0x1017) and
  consumer of the master's heartbeat (0x1016), PDO mapping (RPDO1 controlword + target,
  TPDO1 statusword + position, TPDO2 velocity where ``velocity_feedback``), NMT operational.
  After set-up canopen's receive thread is stopped: the cycle reads the buses itself.
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

Cycle: ``read()`` drains every bus without blocking (``bus.recv(0)``; optionally waits up to
``feedback_wait`` [s] for the TPDO1 of every drive) and decodes TPDO1/TPDO2, heartbeats and
EMCY with precompiled structs; ``write()`` sends every drive's
RPDO1, then one SYNC per bus, and the master heartbeat when due. Feedback is one cycle old:
what ``read()`` returns was sampled by the drives at the previous cycle's SYNC; its ``stamp``
is that SYNC's time, and the following-error check compares it with the set-point sent
*before* that SYNC.

Lockstep (``--hal hil``): with a ``lockstep`` partner (the in-process drive emulator) the
backend counts the SYNCs it sends per bus and ``read()`` first waits until the partner has
answered all of them (:meth:`Lockstep.wait_answered`): the feedback is exactly that of the
cycle just commanded, however late the emulator's threads run on a busy host (a late cycle
is an overrun, never a missing TPDO). The wait is bounded by ``lockstep_timeout`` [s]; after
a timeout (a stopped emulator) it waits at most two periods until the partner answers again,
and the TPDO timeout counts the cycles as usual. Real buses (``--hal can``) have no partner:
supervision there stays on the wire's timing.

Vehicle: x/y/θ are virtual joints on wheel drives (:mod:`hal.can.vehicle`) unless the profile
gives them as drives.

Supervision runs in every read (:mod:`hal.can.supervision`); any fault puts the backend in
FAULT and every drive's goal to OFF (quick stop), so nothing further is commanded.

Thread safety: read/write and the lifecycle calls take one lock, so a ``read()`` from another
thread (e.g. a status query) is safe; a second ``read()`` without a ``write()`` in between
returns the same state without touching the buses.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import can
import numpy as np

from controller.model.alarms import AlarmCode
from controller.model.robot import Robot
from hal.can import pdo
from hal.can.busload import classic_frame_bits
from hal.can.cia402 import DriveMaster, Goal, State, decode
from hal.can.drive_profile import VEHICLE_JOINTS, DriveProfile
from hal.can.scaling import I32_MIN, ScalingArray, delta_i32
from hal.can.supervision import DriveError, Supervisor
from hal.can.vehicle import VehicleMapping
from hal.interface import (
    HardwareFault,
    HardwareInterface,
    HardwareState,
    JointCommand,
    JointState,
)

log = logging.getLogger(__name__)

#: Modes of operation (0x6060): cyclic synchronous position.
MODE_CSP = 8
#: Quick stop option code (0x605A): decelerate on the quick stop ramp, then Switch on disabled.
QUICK_STOP_OPTION = 2
#: Worst-case classic frame length [bit] per data length (0..8 bytes).
_FRAME_BITS = [classic_frame_bits(n) for n in range(9)]
#: Socketcan error-frame class bit of a bus-off (linux/can/error.h CAN_ERR_BUSOFF).
CAN_ERR_BUSOFF = 0x40


@dataclass
class Port:
    """One bus: its python-can handle, the drives on it and its preallocated frames."""

    name: str
    bus: can.BusABC
    #: Drive indices on this bus.
    drives: list[int]
    #: COB-ID -> (kind, drive index) of the frames decoded from this bus.
    table: dict[int, tuple[pdo.Kind, int]]
    sync: can.Message
    heartbeat: can.Message
    kwargs: dict[str, Any] = field(default_factory=dict)
    failed: bool = False


class Lockstep(Protocol):
    """A simulated bus partner that answers SYNCs in the same process (the drive emulator)."""

    def wait_answered(self, sent: Mapping[str, int], timeout: float) -> bool:
        """Wait up to ``timeout`` [s] until each bus of ``sent`` has answered that many SYNC
        frames (their TPDOs are on the bus, no cycle left open); False on timeout."""
        ...


def interpolation_period(dt: float) -> tuple[int, int]:
    """0x60C2 (value u8, index i8) with value·10^index = ``dt`` [s]."""
    for index in (-3, -4, -5, -6):
        value = dt * 10.0**-index
        if abs(value - round(value)) < 1e-6 and 1 <= round(value) <= 255:
            return round(value), index
    raise ValueError(f"the period {dt!r} s has no exact 0x60C2 representation")


def open_bus(kwargs: dict[str, Any]) -> can.BusABC:
    """A python-can bus from keyword arguments (``interface``, ``channel``, ...)."""
    return can.Bus(**kwargs)


class CanBackend(HardwareInterface):
    """CiA 402 drives of ``profile`` for ``robot`` at loop period ``dt`` [s] (module doc)."""

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
        bus_factory: Callable[[str, dict[str, Any]], can.BusABC] | None = None,
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
        self.lockstep = lockstep
        self.lockstep_timeout = lockstep_timeout
        #: The last lockstep wait timed out: wait at most two periods until it answers again.
        self.lockstep_stalled = False
        #: Lockstep waits that timed out since configure.
        self.lockstep_timeouts = 0
        self._clock = clock
        self._sleep = sleep
        self._bus_factory = bus_factory or (lambda _name, kwargs: open_bus(kwargs))
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

        units = [n for joints in robot.profile.units.values() for n in joints]
        self.joint_names = tuple(units) + robot.gripper_joints
        #: Drives in profile order.
        self.drive_names = list(profile.drives)
        cfgs = [profile.drives[n] for n in self.drive_names]
        self.node_ids = [d.node_id for d in cfgs]
        self.drive_bus = [d.bus for d in cfgs]
        self._scalings = [d.scaling() for d in cfgs]
        self._scale = ScalingArray(self._scalings)
        n = len(cfgs)
        self._has_vel = np.array([d.velocity_feedback for d in cfgs], dtype=bool)
        # Vehicle: wheels (virtual x/y/θ) or the x/y/θ joints as drives.
        wheel_names = profile.wheels
        self._wheel_idx = np.array([self.drive_names.index(w) for w in wheel_names], dtype=int)
        self._vehicle: VehicleMapping | None = None
        self._vehicle_joints = np.zeros(0, dtype=int)
        if wheel_names:
            assert robot.profile.vehicle is not None
            self._vehicle = VehicleMapping(robot.profile.vehicle.wheels)
            self._vehicle_joints = np.array(
                [self.joint_names.index(j) for j in VEHICLE_JOINTS], dtype=int
            )
        # Joint i <- drive _joint_drive[i] for every joint that is a drive.
        joint_of = {name: i for i, name in enumerate(self.joint_names)}
        pairs = [(joint_of[d], k) for k, d in enumerate(self.drive_names) if d in joint_of]
        self._joint_idx = np.array([p[0] for p in pairs], dtype=int)
        self._joint_drive = np.array([p[1] for p in pairs], dtype=int)
        missing = set(self.joint_names) - {self.joint_names[i] for i in self._joint_idx}
        if self._vehicle is not None:
            missing -= set(VEHICLE_JOINTS)
        if missing:
            raise ValueError(f"{robot.id}: joints without a drive: {sorted(missing)}")

        # Per-drive state (SI positions are per drive; wheels as unbounded angles).
        self._sw = [0] * n
        self._seen = np.zeros(n, dtype=bool)
        self._raw = np.zeros(n, dtype=np.int64)  # last position actual [counts]
        self._raw_vel = np.zeros(n)
        self._fresh = np.zeros(n, dtype=bool)
        self._pos = np.zeros(n)  # [rad]/[m]
        self._prev_pos = np.zeros(n)
        self._vel = np.zeros(n)
        self._target = np.zeros(n)  # set-point sent before the last SYNC [SI]
        self._checked_target = np.zeros(n)
        self._target_counts = [0] * n
        self._wheel_raw = np.zeros(len(wheel_names), dtype=np.int64)
        self._wheel_seen = np.zeros(len(wheel_names), dtype=bool)
        self._vehicle_started = False
        self._masters = [DriveMaster() for _ in range(n)]
        self._states = [State.UNKNOWN] * n
        self._position = np.zeros(len(self.joint_names))
        self._velocity = np.zeros(len(self.joint_names))
        self._stamp = 0.0
        self._sync_stamp = 0.0
        self._pending = False  # a SYNC went out since the last drain
        self._last_hb_sent = -math.inf
        self._ports: list[Port] = []
        self._rpdo = [
            can.Message(arbitration_id=pdo.RPDO1 + nid, data=bytearray(6), is_extended_id=False)
            for nid in self.node_ids
        ]
        fe = profile.following_error
        self._supervisor = Supervisor(
            self.drive_names,
            self.node_ids,
            self.drive_bus,
            self.dt,
            np.array([profile.following_window(d) for d in self.drive_names]),
            fe.time_ms / 1000.0,
            profile.heartbeat.master_consumer_ms / 1000.0,
            profile.tpdo_timeout_cycles,
        )
        self._state = HardwareState.UNCONFIGURED
        self._faults: list[HardwareFault] = []
        self._new_faults: list[HardwareFault] = []
        self._lock = threading.RLock()
        self._keepalive: threading.Thread | None = None
        self._keepalive_stop = threading.Event()
        #: Frames sent and received per bus since configure, and their worst-case length
        #: [bit] (classic CAN, bit stuffing; :mod:`hal.can.busload`), for benchmarks.
        self.frames_sent = dict.fromkeys(profile.buses, 0)
        #: SYNC frames sent per bus since configure (the lockstep count).
        self.syncs_sent = dict.fromkeys(profile.buses, 0)
        self.frames_received = dict.fromkeys(profile.buses, 0)
        self.bits = dict.fromkeys(profile.buses, 0)

    # ----------------------------------------------------------------------------- queries
    @property
    def state(self) -> HardwareState:
        return self._state

    def faults(self) -> list[HardwareFault]:
        return list(self._faults)

    def drive_states(self) -> dict[str, State]:
        """Each drive's last decoded CiA 402 state."""
        return dict(zip(self.drive_names, self._states, strict=True))

    def bus_kwargs(self, name: str) -> dict[str, Any]:
        """python-can keyword arguments of bus ``name`` (profile, then the overrides)."""
        cfg = self.profile.buses[name]
        kwargs: dict[str, Any] = {
            "interface": cfg.interface,
            "channel": cfg.channel,
            "bitrate": cfg.bitrate,
        }
        if cfg.fd:
            kwargs.update(fd=True, data_bitrate=cfg.data_bitrate)
        kwargs.update(self._bus_options.get(name, {}))
        if kwargs["interface"] in ("virtual", "remote"):
            kwargs.pop("bitrate", None)
            kwargs.pop("data_bitrate", None)
        return kwargs

    # --------------------------------------------------------------------------- lifecycle
    def configure(self) -> None:
        """Open the buses and set every drive up over SDO. UNCONFIGURED -> INACTIVE."""
        with self._lock:
            if self._state is not HardwareState.UNCONFIGURED:
                raise RuntimeError(
                    f"configure() needs UNCONFIGURED, backend is {self._state.value}"
                )
            try:
                self._open_ports()
                for port in self._ports:
                    self._set_up_port(port)
            except BaseException:
                self._close_ports()
                raise
            now = self._clock()
            self._supervisor.reset(now)
            self._send_heartbeat(now, force=True)
            self._state = HardwareState.INACTIVE
            self._send_cycle(None)  # a first SYNC: the first read() has feedback
            self._keepalive_stop.clear()
            self._keepalive = threading.Thread(
                target=self._keep_alive, name="can-heartbeat", daemon=True
            )
            self._keepalive.start()

    def activate(self) -> None:
        """Enable every drive holding its position (bounded blocking). INACTIVE -> ACTIVE."""
        with self._lock:
            if self._state is HardwareState.ACTIVE:
                return
            if self._state is not HardwareState.INACTIVE:
                raise RuntimeError(f"activate() needs INACTIVE, backend is {self._state.value}")
            for m in self._masters:
                m.goal = Goal.ENABLED
            start = self._clock()
            while True:
                self._send_cycle(None)
                self._sleep(self.dt)
                self._drain()
                if self._state is HardwareState.FAULT:
                    raise DriveError(self.faults())
                if all(s is State.OPERATION_ENABLED for s in self._states):
                    break
                if self._clock() - start > self.enable_timeout:
                    refused = [
                        self._supervisor.enable_refused(i, s, self.enable_timeout)
                        for i, s in enumerate(self._states)
                        if s is not State.OPERATION_ENABLED
                    ]
                    self._enter_fault(refused)
                    self._send_cycle(None)
                    raise DriveError(refused)
            self._hold_targets()
            if self._vehicle is not None:
                self._vehicle.hold()
            self._supervisor.outside[:] = 0
            self._state = HardwareState.ACTIVE

    def deactivate(self) -> None:
        """Quick stop, then disable, from the next cycle on. ACTIVE -> INACTIVE."""
        with self._lock:
            for m in self._masters:
                if m.goal is not Goal.RESET:
                    m.goal = Goal.OFF
            if self._state is HardwareState.ACTIVE:
                self._state = HardwareState.INACTIVE

    def reset_faults(self) -> bool:
        """Fault reset (bit-7 edge); True once everything is healthy again (INACTIVE)."""
        with self._lock:
            if self._state is not HardwareState.FAULT:
                return self._state is HardwareState.INACTIVE
            for m in self._masters:
                m.goal = Goal.RESET
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
                    and all(
                        s not in (State.FAULT, State.FAULT_REACTION_ACTIVE, State.UNKNOWN)
                        for s in self._states
                    )
                    and bool(self._fresh.all())
                    and self._supervisor.alive(self._clock())
                    and not any(p.failed for p in self._ports)
                )
                healthy = healthy + 1 if ok else 0
                if healthy >= 2:
                    self._faults.clear()
                    self._supervisor.reset(self._clock())
                    for m in self._masters:
                        m.goal = Goal.OFF
                    self._state = HardwareState.INACTIVE
                    return True
            for m in self._masters:
                m.goal = Goal.OFF
            return False

    def shutdown(self) -> None:
        """Quick stop every drive and close the buses. Any state -> FINALIZED."""
        self._keepalive_stop.set()
        if self._keepalive is not None:
            self._keepalive.join(timeout=1.0)
            self._keepalive = None
        with self._lock:
            if self._ports:
                for m in self._masters:
                    m.goal = Goal.OFF
                try:
                    self._send_cycle(None)
                except Exception as exc:  # closing anyway
                    log.warning("quick stop at shutdown failed: %s", exc)
            self._close_ports()
            self._state = HardwareState.FINALIZED
            for hook in self.on_shutdown:
                hook()
            self.on_shutdown.clear()

    # ------------------------------------------------------------------------------ cycle
    def read(self) -> JointState:
        """Measured state (sampled at the previous SYNC; ``stamp`` = that SYNC's time)."""
        with self._lock:
            if self._state in (HardwareState.UNCONFIGURED, HardwareState.FINALIZED):
                raise RuntimeError(f"read() needs a configured backend, it is {self._state.value}")
            if self._pending:
                self._drain()
            return JointState(self._position.copy(), self._velocity.copy(), self._stamp)

    def write(self, command: JointCommand) -> None:
        """Send every drive's RPDO1 (set-point in ACTIVE, else hold), SYNC and heartbeat."""
        with self._lock:
            if self._state in (HardwareState.UNCONFIGURED, HardwareState.FINALIZED):
                return
            position = np.asarray(command.position, dtype=float)
            n = len(self.joint_names)
            if position.shape != (n,):
                raise ValueError(f"command.position has shape {position.shape}, expected ({n},)")
            if self._state is HardwareState.ACTIVE and not np.isfinite(position).all():
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

    # ---------------------------------------------------------------------------- internals
    def _open_ports(self) -> None:
        for name in self.profile.buses:
            kwargs = self.bus_kwargs(name)
            try:
                bus = self._bus_factory(name, kwargs)
            except Exception as exc:
                raise DriveError(
                    [
                        HardwareFault(
                            int(AlarmCode.BUS_ERROR),
                            name,
                            f"bus {name}: cannot open {kwargs}: {exc}",
                        )
                    ]
                ) from exc
            drives = [i for i, b in enumerate(self.drive_bus) if b == name]
            table = pdo.receive_table([self.node_ids[i] for i in drives])
            table = {cob: (kind, drives[j]) for cob, (kind, j) in table.items()}
            hb = can.Message(
                arbitration_id=pdo.HEARTBEAT + self.profile.master_node_id,
                data=bytes([pdo.NmtState.OPERATIONAL]),
                is_extended_id=False,
            )
            sync = can.Message(arbitration_id=pdo.SYNC, data=b"", is_extended_id=False)
            self._ports.append(Port(name, bus, drives, table, sync, hb, kwargs))

    def _close_ports(self) -> None:
        for port in self._ports:
            try:
                port.bus.shutdown()
            except Exception as exc:  # a broken bus must not block the others
                log.warning("closing bus %s: %s", port.name, exc)
        self._ports = []

    def _set_up_port(self, port: Port) -> None:
        """SDO set-up of every drive of ``port`` (canopen), then NMT operational."""
        from hal.can.setup import set_up_drives

        set_up_drives(self, port)

    def _send(self, port: Port, msg: can.Message) -> bool:
        if port.failed:
            return False
        try:
            port.bus.send(msg, timeout=0.0 if port.kwargs.get("interface") == "virtual" else None)
        except (can.CanError, OSError, ValueError) as exc:
            port.failed = True
            what = f"send of 0x{msg.arbitration_id:03X} failed: {exc}"
            try:
                off = port.bus.state is can.BusState.ERROR
            except Exception:  # interfaces without a state
                off = False
            fault = Supervisor.bus_off if off else Supervisor.bus_error
            self._enter_fault([fault(port.name, what)])
            return False
        self.frames_sent[port.name] += 1
        self.bits[port.name] += _FRAME_BITS[min(len(msg.data), 8)]
        return True

    def _send_cycle(self, position: np.ndarray | None) -> None:
        """RPDO1 per drive, SYNC per bus, heartbeat when due. ``position``: None = hold.

        In lockstep a round never goes out before the last one is answered (activate(),
        reset_faults() and shutdown() may follow a write() without a read())."""
        if self._pending and self.lockstep is not None:
            self._wait_lockstep()
        if position is not None and self._state is HardwareState.ACTIVE:
            target = self._target
            target[self._joint_drive] = position[self._joint_idx]
            if self._vehicle is not None:
                target[self._wheel_idx] = self._vehicle.command(position[self._vehicle_joints])
            counts = np.rint(target * self._scale.factor + self._scale.offset).astype(np.int64)
            counts = (counts - I32_MIN) % (2**32) + I32_MIN
            self._target_counts = counts.tolist()
        else:
            self._hold_targets()
        self._checked_target[:] = self._target
        for port in self._ports:
            for i in port.drives:
                if not self._seen[i]:
                    continue  # no RPDO before the drive's first feedback (target unknown)
                m = self._masters[i]
                cw = m.controlword(self._sw[i] if self._seen[i] else None)
                msg = self._rpdo[i]
                pdo.RPDO1_STRUCT.pack_into(msg.data, 0, cw, self._target_counts[i])
                if not self._send(port, msg):
                    break
            if self._send(port, port.sync):
                self.syncs_sent[port.name] += 1
        now = self._clock()
        self._sync_stamp = now
        self._pending = True
        self._send_heartbeat(now)

    def _hold_targets(self) -> None:
        """Target := actual for every drive."""
        self._target[:] = self._pos
        self._target_counts = [
            int(r) for r in self._raw
        ]  # raw counts, exact (wheels wrap as the drive does)
        if self._vehicle is not None:
            self._vehicle.hold()

    def _keep_alive(self) -> None:
        """Master heartbeat while the drives are not enabled and no cycle sends it (between
        configure() and the loop's first cycle, in a paused loop). Never in ACTIVE: a stalled
        loop must let the enabled drives time out and stop."""
        period = self.profile.heartbeat.master_producer_ms / 1e3
        while not self._keepalive_stop.wait(period / 2):
            if self._state is HardwareState.ACTIVE or not self._lock.acquire(blocking=False):
                continue
            try:
                if self._state in (HardwareState.INACTIVE, HardwareState.FAULT):
                    self._send_heartbeat(self._clock())
            finally:
                self._lock.release()

    def _send_heartbeat(self, now: float, force: bool = False) -> None:
        if force or now - self._last_hb_sent >= self.profile.heartbeat.master_producer_ms / 1e3:
            self._last_hb_sent = now
            for port in self._ports:
                self._send(port, port.heartbeat)

    def _drain(self) -> None:
        """Decode every frame waiting on the buses, update the state, run supervision."""
        self._fresh[:] = False
        now = self._clock()
        if self.lockstep is not None:
            self._wait_lockstep()
        for port in self._ports:
            self._drain_port(port, now)
        if self.feedback_wait > 0 and not self._fresh.all():
            deadline = now + self.feedback_wait
            for port in self._ports:
                while not self._fresh[port.drives].all():
                    left = deadline - self._clock()
                    if left <= 0 or not self._receive_one(port, left):
                        break
                self._drain_port(port, now)
        self._pending = False
        self._update(now)

    def _wait_lockstep(self) -> None:
        """Until the lockstep partner answered every SYNC sent (bounded, see the module doc)."""
        assert self.lockstep is not None
        timeout = 2 * self.dt if self.lockstep_stalled else self.lockstep_timeout
        if self.lockstep.wait_answered(self.syncs_sent, timeout):
            self.lockstep_stalled = False
            return
        if not self.lockstep_stalled:
            log.warning("lockstep: SYNCs unanswered after %.3f s", timeout)
        self.lockstep_stalled = True
        self.lockstep_timeouts += 1

    def _drain_port(self, port: Port, now: float) -> None:
        while self._receive_one(port, 0.0):
            pass

    def _receive_one(self, port: Port, timeout: float) -> bool:
        try:
            msg = port.bus.recv(timeout)
        except (can.CanError, OSError, ValueError) as exc:
            if not port.failed:
                port.failed = True
                self._enter_fault([Supervisor.bus_error(port.name, f"receive failed: {exc}")])
            return False
        if msg is None:
            return False
        self.frames_received[port.name] += 1
        self.bits[port.name] += _FRAME_BITS[min(len(msg.data), 8)]
        if msg.is_error_frame:
            if msg.arbitration_id & CAN_ERR_BUSOFF:
                port.failed = True
                self._enter_fault([Supervisor.bus_off(port.name, "error frame")])
            return True
        entry = port.table.get(msg.arbitration_id)
        if entry is None:
            return True
        kind, i = entry
        data = msg.data
        if kind is pdo.Kind.TPDO1:
            if len(data) >= 6:
                self._sw[i], self._raw[i] = pdo.TPDO1_STRUCT.unpack_from(data)
                self._fresh[i] = True
                self._seen[i] = True
        elif kind is pdo.Kind.TPDO2:
            if len(data) >= 4:
                (self._raw_vel[i],) = pdo.TPDO2_STRUCT.unpack_from(data)
        elif kind is pdo.Kind.HEARTBEAT:
            if len(data) >= 1:
                self._supervisor.last_heartbeat[i] = self._clock()
                # A PRE-OPERATIONAL heartbeat before the drive's first TPDO1 is stale: sent
                # during its set-up, before it handled the NMT start (not a fault).
                stale = data[0] == pdo.NmtState.PRE_OPERATIONAL and not self._seen[i]
                fault = None if stale else self._supervisor.nmt(i, data[0])
                if fault is not None and self._state is not HardwareState.UNCONFIGURED:
                    self._enter_fault([fault])
        elif kind is pdo.Kind.EMCY and len(data) >= 3:
            code, register = data[0] | data[1] << 8, data[2]
            fault = self._supervisor.emcy(i, code, register)
            if fault is not None:
                self._enter_fault([fault])
        return True

    def _update(self, now: float) -> None:
        """New SI state from the raw feedback, then the per-cycle checks."""
        fresh = self._fresh
        self._prev_pos[:] = self._pos
        pos = self._scale.to_si(self._raw.astype(float))
        for k, i in enumerate(self._wheel_idx):
            # Wheels turn without bound: integrate wrapped count differences.
            if self._wheel_seen[k]:
                step = delta_i32(int(self._raw[i]), int(self._wheel_raw[k]))
                pos[i] = self._pos[i] + step / self._scale.factor[i]
            if self._seen[i]:
                self._wheel_raw[k] = self._raw[i]
                self._wheel_seen[k] = True
        self._pos[:] = np.where(self._seen, pos, self._pos)
        self._vel[:] = np.where(fresh, (self._pos - self._prev_pos) / self.dt, self._vel)
        if self._has_vel.any():
            self._vel[self._has_vel] = self._scale.velocity_to_si(self._raw_vel)[self._has_vel]
        self._position[self._joint_idx] = self._pos[self._joint_drive]
        self._velocity[self._joint_idx] = self._vel[self._joint_drive]
        if self._vehicle is not None and self._wheel_seen.all():
            wheels = self._pos[self._wheel_idx]
            speeds = self._vel[self._wheel_idx] if self._has_vel[self._wheel_idx].all() else None
            if self._vehicle_started:
                self._vehicle.measure(wheels, speeds, self.dt)
            else:
                self._vehicle.start(wheels)
                self._vehicle_started = True
            self._position[self._vehicle_joints] = self._vehicle.pose
            self._velocity[self._vehicle_joints] = self._vehicle.velocity
        self._stamp = self._sync_stamp
        for i, sw in enumerate(self._sw):
            if self._seen[i]:
                self._states[i] = decode(sw)
        self._check(now)

    def _check(self, now: float) -> None:
        if self._state in (HardwareState.UNCONFIGURED, HardwareState.FINALIZED):
            return
        sup = self._supervisor
        faults = sup.tpdo(self._fresh)
        faults += sup.heartbeats(now)
        for i, state in enumerate(self._states):
            fault = sup.state(i, state, self._sw[i])
            if fault is not None:
                faults.append(fault)
            elif self._state is HardwareState.ACTIVE and state is not State.OPERATION_ENABLED:
                faults.append(
                    HardwareFault(
                        int(AlarmCode.DRIVE_FAULT),
                        self.drive_names[i],
                        f"{sup.where(i)}: left operation enabled (state: {state.value})",
                    )
                )
        if self._state is HardwareState.ACTIVE:
            enabled = np.array([s is State.OPERATION_ENABLED for s in self._states])
            faults += sup.following(self._pos - self._checked_target, enabled & self._fresh)
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
        for m in self._masters:
            if m.goal is not Goal.RESET:
                m.goal = Goal.OFF
        if self._state is not HardwareState.UNCONFIGURED:
            self._state = HardwareState.FAULT


def default_joint_names(robot: Robot) -> Sequence[str]:
    """The joints a CAN backend exposes: unit joints in unit order, then grippers."""
    units = [n for joints in robot.profile.units.values() for n in joints]
    return (*units, *robot.gripper_joints)
