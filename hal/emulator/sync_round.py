"""A SYNC of one bus, and the physics between rounds of SYNCs (the emulator's cycle).

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

**Compiled round.** Where numba is available (``compiled``) the drives' hot values live in
one :class:`~hal.emulator.bank.DriveBank` and a bus's SYNC is one call for all its plain
drives (:func:`hal.emulator.kernels.sync_drives`), which encodes their TPDOs straight into
the bus's buffer of wire frames; the others, and every transition, fault and EMCY, take the
drives' Python path, which is also the whole of the ``IMOTION_JIT=0`` emulator. The physics
step's set-points and new actuals are one call each around :meth:`Plant.step`. Same frames
either way (``tests/test_emulator_kernels.py``), except their time stamps: the compiled round
stamps a SYNC's TPDOs with one time, the Python path each as it is sent. The master reads no
frame's time stamp (docs/emulator.md, "One time stamp per SYNC").
"""

from __future__ import annotations

import time

import numpy as np

from hal.emulator import kernels
from hal.emulator.bank import DriveBank
from hal.emulator.drive import EmulatedDrive
from hal.emulator.plant import Plant
from hal.emulator.port import Port


class SyncRound:
    """The SYNCs and physics steps of ``drives`` (plant order) on ``ports``, their hot values
    in ``bank``, their joints in ``plant`` (module doc)."""

    def __init__(
        self,
        drives: list[EmulatedDrive],
        ports: list[Port],
        bank: DriveBank,
        plant: Plant,
        compiled: bool,
    ):
        self._order = drives
        self._ports = ports
        self.bank = bank
        self.plant = plant
        self.compiled = compiled
        #: Physics steps (rounds) so far.
        self.cycles = 0
        self._setpoints = np.empty(len(drives), dtype=np.int64)
        self._torque = np.empty(len(drives), dtype=bool)
        self._now = np.zeros(1)  # [s] time.time() of a SYNC's TPDOs, and its wire bytes
        self._now_bytes = self._now.view(np.uint8)

    def sync(self, port: Port, group: list[int], slots: np.ndarray) -> None:
        """SYNC on ``port`` for its drives ``group`` (positions on the bus; ``slots``: their
        bank rows): a new round steps first (module doc), then latch, sample, TPDOs."""
        if port.synced:
            self.step()
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

    def step(self) -> None:
        """The physics of one period with every drive's latched set-point; new actuals."""
        setpoints, torque, plant = self._setpoints, self._torque, self.plant
        if self.compiled:
            kernels.setpoints(self.bank.ints, setpoints, torque)
            plant.step(setpoints, torque)
            scaling = plant.scaling
            kernels.move(self.bank.ints, plant.position, plant.velocity, scaling.factor,
                         scaling.offset)  # fmt: skip
        else:
            order = self._order
            for i, drive in enumerate(order):
                setpoints[i], torque[i] = drive.setpoint()
            plant.step(setpoints, torque)
            positions = plant.position_counts().tolist()
            velocities = plant.velocity_counts().tolist()
            for drive, position, velocity in zip(order, positions, velocities, strict=True):
                drive.move(position, velocity)
        for port in self._ports:
            port.synced = False
        self.cycles += 1

    def warm_up(self) -> None:
        """Compile (or load) the kernels now, on a scratch bank, not in the first round."""
        scratch = DriveBank(1)
        slots = np.zeros(1, dtype=np.int64)
        out = np.zeros(kernels.DRIVE_BYTES, dtype=np.uint8)
        ends = np.zeros(1, dtype=np.int64)
        kernels.sync_drives(scratch.ints, scratch.floats, slots, 0.0, self._now_bytes, out, ends,
                            np.zeros(1, dtype=bool))  # fmt: skip
        kernels.setpoints(scratch.ints, np.zeros(1, dtype=np.int64), np.zeros(1, dtype=bool))
        kernels.move(scratch.ints, np.zeros(1), np.zeros(1), np.ones(1), np.zeros(1))
