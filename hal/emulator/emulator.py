"""All drives of a robot, emulated on its CAN buses and driving one MuJoCo model.

:class:`DriveEmulator` reads the robot's drive profile (``config/robots/<id>/drives.yaml``),
puts one :class:`~hal.emulator.drive.EmulatedDrive` per drive on a python-can bus per profile
bus (:class:`~hal.emulator.port.Port`), and moves the joints in a
:class:`~hal.emulator.plant.Plant` (MuJoCo).

**Each bus on its own SYNC.** Simulated time advances one period per round of SYNCs. A SYNC
on a bus is answered at once and on that bus alone: if this bus already had a SYNC since the
last physics step, a new round has begun and the physics steps one period first (with the
set-points latched at the previous round's SYNCs, every bus's); then the bus's drives latch
their RPDOs (state machine, new targets) and sample: their TPDOs carry the statusword after
the controlword and the position at this SYNC, as a real drive samples at SYNC. No bus ever
waits for another: a bus whose SYNC comes late, or never, costs nothing to the others (the
physics steps on whichever bus's SYNC opens the next round). The targets of round ``k`` act
over the period that ends at round ``k + 1``'s SYNCs, so a master reads the position of its
previous set-point (feedback one cycle behind the command, as on real CSP drives).

**Master rounds (in process).** Per bus the emulator counts the SYNC frames it has handled,
ignored ones included (bus-off). A master in the same process (``--hal hil`` with
``emulator: thread``) counts the SYNCs it sent and calls :meth:`DriveEmulator.wait_answered`:
once it returns True every SYNC is answered and its TPDOs are on the bus.

**Buses.** ``channels`` maps a profile bus name to python-can ``(interface, channel)``;
by default each bus is a ``virtual`` channel private to this emulator (``hil-<n>-<bus>``),
and :meth:`DriveEmulator.open_master_bus` opens the master's end of it (wrapped for bus-off
injection). ``imotion-sim`` (:mod:`hal.emulator.main`) puts them on ``unix`` buses
(:mod:`hal.can.unix_bus`) for a master in another process.

**Two ways to run it.**

* Threaded (``--hal hil``, ``imotion-sim``): :meth:`DriveEmulator.start`. Buses with a file
  descriptor (``unix``, ``socketcan``) are served by one thread that waits on all of them
  with ``select`` and ticks the heartbeats; others (``virtual``) get one receive thread each
  and a ticker. :meth:`DriveEmulator.stop` ends them.
* Synchronous (tests): :meth:`DriveEmulator.open`, then :meth:`DriveEmulator.poll` handles
  every frame waiting on the buses and ticks the heartbeats at ``now`` (the emulator's clock,
  injectable), without any thread. :meth:`DriveEmulator.on_sync` runs one round directly.

**Compiled round.** Where numba is available (``compiled``, default
:func:`controller.model.jit.available`) the drives' hot values live in one
:class:`~hal.emulator.bank.DriveBank`, the frames come in whole through
:class:`~hal.emulator.inbox.Inbox` (RPDOs straight into the bank) and a bus's SYNC is one
call for all its plain drives (:func:`hal.emulator.kernels.sync_drives`); the others, and
every transition, fault and EMCY, take the drives' Python path, which is also the whole of
the ``IMOTION_JIT=0`` emulator. Same frames either way (``tests/test_emulator_kernels.py``).

Every public method takes the emulator's lock, so injections and the API are safe from other
threads while the threads run.
"""

from __future__ import annotations

import itertools
import logging
import os
import select
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import can
import numpy as np

from controller.model import jit
from controller.model.robot import Robot, load_robot
from hal.can.drive_profile import DriveProfile, drives_path, eds_path, load_drive_profile
from hal.can.unix_bus import INTERFACE as UNIX
from hal.emulator import kernels
from hal.emulator.bank import DriveBank
from hal.emulator.drive import EmulatedDrive
from hal.emulator.faults import ActiveFault, FaultableBus, FaultInjector
from hal.emulator.inbox import Inbox
from hal.emulator.plant import Plant
from hal.emulator.port import Port

log = logging.getLogger(__name__)

#: The SYNC COB-ID of the predefined connection set (a drive's 0x1005 may name another).
SYNC_COB_ID = 0x080
_instances = itertools.count(1)
#: Heartbeat tick period of the threads [s].
TICK = 0.005
#: A batch of frames that took longer than this [s] is logged (the emulator fell behind).
SLOW_BATCH = 0.02
#: Batches handled at most before the heartbeats are ticked (frames keep coming).
CATCH_UP = 20


def _stamp(frame: tuple[float, int, int, bytes]) -> float:
    return frame[0]


class DriveEmulator:
    """The drives of ``robot`` (id, directory or :class:`Robot`) per its ``drives.yaml``.

    ``period`` [s] is the simulated time per SYNC (default: 1 / the profile's ``rate_hz``).
    ``channels`` overrides the python-can ``(interface, channel)`` of profile buses.
    ``clock`` [s] drives heartbeats (default :func:`time.monotonic`).
    ``compiled``: the SYNC rounds through :mod:`hal.emulator.kernels` (default: where
    :func:`controller.model.jit.available`), else the per-drive Python of every drive.
    """

    def __init__(
        self,
        robot: Robot | str | Path,
        profile: DriveProfile | None = None,
        period: float | None = None,
        channels: Mapping[str, tuple[str, str]] | None = None,
        clock: Callable[[], float] = time.monotonic,
        compiled: bool | None = None,
    ):
        self.robot = robot if isinstance(robot, Robot) else load_robot(robot)
        self.profile = profile or load_drive_profile(drives_path(self.robot), self.robot)
        self.period = float(period) if period is not None else 1.0 / self.profile.rate_hz
        if not self.period > 0:
            raise ValueError(f"period must be positive, got {period!r}")
        self._clock = clock
        self._lock = threading.RLock()
        #: Notified whenever a SYNC frame was handled (:meth:`wait_answered`).
        self._handled = threading.Condition(self._lock)
        instance = next(_instances)
        overrides = dict(channels or {})
        unknown = set(overrides) - set(self.profile.buses)
        if unknown:
            raise ValueError(
                f"channels: unknown buses {sorted(unknown)} (profile buses: "
                f"{', '.join(self.profile.buses)})"
            )
        self.drives: dict[str, EmulatedDrive] = {}
        self._ports: dict[str, Port] = {}
        for bus_name in self.profile.buses:
            interface, channel = overrides.get(bus_name, ("virtual", f"hil-{instance}-{bus_name}"))
            self._ports[bus_name] = Port(bus_name, interface, channel, [])
        directory = drives_path(self.robot).parent
        self.compiled = jit.available() if compiled is None else bool(compiled)
        #: Every drive's hot values, row = plant index (:mod:`hal.emulator.bank`).
        self.bank = DriveBank(len(self.profile.drives))
        for k, (name, config) in enumerate(self.profile.drives.items()):
            port = self._ports[config.bus]
            drive = EmulatedDrive(name, config.node_id, eds_path(self.profile, name, directory),
                                  port.send, self.bank.rows(k))  # fmt: skip
            drive.on_routes_changed = self._routes_changed(port)
            port.drives.append(drive)
            port.indices.append(len(self.drives))
            self.drives[name] = drive
        self._order = list(self.drives.values())  # plant order = profile order
        self.plant = Plant(self.robot, self.profile, self.period, compiled=self.compiled)
        self._setpoints = np.empty(len(self._order), dtype=np.int64)
        self._torque = np.empty(len(self._order), dtype=bool)
        self._now = np.zeros(1)  # [s] time.time() of a SYNC's TPDOs, and its wire bytes
        self._now_bytes = self._now.view(np.uint8)
        self._port_index = {name: k for k, name in enumerate(self._ports)}
        self._inbox: Inbox | None = None
        if self.compiled:
            self._warm_up()
            self._inbox = Inbox(list(self._ports.values()), self.bank.ints, self._frame)
        self.plant.start()
        positions = self.plant.position_counts()
        for drive, position in zip(self._order, positions, strict=True):
            drive.place(int(position))
        self.faults = FaultInjector(
            self.drives, {n: d.bus for n, d in self.profile.drives.items()}, self._set_bus_off
        )
        self._master_buses: dict[str, list[FaultableBus]] = {n: [] for n in self._ports}
        self._cycles = 0
        self._threads: list[threading.Thread] = []
        self._running = threading.Event()
        self._opened = False
        #: SCHED_FIFO priority of the threads (0: normal scheduling), set before start().
        self.priority = 0
        #: Cost of each answered SYNC (physics step included when it took one) [s].
        self.sync_times: list[float] = []
        self.record_sync_times = False

    # ----------------------------------------------------------------------------- queries

    @property
    def channels(self) -> dict[str, tuple[str, str]]:
        """Profile bus name -> python-can (interface, channel) the emulator is on."""
        return {n: (p.interface, p.channel) for n, p in self._ports.items()}

    @property
    def cycles(self) -> int:
        """Physics steps (rounds) since start."""
        return self._cycles

    @property
    def sim_time(self) -> float:
        return self.plant.sim_time

    def sync_counts(self) -> dict[str, int]:
        """Per bus, the SYNC frames handled so far (module doc)."""
        with self._lock:
            return {n: p.syncs for n, p in self._ports.items()}

    def wait_answered(self, sent: Mapping[str, int], timeout: float) -> bool:
        """Wait up to ``timeout`` [s] until every bus of ``sent`` has handled that many SYNC
        frames: on True every one of them is answered (its TPDOs are on the bus). False on
        timeout (threads stalled or stopped)."""
        ports = [(self._ports[name], count) for name, count in sent.items()]
        with self._handled:
            return self._handled.wait_for(
                lambda: all(port.syncs >= count for port, count in ports), timeout
            )

    def drive_on(self, bus: str, node_id: int) -> EmulatedDrive:
        for drive in self._ports[bus].drives:
            if drive.node_id == node_id:
                return drive
        raise KeyError(f"no drive with node id {node_id} on bus {bus}")

    # --------------------------------------------------------------------------- lifecycle

    def open(self, buses: Mapping[str, can.BusABC] | None = None) -> None:
        """Join the buses (or use the given ones) and boot every drive (boot-up messages)."""
        with self._lock:
            if self._opened:
                return
            given = dict(buses or {})
            for name, port in self._ports.items():
                if name in given:
                    port.attach(given[name])
                    continue
                # unix buses hold the TPDOs of a SYNC until it is answered: one record
                extra: dict[str, Any] = {"hold_pdos": True} if port.interface == UNIX else {}
                try:
                    port.attach(can.Bus(interface=port.interface, channel=port.channel, **extra))
                except Exception as exc:
                    self._close_buses()
                    raise OSError(
                        f"bus {name}: cannot open python-can interface {port.interface!r} "
                        f"channel {port.channel!r}: {exc}"
                    ) from exc
            self._opened = True
            now = self._clock()
            for drive in self._order:
                drive.tick(now)
                drive.boot()

    def open_master_bus(self, bus: str) -> FaultableBus:
        """The master's end of emulated bus ``bus`` (a new python-can bus on its channel),
        failing while a bus_off is injected there. The caller shuts it down."""
        port = self._ports.get(bus)
        if port is None:
            raise ValueError(f"unknown bus {bus!r} (buses: {', '.join(self._ports)})")
        inner = can.Bus(interface=port.interface, channel=port.channel)
        wrapped = FaultableBus(inner, bus)
        with self._lock:
            wrapped.bus_off = port.bus_off
            self._master_buses[bus].append(wrapped)
        return wrapped

    def start(self) -> None:
        """Open the buses if needed and run the threads (module doc)."""
        self.open()
        if self._running.is_set():
            return
        self._running.set()
        ports = list(self._ports.values())
        if all(port.selectable() for port in ports):
            self._threads.append(
                threading.Thread(target=self._select_loop, args=(ports,), name="emu", daemon=True)
            )
        else:
            for port in ports:
                thread = threading.Thread(
                    target=self._receive_loop, args=(port,), name=f"emu-{port.name}", daemon=True
                )
                self._threads.append(thread)
            self._threads.append(
                threading.Thread(target=self._tick_loop, name="emu-tick", daemon=True)
            )
        for thread in self._threads:
            thread.start()

    def stop(self) -> None:
        """Stop the threads (the buses stay open)."""
        self._running.clear()
        for thread in self._threads:
            thread.join(timeout=2.0)
        self._threads.clear()

    def close(self) -> None:
        """Stop and leave the buses (the master buses opened here too)."""
        self.stop()
        with self._lock:
            self._close_buses()
            for wrapped in itertools.chain.from_iterable(self._master_buses.values()):
                wrapped.shutdown()
            self._master_buses = {n: [] for n in self._ports}
            self._opened = False
        #: SCHED_FIFO priority of the threads (0: normal scheduling), set before start().
        self.priority = 0

    def __enter__(self) -> DriveEmulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------- synchronous API

    def poll(self, now: float | None = None) -> int:
        """Tick heartbeats at ``now``, then handle every frame waiting on every bus, in the
        order they were sent; how many."""
        with self._lock:
            self._tick(self._clock() if now is None else now)
            return self._handle(list(self._ports.values()))

    def process(self, bus: str, msg: can.Message) -> None:
        """Handle one frame as if received on ``bus``."""
        with self._lock:
            self._process(self._ports[bus], msg)

    def tick(self, now: float | None = None) -> None:
        """Heartbeat production and supervision at ``now`` [s] (default: the clock)."""
        with self._lock:
            self._tick(self._clock() if now is None else now)

    def on_sync(self, buses: Iterable[str] | None = None) -> None:
        """One round without frames: the physics steps one period, then every drive of
        ``buses`` (default: all) has its SYNC (latch, sample, TPDOs)."""
        with self._lock:
            self._step()
            for name in buses if buses is not None else self._ports:
                port = self._ports[name]
                if port.dirty:
                    port.rebuild()
                if not port.bus_off:
                    everyone = list(range(len(port.drives)))
                    self._sync(port, everyone, np.array(port.indices, dtype=np.int64))
                    port.flush()

    # ----------------------------------------------------------------------- injection

    def inject(self, kind: str, joint: str | None = None, **params: Any) -> None:
        """Inject a fault (see :mod:`hal.emulator.faults`)."""
        with self._lock:
            self.faults.inject(kind, joint, **params)

    def clear(self, kind: str | None = None, joint: str | None = None) -> int:
        """Clear injected faults matching ``kind``/``joint`` (None = any)."""
        with self._lock:
            return self.faults.clear(kind, joint)

    @property
    def active_faults(self) -> list[ActiveFault]:
        with self._lock:
            return self.faults.active

    # -------------------------------------------------------------------------- internals

    def _process(self, port: Port, msg: can.Message) -> None:
        if msg.is_error_frame or msg.is_remote_frame or msg.is_extended_id:
            return
        self._frame(port, msg.arbitration_id, bytes(msg.data))

    def _frame(self, port: Port, can_id: int, data: bytes) -> None:
        """One classic data frame ``can_id`` with ``data`` received on ``port``."""
        if port.dirty:
            port.rebuild()
        group = port.sync_groups.get(can_id)
        if group is not None or can_id == SYNC_COB_ID:
            if group is not None and not port.bus_off:
                start = time.perf_counter()
                self._sync(port, group, port.sync_slots[can_id])
                port.flush()  # this bus's TPDOs now, in one record (a hold_pdos bus)
                if self.record_sync_times:
                    self.sync_times.append(time.perf_counter() - start)
            port.syncs += 1  # handled, even when ignored (bus-off, no drive on this COB-ID)
            self._handled.notify_all()
            return
        if port.bus_off:
            return
        handlers = port.routes.get(can_id)
        if handlers:
            now = self._clock()
            for handler in handlers:
                handler(data, now)

    def _sync(self, port: Port, group: list[int], slots: np.ndarray) -> None:
        """SYNC on ``port`` for its drives ``group`` (positions on the bus; ``slots``: their
        bank rows) (module doc: a new round steps first)."""
        if port.synced:
            self._step()
        port.synced = True
        drives = port.drives
        sim_time = self.plant.sim_time
        if not self.compiled:
            for k in group:
                drive = drives[k]
                drive.latch()
                drive.sample(sim_time)
            return
        bank, out, ends, slow = self.bank, port.out, port.ends, port.slow
        self._now[0] = time.time()  # the frames' time stamp (its bytes: self._now_bytes)
        left = kernels.sync_drives(bank.ints, bank.floats, slots, sim_time,
                                   self._now_bytes, out, ends, slow)  # fmt: skip
        if not left:
            if len(group) and ends[len(group) - 1]:
                port.send_frames(out[: ends[len(group) - 1]].tobytes())
            return
        start = 0
        for j, k in enumerate(group):  # a drive left to Python between plain ones: in order
            if slow[j]:
                drive = drives[k]
                drive.latch()
                drive.sample(sim_time)
            elif ends[j] > start:
                port.send_frames(out[start : ends[j]].tobytes())
            start = int(ends[j])

    def _step(self) -> None:
        """The physics of one period with every drive's latched set-point; new actuals."""
        setpoints, torque = self._setpoints, self._torque
        if self.compiled:
            kernels.setpoints(self.bank.ints, setpoints, torque)
            self.plant.step(setpoints, torque)
            plant, scaling = self.plant, self.plant.scaling
            kernels.move(self.bank.ints, plant.position, plant.velocity, scaling.factor,
                         scaling.offset)  # fmt: skip
        else:
            order = self._order
            for i, drive in enumerate(order):
                setpoints[i], torque[i] = drive.setpoint()
            self.plant.step(setpoints, torque)
            positions = self.plant.position_counts().tolist()
            velocities = self.plant.velocity_counts().tolist()
            for drive, position, velocity in zip(order, positions, velocities, strict=True):
                drive.move(position, velocity)
        for port in self._ports.values():
            port.synced = False
        self._cycles += 1

    def _warm_up(self) -> None:
        """Compile (or load) the kernels now, on a scratch bank, not in the first round."""
        scratch = DriveBank(1)
        slots = np.zeros(1, dtype=np.int64)
        out = np.zeros(kernels.DRIVE_BYTES, dtype=np.uint8)
        ends = np.zeros(1, dtype=np.int64)
        kernels.sync_drives(scratch.ints, scratch.floats, slots, 0.0, self._now_bytes, out, ends,
                            np.zeros(1, dtype=bool))  # fmt: skip
        kernels.setpoints(scratch.ints, np.zeros(1, dtype=np.int64), np.zeros(1, dtype=bool))
        kernels.move(scratch.ints, np.zeros(1), np.zeros(1), np.ones(1), np.zeros(1))

    def _tick(self, now: float) -> None:
        for drive in self._order:
            drive.tick(now)

    def _routes_changed(self, port: Port) -> Callable[[], None]:
        def mark() -> None:
            port.dirty = True

        return mark

    def _set_bus_off(self, bus: str, on: bool) -> None:
        port = self._ports[bus]
        port.bus_off = on
        for wrapped in self._master_buses[bus]:
            wrapped.bus_off = on

    def _close_buses(self) -> None:
        for port in self._ports.values():
            if port.bus is not None:
                try:
                    port.bus.shutdown()
                except Exception as exc:  # a broken remote connection must not block close()
                    log.warning("bus %s: shutdown failed: %s", port.name, exc)
                port.attach(None)

    def _receive_loop(self, port: Port) -> None:
        self._realtime()
        while self._running.is_set():
            bus = port.bus
            if bus is None:
                return
            try:
                msg = bus.recv(0.05)
            except Exception as exc:
                log.error("bus %s: receive failed, the emulator leaves it: %s", port.name, exc)
                return
            if msg is None:
                continue
            with self._lock:
                try:
                    self._process(port, msg)
                except Exception:  # one bad frame must not end the bus
                    log.exception("bus %s: frame 0x%03X failed", port.name, msg.arbitration_id)

    def _select_loop(self, ports: list[Port]) -> None:
        """All buses in one thread: wait on their descriptors, then handle every frame waiting
        on any bus in the order they were sent; tick the heartbeats every :data:`TICK` [s]."""
        fds = {port.bus.fileno(): port for port in ports if port.bus is not None}
        descriptors = list(fds)
        self._realtime()
        next_tick = 0.0
        while self._running.is_set():
            try:
                ready, _, _ = select.select(descriptors, [], [], TICK)
            except (OSError, ValueError) as exc:
                if self._running.is_set():
                    log.error("emulator: select failed, the emulator stops: %s", exc)
                return
            with self._lock:
                start = time.monotonic()
                handled = 0
                for _ in range(CATCH_UP if ready else 0):  # what came meanwhile too, so
                    handled += self._handle([fds[fd] for fd in ready])  # the ticks below
                    if self._clock() >= next_tick + TICK:  # see every heartbeat; ticks due
                        break
                    try:  # the buses that got more meanwhile (one system call for all)
                        ready, _, _ = select.select(descriptors, [], [], 0.0)
                    except (OSError, ValueError):
                        break  # the next wait says why
                    if not ready:
                        break
                took = time.monotonic() - start
                if took > SLOW_BATCH:
                    log.warning("emulator: %.0f ms to handle %d frames (host busy?)",
                                took * 1e3, handled)  # fmt: skip
                now = self._clock()
                if now >= next_tick:
                    self._tick(now)
                    next_tick = now + TICK

    def _realtime(self) -> None:
        """The calling thread under SCHED_FIFO at :attr:`priority` (if set)."""
        if not self.priority:
            return
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(self.priority))
        except (AttributeError, OSError) as exc:
            log.warning("emulator: SCHED_FIFO priority %d not in effect: %s", self.priority, exc)

    def _handle(self, ports: list[Port]) -> int:
        """Every frame waiting on ``ports``, in the order they were sent (their timestamps):
        a SYNC round is then seen as the master sent it, however the buses were read."""
        if self._inbox is not None:
            return self._inbox.handle([self._port_index[port.name] for port in ports])
        frames: list[tuple[float, int, int, bytes]] = []
        for k, port in enumerate(ports):
            try:
                frames += [(stamp, k, can_id, data) for stamp, can_id, data in port.receive()]
            except Exception as exc:
                log.error("bus %s: receive failed: %s", port.name, exc)
        frames.sort(key=_stamp)
        for _, k, can_id, data in frames:
            try:
                self._frame(ports[k], can_id, data)
            except Exception:  # one bad frame must not end the bus
                log.exception("bus %s: frame 0x%03X failed", ports[k].name, can_id)
        return len(frames)

    def _tick_loop(self) -> None:
        self._realtime()
        while self._running.is_set():
            with self._lock:
                self._tick(self._clock())
            time.sleep(TICK)
