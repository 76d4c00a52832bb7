"""All drives of a robot, emulated on its CAN buses and driving one MuJoCo model.

:class:`DriveEmulator` reads the robot's drive profile (``config/robots/<id>/drives.yaml``),
puts one :class:`~hal.emulator.drive.EmulatedDrive` per drive on a python-can bus per profile
bus (:class:`~hal.emulator.port.Port`), and moves the joints in a
:class:`~hal.emulator.plant.Plant` (MuJoCo).

**Each bus on its own SYNC** (:mod:`hal.emulator.sync_round`): simulated time advances
one period per round of SYNCs; a SYNC is answered at once on its bus alone, the physics
stepping first when it opens a new round. No bus waits for another.

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

* Threaded (``--hal hil``, ``imotion-sim``): :meth:`DriveEmulator.start` runs
  :class:`hal.emulator.threads.BusThreads`: buses with a file descriptor (``unix``,
  ``socketcan``) are served by one thread that waits on all of them with ``select`` and
  ticks the heartbeats; others (``virtual``) get one receive thread each and a ticker.
  :meth:`DriveEmulator.stop` ends them.
* Synchronous (tests): :meth:`DriveEmulator.open`, then :meth:`DriveEmulator.poll` handles
  every frame waiting on the buses and ticks the heartbeats at ``now`` (the emulator's clock,
  injectable), without any thread. :meth:`DriveEmulator.on_sync` runs one round directly.

**Compiled round.** Where numba is available (``compiled``, default
:func:`controller.model.jit.available`) the drives' hot values live in one
:class:`~hal.emulator.bank.DriveBank`, the frames come in whole through
:class:`~hal.emulator.inbox.Inbox` (RPDOs straight into the bank) and a bus's SYNC is one
call for all its plain drives (:mod:`hal.emulator.sync_round`); the others, and every
transition, fault and EMCY, take the drives' Python path, which is also the whole of the
``IMOTION_JIT=0`` emulator. Same frames either way (``tests/test_emulator_kernels.py``).

Every public method takes the emulator's lock, so injections and the API are safe from other
threads while the threads run.
"""

from __future__ import annotations

import itertools
import logging
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
from hal.emulator.bank import DriveBank
from hal.emulator.drive import EmulatedDrive
from hal.emulator.faults import ActiveFault, FaultableBus, FaultInjector
from hal.emulator.inbox import Inbox
from hal.emulator.plant import Plant
from hal.emulator.port import Port
from hal.emulator.sync_round import SyncRound
from hal.emulator.threads import BusThreads

log = logging.getLogger(__name__)

#: The SYNC COB-ID of the predefined connection set (a drive's 0x1005 may name another).
SYNC_COB_ID = 0x080
_instances = itertools.count(1)


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
        self._round = SyncRound(self._order, list(self._ports.values()), self.bank, self.plant,
                                self.compiled)  # fmt: skip
        self._port_index = {name: k for k, name in enumerate(self._ports)}
        self._inbox: Inbox | None = None
        if self.compiled:
            self._round.warm_up()
            self._inbox = Inbox(list(self._ports.values()), self.bank.ints, self._frame)
        self.plant.start()
        positions = self.plant.position_counts()
        for drive, position in zip(self._order, positions, strict=True):
            drive.place(int(position))
        self.faults = FaultInjector(
            self.drives, {n: d.bus for n, d in self.profile.drives.items()}, self._set_bus_off
        )
        self._master_buses: dict[str, list[FaultableBus]] = {n: [] for n in self._ports}
        self._service: BusThreads | None = None
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
        return self._round.cycles

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
        """Open the buses if needed and run the threads (:mod:`hal.emulator.threads`) at
        :attr:`priority`."""
        self.open()
        if self._service is not None:
            return
        self._service = BusThreads(
            list(self._ports.values()), self._lock, self._handle, self._process, self._tick,
            self._clock, self.priority,
        )  # fmt: skip
        self._service.start()

    def stop(self) -> None:
        """Stop the threads (the buses stay open)."""
        service, self._service = self._service, None
        if service is not None:
            service.stop()

    @property
    def threads(self) -> list[threading.Thread]:
        """The threads serving the buses while started (:mod:`hal.emulator.threads`)."""
        return list(self._service.threads) if self._service is not None else []

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
            self._round.step()
            for name in buses if buses is not None else self._ports:
                port = self._ports[name]
                if port.dirty:
                    port.rebuild()
                if not port.bus_off:
                    everyone = list(range(len(port.drives)))
                    self._round.sync(port, everyone, np.array(port.indices, dtype=np.int64))
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
                self._round.sync(port, group, port.sync_slots[can_id])
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

    def _handle(self, ports: list[Port], more: Callable[[], list[Port]] | None = None) -> int:
        """Every frame waiting on ``ports``, in the order they were sent (their timestamps):
        a SYNC round is then seen as the master sent it, however the buses were read.
        ``more``: the ports that still hold something, for reading a record per peer and
        asking once for all buses (:meth:`Inbox.handle`)."""
        if self._inbox is not None:
            index = self._port_index
            indices = [index[port.name] for port in ports]
            more_indices = None if more is None else lambda: [index[p.name] for p in more()]
            return self._inbox.handle(indices, more_indices)
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
