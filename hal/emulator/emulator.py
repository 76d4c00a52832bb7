"""All drives of a robot, emulated on its CAN buses and driving one MuJoCo model in lockstep.

:class:`DriveEmulator` reads the robot's drive profile (``config/robots/<id>/drives.yaml``),
puts one :class:`~hal.emulator.drive.EmulatedDrive` per drive on a python-can bus per profile
bus, and moves the joints in a :class:`~hal.emulator.plant.Plant` (MuJoCo).

**Lockstep.** Simulated time advances only on SYNC, one period per cycle. A cycle spans every
bus: on a bus's SYNC its drives latch their RPDOs; once every bus that the cycle waits for
has had its SYNC, the physics steps one period and every synced drive samples and sends its
TPDOs. A cycle waits for a bus when one of its drives is OPERATIONAL (the others do not
answer a SYNC anyway), it is not bus-off, and its master is alive: a second SYNC on a bus
before the others had theirs closes the pending cycle and marks the silent buses gone until
their next SYNC. So a master that sends RPDOs on every bus and then one SYNC per bus gets,
on each bus, TPDOs that describe the state at the end of the period it just commanded; a
master that only uses some of the buses is not slowed by the others.

**Master rounds (in process).** Per bus the emulator counts the SYNC frames (COB-ID 0x080 or
a drive's 0x1005) it has handled, ignored ones included (bus-off, nobody listening). A
master in the same process (``--hal hil``) counts the SYNCs it sent and calls
:meth:`DriveEmulator.wait_answered`: once every one of them is handled, a cycle still open
is closed there (it waits for a bus whose SYNC of this round went into the previous cycle,
e.g. because that bus's drives became OPERATIONAL in between), so every SYNC of the round is
answered and the barrier can never slip a cycle. The master gets the feedback of exactly
the cycle it commanded, however late the threads run.

**Buses.** ``channels`` maps a profile bus name to python-can ``(interface, channel)``;
by default each bus is a ``virtual`` channel private to this emulator (``hil-<n>-<bus>``),
and :meth:`DriveEmulator.open_master_bus` opens the master's end of it (wrapped for bus-off
injection). ``imotion-sim`` (:mod:`hal.emulator.main`) serves those channels to other
processes.

**Two ways to run it.**

* Threaded (the daemon, ``imotion-sim``): :meth:`DriveEmulator.start` runs one receive thread
  per bus and a ticker for heartbeats; :meth:`DriveEmulator.stop` ends them.
* Synchronous (tests): :meth:`DriveEmulator.open`, then :meth:`DriveEmulator.poll` handles
  every frame waiting on the buses and ticks the heartbeats at ``now`` (the emulator's clock,
  injectable), without any thread. :meth:`DriveEmulator.on_sync` runs one cycle directly.

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

from controller.model.robot import Robot, load_robot
from hal.can.drive_profile import DriveProfile, drives_path, eds_path, load_drive_profile
from hal.can.scaling import wrap_i32
from hal.emulator.drive import NMT_OPERATIONAL, EmulatedDrive
from hal.emulator.faults import ActiveFault, FaultableBus, FaultInjector
from hal.emulator.plant import Plant

log = logging.getLogger(__name__)

Handler = Callable[[bytes, float], None]
#: The SYNC COB-ID of the predefined connection set (a drive's 0x1005 may name another).
SYNC_COB_ID = 0x080
_instances = itertools.count(1)


class _Port:
    """One bus as the emulator sees it: its python-can bus, drives and routing table."""

    def __init__(self, name: str, interface: str, channel: str, drives: list[EmulatedDrive]):
        self.name = name
        self.interface = interface
        self.channel = channel
        self.drives = drives
        #: Plant index (profile order) of each drive of this bus.
        self.indices: list[int] = []
        self.bus: can.BusABC | None = None
        self.bus_off = False
        self.routes: dict[int, list[Handler]] = {}
        #: SYNC COB-ID -> positions in :attr:`drives` of the drives it synchronises.
        self.sync_groups: dict[int, list[int]] = {}
        #: Per drive: latched at a SYNC of the open cycle.
        self.pending: list[bool] = []
        self.dirty = True
        self.synced = False
        #: False once a cycle had to close without this bus's SYNC (its master is gone).
        self.alive = True
        self.send_errors = 0
        #: SYNC frames handled on this bus (latched, or ignored: bus-off, nobody listens).
        self.syncs = 0

    def send(self, can_id: int, data: bytes) -> None:
        bus = self.bus
        if bus is None or self.bus_off:
            return
        try:
            bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=False))
        except can.CanError as exc:
            self.send_errors += 1
            if self.send_errors in (1, 10, 100) or self.send_errors % 1000 == 0:
                log.warning("bus %s: send 0x%03X failed (%d so far): %s",
                            self.name, can_id, self.send_errors, exc)  # fmt: skip

    def rebuild(self) -> None:
        routes: dict[int, list[Handler]] = {}
        for drive in self.drives:
            for can_id, handler in drive.routes().items():
                routes.setdefault(can_id, []).append(handler)
        self.routes = routes
        groups: dict[int, list[int]] = {}
        for k, drive in enumerate(self.drives):
            groups.setdefault(drive.sync_cob_id, []).append(k)
        self.sync_groups = groups
        self.dirty = False


class DriveEmulator:
    """The drives of ``robot`` (id, directory or :class:`Robot`) per its ``drives.yaml``.

    ``period`` [s] is the simulated time per SYNC (default: 1 / the profile's ``rate_hz``).
    ``channels`` overrides the python-can ``(interface, channel)`` of profile buses.
    ``clock`` [s] drives heartbeats (default :func:`time.monotonic`).
    """

    def __init__(
        self,
        robot: Robot | str | Path,
        profile: DriveProfile | None = None,
        period: float | None = None,
        channels: Mapping[str, tuple[str, str]] | None = None,
        clock: Callable[[], float] = time.monotonic,
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
        self._ports: dict[str, _Port] = {}
        for bus_name in self.profile.buses:
            interface, channel = overrides.get(bus_name, ("virtual", f"hil-{instance}-{bus_name}"))
            self._ports[bus_name] = _Port(bus_name, interface, channel, [])
        directory = drives_path(self.robot).parent
        for name, config in self.profile.drives.items():
            port = self._ports[config.bus]
            drive = EmulatedDrive(name, config.node_id, eds_path(self.profile, name, directory),
                                  port.send)  # fmt: skip
            drive.on_routes_changed = self._routes_changed(port)
            port.drives.append(drive)
            port.indices.append(len(self.drives))
            self.drives[name] = drive
        for port in self._ports.values():
            port.pending = [False] * len(port.drives)
        self._order = list(self.drives.values())  # plant order = profile order
        self.plant = Plant(self.robot, self.profile, self.period)
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
        #: Per-cycle cost of the last cycles (latch excluded) [s], for benchmarks.
        self.cycle_times: list[float] = []
        self.record_cycle_times = False

    # ----------------------------------------------------------------------------- queries

    @property
    def channels(self) -> dict[str, tuple[str, str]]:
        """Profile bus name -> python-can (interface, channel) the emulator is on."""
        return {n: (p.interface, p.channel) for n, p in self._ports.items()}

    @property
    def cycles(self) -> int:
        """Completed cycles (physics steps) since start."""
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
        frames, then close the cycle they opened if it is still open: on True every one of
        them is answered (its TPDOs are on the bus). False on timeout (threads stalled or
        stopped)."""
        ports = [(self._ports[name], count) for name, count in sent.items()]
        with self._handled:
            if not self._handled.wait_for(
                lambda: all(port.syncs >= count for port, count in ports), timeout
            ):
                return False
            if any(p.synced for p in self._ports.values()):
                self._complete_cycle()
            return True

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
                    port.bus = given[name]
                    continue
                try:
                    port.bus = can.Bus(interface=port.interface, channel=port.channel)
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
        """Open the buses if needed and run the receive threads and the heartbeat ticker."""
        self.open()
        if self._running.is_set():
            return
        self._running.set()
        for port in self._ports.values():
            thread = threading.Thread(
                target=self._receive_loop, args=(port,), name=f"emu-{port.name}", daemon=True
            )
            self._threads.append(thread)
        self._threads.append(threading.Thread(target=self._tick_loop, name="emu-tick", daemon=True))
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

    def __enter__(self) -> DriveEmulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------- synchronous API

    def poll(self, now: float | None = None) -> int:
        """Tick heartbeats at ``now``, then handle every frame waiting on every bus; how many."""
        handled = 0
        with self._lock:
            self._tick(self._clock() if now is None else now)
            for port in self._ports.values():
                bus = port.bus
                if bus is None:
                    continue
                while True:
                    msg = bus.recv(0.0)
                    if msg is None:
                        break
                    self._process(port, msg)
                    handled += 1
        return handled

    def process(self, bus: str, msg: can.Message) -> None:
        """Handle one frame as if received on ``bus``."""
        with self._lock:
            self._process(self._ports[bus], msg)

    def tick(self, now: float | None = None) -> None:
        """Heartbeat production and supervision at ``now`` [s] (default: the clock)."""
        with self._lock:
            self._tick(self._clock() if now is None else now)

    def on_sync(self, buses: Iterable[str] | None = None) -> None:
        """One full cycle without frames: SYNC on ``buses`` (default: all), then the step."""
        with self._lock:
            for name in buses if buses is not None else self._ports:
                self._sync(self._ports[name])
            if any(p.synced for p in self._ports.values()):
                self._complete_cycle()

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

    def _process(self, port: _Port, msg: can.Message) -> None:
        if msg.is_error_frame or msg.is_remote_frame or msg.is_extended_id:
            return
        if port.dirty:
            port.rebuild()
        can_id = msg.arbitration_id
        group = port.sync_groups.get(can_id)
        is_sync = group is not None or can_id == SYNC_COB_ID
        if port.bus_off or (is_sync and (group is None or not self._operational(port))):
            if is_sync:  # ignored: handled, nothing will come of it
                port.syncs += 1
                self._handled.notify_all()
            return
        if group is not None:
            self._sync(port, group)
            port.syncs += 1
            if all(p.synced for p in self._ports.values() if self._expects(p)):
                self._complete_cycle()
            self._handled.notify_all()
            return
        handlers = port.routes.get(can_id)
        if handlers:
            now = self._clock()
            data = bytes(msg.data)
            for handler in handlers:
                handler(data, now)

    def _sync(self, port: _Port, group: list[int] | None = None) -> None:
        if port.bus_off:
            return
        if port.dirty:
            port.rebuild()
        if group is None:
            group = list(range(len(port.drives)))
        pending = port.pending
        if port.synced and any(pending[k] for k in group):
            # A second SYNC before the other buses had theirs: they are gone; close the cycle.
            for other in self._ports.values():
                if not other.synced and self._expects(other):
                    other.alive = False
                    log.warning("bus %s: no SYNC this cycle; cycles go on without it", other.name)
            self._complete_cycle()
        port.alive = True
        drives = port.drives
        for k in group:
            drives[k].latch()
            pending[k] = True
        port.synced = True

    def _complete_cycle(self) -> None:
        start = time.perf_counter()
        order = self._order
        setpoints = np.empty(len(order), dtype=np.int64)
        torque = np.empty(len(order), dtype=bool)
        for i, drive in enumerate(order):
            setpoints[i], torque[i] = drive.setpoint()
        self.plant.step(setpoints, torque)
        positions = self.plant.position_counts().tolist()
        velocities = self.plant.velocity_counts().tolist()
        sim_time = self.plant.sim_time
        for port in self._ports.values():
            port.synced = False
            pending = port.pending
            for k, (i, drive) in enumerate(zip(port.indices, port.drives, strict=True)):
                if pending[k]:
                    drive.sample(positions[i], velocities[i], sim_time)
                    pending[k] = False
                else:  # no SYNC for this drive this cycle: its joint moved, nothing is sent
                    drive.actual, drive.velocity = wrap_i32(positions[i]), 0
        self._cycles += 1
        if self.record_cycle_times:
            self.cycle_times.append(time.perf_counter() - start)

    @staticmethod
    def _operational(port: _Port) -> bool:
        """One of the bus's drives is OPERATIONAL (only those answer a SYNC)."""
        return any(d.nmt_state == NMT_OPERATIONAL for d in port.drives)

    @classmethod
    def _expects(cls, port: _Port) -> bool:
        """Whether a cycle waits for this bus's SYNC: it is up, its master alive, and one of
        its drives OPERATIONAL. A SYNC on a bus without one opens no cycle."""
        return port.alive and not port.bus_off and cls._operational(port)

    def _tick(self, now: float) -> None:
        for drive in self._order:
            drive.tick(now)

    def _routes_changed(self, port: _Port) -> Callable[[], None]:
        def mark() -> None:
            port.dirty = True

        return mark

    def _set_bus_off(self, bus: str, on: bool) -> None:
        port = self._ports[bus]
        port.bus_off = on
        port.synced = False
        port.pending = [False] * len(port.drives)
        for wrapped in self._master_buses[bus]:
            wrapped.bus_off = on

    def _close_buses(self) -> None:
        for port in self._ports.values():
            if port.bus is not None:
                try:
                    port.bus.shutdown()
                except Exception as exc:  # a broken remote connection must not block close()
                    log.warning("bus %s: shutdown failed: %s", port.name, exc)
                port.bus = None

    def _receive_loop(self, port: _Port) -> None:
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

    def _tick_loop(self) -> None:
        while self._running.is_set():
            with self._lock:
                self._tick(self._clock())
            time.sleep(0.005)
