"""The CAN master's per-cycle work on every drive at once, compiled (numba).

One call per step of a cycle on the caller's preallocated arrays, where the NumPy form
(:mod:`hal.can.joints`, :mod:`hal.can.supervision`) takes 10-20 NumPy calls of a few
microseconds each on 21-element arrays:

* :func:`feedback`: TPDO counts -> SI positions and velocities per drive, wheels integrated
  from wrapped differences, vehicle odometry, the joint state (:meth:`JointMap.update`).
* :func:`command`: joint set-points -> targets [SI] and wrapped 32-bit counts per drive,
  wheel increments of the commanded base pose (:meth:`JointMap.command`).
* :func:`supervise`: TPDO1 freshness counters, heartbeat ages and the following error as
  masks (:meth:`Supervisor.check`); the faults' texts stay in Python (rare).
* :func:`decode_record` / :func:`encode_records`: a ``unix`` bus's records
  (:mod:`hal.can.unix_wire`) straight into and out of the feedback and set-point arrays,
  no Python object per frame (:mod:`hal.can.cycle`).

Each is a plain Python function on NumPy arrays (counts as int64, flags as bool), compiled
with :func:`controller.model.jit.jit` where numba imports; the callers compile or load them
when they are built (``warm_up``), never in a cycle, and keep their NumPy code where
:func:`controller.model.jit.available` is False (``IMOTION_JIT=0``; tests compare both).
"""

from __future__ import annotations

import math

import numpy as np

from controller.model import jit

I32_MIN = -(2**31)
_SPAN = 2**32

#: Results of :func:`feedback`: the vehicle's odometry must start (every wheel seen once).
START_VEHICLE = 1
#: Bits of :func:`supervise`'s result: some drive's TPDO1 late, heartbeat late, following
#: error over its window for the allowed cycles (the caller builds those faults).
LATE_TPDO, LATE_HEARTBEAT, FOLLOWING = 1, 2, 4


@jit.jit
def feedback(
    raw: np.ndarray,
    raw_velocity: np.ndarray,
    fresh: np.ndarray,
    seen: np.ndarray,
    offset: np.ndarray,
    factor: np.ndarray,
    dt: float,
    wheel_idx: np.ndarray,
    wheel_raw: np.ndarray,
    wheel_seen: np.ndarray,
    vel_idx: np.ndarray,
    pos: np.ndarray,
    prev: np.ndarray,
    vel: np.ndarray,
    joint_idx: np.ndarray,
    joint_drive: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    vehicle: np.ndarray,
    pose: np.ndarray,
    twist: np.ndarray,
    last: np.ndarray,
    inverse: np.ndarray,
    vehicle_joints: np.ndarray,
) -> int:
    """New SI state of every drive from ``raw`` [counts] and ``raw_velocity`` [counts/s]
    (``seen``: ever sent a TPDO1, ``fresh``: sent one this cycle), as
    :meth:`hal.can.joints.JointMap.update`: ``pos``/``vel`` per drive [rad, m, /s] (``prev``
    := the last ``pos``), wheels (drives ``wheel_idx``) integrated from wrapped differences
    of ``wheel_raw`` (``wheel_seen``), the drives ``vel_idx`` with their TPDO2 velocity, joint
    ``joint_idx[k]`` := drive ``joint_drive[k]`` in ``position``/``velocity``.

    ``vehicle`` (int64: a base on the wheels, its odometry started, the wheels report
    speeds) and the arrays of :class:`hal.can.vehicle.VehicleMapping` (``pose``, ``twist``
    = its velocity, ``last`` wheel angles, ``inverse``): once every wheel was seen, the
    odometry integrates the wheels' change as :meth:`VehicleMapping.measure` and goes to the
    joints ``vehicle_joints``. Returns :data:`START_VEHICLE` when every wheel has been seen
    and the odometry has not started (the caller starts it), else 0."""
    n = pos.shape[0]
    for i in range(n):
        prev[i] = pos[i]
    for i in range(n):
        if seen[i]:
            pos[i] = (float(raw[i]) - offset[i]) / factor[i]
    all_seen = True
    for k in range(wheel_idx.shape[0]):
        i = wheel_idx[k]
        if wheel_seen[k]:
            step = (raw[i] - wheel_raw[k] - I32_MIN) % _SPAN + I32_MIN
            if seen[i]:
                pos[i] = prev[i] + step / factor[i]
        if seen[i]:
            wheel_raw[k] = raw[i]
            wheel_seen[k] = True
        all_seen = all_seen and wheel_seen[k]
    for i in range(n):
        if fresh[i]:
            vel[i] = (pos[i] - prev[i]) / dt
    for k in range(vel_idx.shape[0]):
        i = vel_idx[k]
        vel[i] = float(raw_velocity[i]) / factor[i]
    for k in range(joint_idx.shape[0]):
        position[joint_idx[k]] = pos[joint_drive[k]]
        velocity[joint_idx[k]] = vel[joint_drive[k]]
    if vehicle[0] == 0 or not all_seen:
        return 0
    if vehicle[1] == 0:
        return START_VEHICLE
    w = wheel_idx.shape[0]
    d0, d1, d2 = odometry_step(pos, wheel_idx, last, inverse, pose)
    if vehicle[2]:
        t0 = t1 = t2 = 0.0
        for k in range(w):
            speed = vel[wheel_idx[k]]
            t0 += inverse[0, k] * speed
            t1 += inverse[1, k] * speed
            t2 += inverse[2, k] * speed
    else:
        t0, t1, t2 = d0 / dt, d1 / dt, d2 / dt
    c, s = math.cos(pose[2]), math.sin(pose[2])
    twist[0] = c * t0 - s * t1
    twist[1] = s * t0 + c * t1
    twist[2] = t2
    for k in range(3):
        position[vehicle_joints[k]] = pose[k]
        velocity[vehicle_joints[k]] = twist[k]
    return 0


@jit.jit
def odometry_step(
    values: np.ndarray,
    wheel_idx: np.ndarray,
    last: np.ndarray,
    inverse: np.ndarray,
    pose: np.ndarray,
) -> tuple[float, float, float]:
    """:meth:`hal.can.vehicle.VehicleMapping.measure`'s integration: the body's
    displacement (x, y [m], θ [rad], body axes) from the wheels' change since ``last`` [rad]
    (the wheels' angles ``values[wheel_idx]``; ``last`` := them), through ``inverse``, and
    ``pose`` (x, y [m], θ [rad]) advanced along it at the midpoint heading. Returns the
    displacement (the master's measured wheels and the emulator's wheel references both)."""
    d0 = d1 = d2 = 0.0
    for k in range(wheel_idx.shape[0]):
        change = values[wheel_idx[k]] - last[k]
        d0 += inverse[0, k] * change
        d1 += inverse[1, k] * change
        d2 += inverse[2, k] * change
    for k in range(wheel_idx.shape[0]):
        last[k] = values[wheel_idx[k]]
    heading = pose[2] + 0.5 * d2
    c, s = math.cos(heading), math.sin(heading)
    pose[0] += c * d0 - s * d1
    pose[1] += s * d0 + c * d1
    pose[2] += d2
    return d0, d1, d2


@jit.jit
def command(
    position: np.ndarray,
    joint_idx: np.ndarray,
    joint_drive: np.ndarray,
    target: np.ndarray,
    factor: np.ndarray,
    offset: np.ndarray,
    counts: np.ndarray,
    wheel_idx: np.ndarray,
    matrix: np.ndarray,
    command_pose: np.ndarray,
    wheel_targets: np.ndarray,
    vehicle_joints: np.ndarray,
) -> None:
    """Joint set-points ``position`` [SI] -> ``target`` [SI] and ``counts`` (rounded,
    wrapped to 32 bits) per drive, as :meth:`hal.can.joints.JointMap.command`. With wheels
    (``wheel_idx`` not empty): the change of the commanded base pose (joints
    ``vehicle_joints``; ``command_pose`` the last one, updated) turned into wheel increments
    at the mid-point heading by ``matrix`` (w x 3), added to ``wheel_targets``."""
    for k in range(joint_idx.shape[0]):
        target[joint_drive[k]] = position[joint_idx[k]]
    w = wheel_idx.shape[0]
    if w:
        last = command_pose
        d0 = position[vehicle_joints[0]] - last[0]
        d1 = position[vehicle_joints[1]] - last[1]
        d2 = position[vehicle_joints[2]] - last[2]
        heading = last[2] + 0.5 * d2
        c, s = math.cos(heading), math.sin(heading)
        b0, b1 = c * d0 + s * d1, -s * d0 + c * d1
        for k in range(w):
            wheel_targets[k] += matrix[k, 0] * b0 + matrix[k, 1] * b1 + matrix[k, 2] * d2
            target[wheel_idx[k]] = wheel_targets[k]
        for k in range(3):
            last[k] = position[vehicle_joints[k]]
    for i in range(target.shape[0]):
        value = np.int64(np.rint(target[i] * factor[i] + offset[i]))
        counts[i] = (value - I32_MIN) % _SPAN + I32_MIN


@jit.jit
def supervise(
    now: float,
    fresh: np.ndarray,
    missed: np.ndarray,
    tpdo_cycles: np.ndarray,
    last_tpdo: np.ndarray,
    tpdo_timeout: np.ndarray,
    tpdo_reported: np.ndarray,
    last_heartbeat: np.ndarray,
    heartbeat_timeout: float,
    heartbeat_reported: np.ndarray,
    active: bool,
    mask: np.ndarray,
    pos: np.ndarray,
    checked: np.ndarray,
    windows: np.ndarray,
    outside: np.ndarray,
    following_cycles: int,
    flags: np.ndarray,
) -> int:
    """The counters of :class:`hal.can.supervision.Supervisor` for one cycle at ``now`` [s],
    as its ``tpdo``, ``heartbeats`` and ``following``: per drive ``flags`` (bits
    :data:`LATE_TPDO`, :data:`LATE_HEARTBEAT`, :data:`FOLLOWING`) of the faults to report
    (marked reported here), their union returned. The following error is ``pos −
    checked`` [SI], counted on the drives of ``mask`` only when ``active``."""
    found = 0
    for i in range(fresh.shape[0]):
        bits = 0
        if fresh[i]:
            missed[i] = 0
            last_tpdo[i] = now
            tpdo_reported[i] = False
        else:
            missed[i] += 1
            if (
                missed[i] >= tpdo_cycles[i]
                and not tpdo_reported[i]
                and now - last_tpdo[i] >= tpdo_timeout[i] - 1e-9  # clock rounding
            ):
                tpdo_reported[i] = True
                bits |= LATE_TPDO
        if now - last_heartbeat[i] > heartbeat_timeout and not heartbeat_reported[i]:
            heartbeat_reported[i] = True
            bits |= LATE_HEARTBEAT
        if active:
            if mask[i] and abs(pos[i] - checked[i]) > windows[i]:
                outside[i] += 1
                if outside[i] == following_cycles:
                    bits |= FOLLOWING
            else:
                outside[i] = 0
        flags[i] = bits
        found |= bits
    return found


#: Kinds in the COB-ID tables of :func:`decode_record` (0: not decoded).
K_TPDO1, K_TPDO2, K_HEARTBEAT, K_EMCY = 1, 2, 3, 4
#: A ``unix`` wire frame's header [bytes] (:data:`hal.can.unix_wire.HEADER`).
HEADER_SIZE = 16
#: The heartbeat state byte of an OPERATIONAL node (the only one with nothing to report).
OPERATIONAL = 0x05


@jit.jit
def decode_record(
    record: bytes,
    start: int,
    kinds: np.ndarray,
    drives: np.ndarray,
    frame_bits: np.ndarray,
    statusword: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    fresh: np.ndarray,
    seen: np.ndarray,
    now: float,
    last_heartbeat: np.ndarray,
    counts: np.ndarray,
) -> int:
    """Decode the frames of one ``unix`` record (:mod:`hal.can.unix_wire`)
    from byte ``start`` into the feedback arrays: TPDO1 (statusword, position actual), TPDO2
    (velocity actual), an OPERATIONAL heartbeat (``last_heartbeat`` := ``now``), by the
    tables ``kinds``/``drives`` (index: COB-ID of a classic frame). Classic frames are
    counted in ``counts`` (frames, worst-case bits by ``frame_bits``), unknown ones skipped.
    Stops at the first frame the caller must decode (any other heartbeat, EMCY, a frame with
    flags: not counted) or at a cut (the rest is shorter than its header says); returns
    that byte offset, or the record's length when every frame was decoded."""
    size = len(record)
    while start + HEADER_SIZE <= size:
        can_id = (
            np.int64(record[start])
            | (np.int64(record[start + 1]) << 8)
            | (np.int64(record[start + 2]) << 16)
            | (np.int64(record[start + 3]) << 24)
        )
        length = np.int64(record[start + 6])
        data = start + HEADER_SIZE
        end = data + length
        if record[start + 4] != 0 or end > size:
            return start
        kind = kinds[can_id] if can_id < kinds.shape[0] else 0
        i = drives[can_id] if kind else 0
        if kind == K_TPDO1:
            if length >= 6:
                statusword[i] = np.int64(record[data]) | (np.int64(record[data + 1]) << 8)
                value = (
                    np.int64(record[data + 2])
                    | (np.int64(record[data + 3]) << 8)
                    | (np.int64(record[data + 4]) << 16)
                    | (np.int64(record[data + 5]) << 24)
                )
                position[i] = value - _SPAN if value > 0x7FFFFFFF else value
                fresh[i] = True
                seen[i] = True
        elif kind == K_TPDO2:
            if length >= 4:
                value = (
                    np.int64(record[data])
                    | (np.int64(record[data + 1]) << 8)
                    | (np.int64(record[data + 2]) << 16)
                    | (np.int64(record[data + 3]) << 24)
                )
                velocity[i] = value - _SPAN if value > 0x7FFFFFFF else value
        elif kind == K_HEARTBEAT:
            if length >= 1:
                if record[data] != OPERATIONAL:
                    return start  # booted, stopped, pre-operational: the caller's
                last_heartbeat[i] = now
        elif kind == K_EMCY:
            if length >= 3:
                return start  # the caller's
        counts[0] += 1
        counts[1] += frame_bits[length if length < 9 else 8]
        start = int(end)
    return start


@jit.jit
def encode_records(
    out: np.ndarray,
    header: np.ndarray,
    stamp: np.ndarray,
    rows: np.ndarray,
    drives: np.ndarray,
    seen: np.ndarray,
    controlword: np.ndarray,
    target: np.ndarray,
    bounds: np.ndarray,
) -> None:
    """One ``unix`` record per bus of a cycle into ``out`` (uint8), bus ``p`` in bytes
    ``bounds[p, 0]:bounds[p, 1]``: the RPDO1 (controlword, target [counts]) of every drive
    seen, then the SYNC. Bus ``p`` owns the rows ``rows[p]:rows[p + 1]`` of ``header``
    (uint8, 8 bytes each: a frame header without its timestamp) and ``drives`` (the drive of
    each RPDO1 row, −1 for the bus's SYNC, its last row); every frame gets the timestamp
    ``stamp`` (8 bytes)."""
    at = 0
    for p in range(rows.shape[0] - 1):
        bounds[p, 0] = at
        for r in range(rows[p], rows[p + 1]):
            i = drives[r]
            if i >= 0 and not seen[i]:
                continue
            for b in range(8):
                out[at + b] = header[r, b]
                out[at + 8 + b] = stamp[b]
            at += HEADER_SIZE
            if i < 0:
                continue
            cw = controlword[i]
            out[at] = cw & 0xFF
            out[at + 1] = (cw >> 8) & 0xFF
            value = target[i] & 0xFFFFFFFF
            out[at + 2] = value & 0xFF
            out[at + 3] = (value >> 8) & 0xFF
            out[at + 4] = (value >> 16) & 0xFF
            out[at + 5] = (value >> 24) & 0xFF
            at += 6
        bounds[p, 1] = at


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel for the arrays its callers pass:
    int64 counts and indices, float64 values, bool flags (C-contiguous), records as
    ``bytes`` and encode buffers as writable uint8. Called at import."""
    i64, f64, flag = np.zeros(1, np.int64), np.zeros(1), np.zeros(1, np.bool_)
    mat = np.zeros((3, 1))
    feedback(i64, i64, flag, flag, f64, np.ones(1), 0.002, i64, i64.copy(), flag.copy(),
             i64, f64.copy(), f64.copy(), f64.copy(), i64, i64, f64.copy(), f64.copy(),
             np.zeros(3, np.int64), np.zeros(3), np.zeros(3), f64.copy(), mat,
             np.zeros(3, np.int64))  # fmt: skip
    command(f64, i64, i64, f64.copy(), np.ones(1), f64, i64.copy(), i64, np.zeros((1, 3)),
            np.zeros(3), f64.copy(), np.zeros(3, np.int64))  # fmt: skip
    supervise(0.0, flag, i64.copy(), i64, f64.copy(), f64, flag.copy(), f64, 1.0, flag.copy(),
              True, flag, f64, f64, f64, i64.copy(), 1, i64.copy())  # fmt: skip
    table = np.zeros(2048, np.int64)
    decode_record(bytes(HEADER_SIZE), 0, table, table,
                  np.zeros(9, np.int64), i64.copy(), i64.copy(), i64.copy(), flag.copy(),
                  flag.copy(), 0.0, f64.copy(), np.zeros(2, np.int64))  # fmt: skip
    encode_records(np.zeros(64, np.uint8), np.zeros((2, 8), np.uint8), np.zeros(8, np.uint8),
                   np.array([0, 2]), np.array([0, -1]), flag, i64, i64,
                   np.zeros((1, 2), np.int64))  # fmt: skip


if jit.available():  # compile (or load) at import: never in a control cycle
    warm_up()
