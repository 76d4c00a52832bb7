"""Compiled distances and distance-Jacobian rows of collision pairs (numba kernels).

:class:`~controller.model.collision.CollisionDistances` computes, every control cycle, the
distance, witness points and normal of each checked shape pair and the Jacobian rows of the
closest ones. Through coal and NumPy that costs ~190 µs per cycle on SmartPal V (196 shape
pairs; most of it Python reading coal's results one by one and small-array overhead); this
module does the same work in compiled code (~13 µs for the distances):

* :func:`update`: the joint placements of the configuration and each joint's world axis and
  origin (its Jacobian column; :func:`controller.model.joint_chain.forward`), every shape's
  world placement, then closed forms per pair kind:
  capsule/sphere pairs (closest points of two segments), capsule/sphere–box (exact minimum
  of the piecewise quadratic squared distance along the segment; golden-section search on
  the signed distance when the segment enters the box), anything–half-space (the lowest
  point); box–box pairs are left to coal (the caller);
* :func:`jacobian_rows`: ``n^T (J_p1 − J_p2)`` from the joint axes, over the columns of each
  pair's support mask.

Conventions are coal's as :class:`CollisionDistances` reads them: signed distance ``d`` [m]
(negative when the shapes overlap), ``n`` the unit normal from shape 2 to shape 1, witness
points ``p1 = p2 + d n`` (world, [m]).

Compiled with :mod:`controller.model.jit`; where :func:`~controller.model.jit.available` is
False, :class:`CollisionDistances` uses coal for every pair (the same results, slower; tests
run both).
"""

from __future__ import annotations

import math
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from controller.model.collision_screen import PairScreen, publish, screen, shape_extent
from controller.model.jit import jit
from controller.model.joint_chain import PRISMATIC, JointChain, Unsupported, compose, forward

#: Shape kinds of the kernels (a sphere is a capsule of length 0).
CAPSULE, BOX, HALFSPACE = 0, 1, 2
#: Pairs :func:`update` computes, and pairs left to the caller (box–box).
KERNEL, OTHER = 0, 1
#: Golden-section steps for a segment inside a box (the interval shrinks 0.618x per step).
GOLDEN_STEPS = 60


# ------------------------------------------------------------------------------- update
@jit
def update(
    q: np.ndarray,
    joint_int: np.ndarray,
    joint_frame: np.ndarray,
    joint_world: np.ndarray,
    columns: np.ndarray,
    column_kind: np.ndarray,
    shape_int: np.ndarray,
    shape_frame: np.ndarray,
    shape_world: np.ndarray,
    size: np.ndarray,
    seg: np.ndarray,
    pairs: np.ndarray,
    d: np.ndarray,
    witness: np.ndarray,
    screen_state: np.ndarray,
    screen_index: np.ndarray,
    screen_flags: np.ndarray,
) -> None:
    """Everything of configuration ``q`` [rad, m] (see :class:`CompiledPairs` for the arrays):

    * the joints' world placements ``joint_world`` (rows 0-2 rotation, row 3 translation
      [m]; joint 0 is the world, set by the caller) from ``joint_int`` (parent, kind,
      velocity index) and ``joint_frame`` (placement rotation, translation, axis);
    * the Jacobian ``columns`` by velocity index (world axis, a point of it [m]) and kinds;
    * the shapes' world placements ``shape_world`` from ``shape_frame`` (on their joint,
      ``shape_int``: joint, kind) and the capsules' segments ``seg``;
    * per ``KERNEL`` pair of ``pairs`` (shape 1, shape 2, kind) the distance ``d`` [m] and
      ``witness``: normal from shape 2 to shape 1, witness points on shape 1 and 2 [m].
      ``size`` per shape: capsule (radius, half length), sphere (radius, 0), box (half
      sides), half-space (normal, offset) in its own frame. ``OTHER`` rows are left as
      they are;
    * which pairs it computes: the rest of the arguments are a
      :class:`~controller.model.collision_screen.PairScreen`'s (every pair while it is off).
    """
    forward(q, joint_int, joint_frame, joint_world, columns, column_kind)
    update_placed(
        q, joint_world, columns, columns, shape_int, shape_frame, shape_world, size, seg,
        pairs, d, witness, screen_state, screen_index, screen_flags,
    )  # fmt: skip


@jit
def update_placed(
    q: np.ndarray,
    placed_world: np.ndarray,
    placed_columns: np.ndarray,
    columns: np.ndarray,
    shape_int: np.ndarray,
    shape_frame: np.ndarray,
    shape_world: np.ndarray,
    size: np.ndarray,
    seg: np.ndarray,
    pairs: np.ndarray,
    d: np.ndarray,
    witness: np.ndarray,
    screen_state: np.ndarray,
    screen_index: np.ndarray,
    screen_flags: np.ndarray,
) -> None:
    """:func:`update` on joints another chain of the same model has placed already
    (``placed_world``, ``placed_columns``: the kinematics' own, at the same ``q``): the
    Jacobian columns copied into ``columns`` (what :func:`jacobian_rows` reads), the joints
    not placed again (:func:`update`'s own after it placed them: the columns its own)."""
    columns[...] = placed_columns
    screen(q, d, screen_state, screen_index, screen_flags)
    computed = screen_flags[d.shape[0] :]
    _measure(
        placed_world, shape_int, shape_frame, shape_world, size, seg, pairs, d, witness, computed
    )
    publish(q, d, screen_state, screen_index, screen_flags)


@jit
def _measure(
    joint_world: np.ndarray,
    shape_int: np.ndarray,
    shape_frame: np.ndarray,
    shape_world: np.ndarray,
    size: np.ndarray,
    seg: np.ndarray,
    pairs: np.ndarray,
    d: np.ndarray,
    witness: np.ndarray,
    computed: np.ndarray,
) -> None:
    """:func:`update` after the joints' placements: every ``KERNEL`` pair ``computed``
    marks, on the world placements of its shapes (``shape_world``, and ``seg`` for capsules;
    every shape's when every pair is computed, else only those of the computed pairs)."""
    kinds = shape_int[:, 1]
    world_rot = shape_world[:, :3]
    world_pos = shape_world[:, 3]
    every = True
    for k in range(pairs.shape[0]):
        if not computed[k]:
            every = False
            break
    placed = np.zeros(shape_int.shape[0], dtype=np.bool_)
    if every:
        for g in range(shape_int.shape[0]):
            _place_shape(g, joint_world, shape_int, shape_frame, shape_world, size, seg)
            placed[g] = True
    n, p1, p2 = witness[:, 0], witness[:, 1], witness[:, 2]
    scratch = np.empty(14)
    for k in range(pairs.shape[0]):
        if pairs[k, 2] != KERNEL or not computed[k]:
            continue
        g1, g2 = pairs[k, 0], pairs[k, 1]
        if not placed[g1]:
            _place_shape(g1, joint_world, shape_int, shape_frame, shape_world, size, seg)
            placed[g1] = True
        if not placed[g2]:
            _place_shape(g2, joint_world, shape_int, shape_frame, shape_world, size, seg)
            placed[g2] = True
        k1, k2 = kinds[g1], kinds[g2]
        if k1 == CAPSULE and k2 == CAPSULE:
            _capsules(k, g1, g2, seg, d, n, p1, p2)
        elif k2 == HALFSPACE:
            _halfspace(k, g1, g2, False, kinds, world_rot, world_pos, size, seg, d, n, p1, p2)
        elif k1 == HALFSPACE:
            _halfspace(k, g2, g1, True, kinds, world_rot, world_pos, size, seg, d, n, p1, p2)
        elif k2 == BOX:
            _capsule_box(k, g1, g2, False, world_rot, world_pos, size, seg, d, n, p1, p2, scratch)
        else:
            _capsule_box(k, g2, g1, True, world_rot, world_pos, size, seg, d, n, p1, p2, scratch)


@jit
def _place_shape(
    g: int,
    joint_world: np.ndarray,
    shape_int: np.ndarray,
    shape_frame: np.ndarray,
    shape_world: np.ndarray,
    size: np.ndarray,
    seg: np.ndarray,
) -> None:
    """Shape ``g``'s world placement on its joint's; a capsule's (or sphere's) segment end
    points along its z and its radius [m] too."""
    compose(joint_world[shape_int[g, 0]], shape_frame[g], shape_world[g])
    if shape_int[g, 1] != CAPSULE:
        return
    h = size[g, 1]
    rot = shape_world[g]
    ax, ay, az = rot[0, 2] * h, rot[1, 2] * h, rot[2, 2] * h
    cx, cy, cz = rot[3, 0], rot[3, 1], rot[3, 2]
    seg[g, 0], seg[g, 1], seg[g, 2] = cx - ax, cy - ay, cz - az
    seg[g, 3], seg[g, 4], seg[g, 5] = cx + ax, cy + ay, cz + az
    seg[g, 6] = size[g, 0]


# ------------------------------------------------------------------------------ distances
@jit
def _clamp01(x: float) -> float:
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)


@jit
def _segment_ends(g: int, seg: np.ndarray) -> Any:
    """A capsule's (or sphere's) segment end points and radius [m] (see :func:`_place_shape`)."""
    return seg[g, 0], seg[g, 1], seg[g, 2], seg[g, 3], seg[g, 4], seg[g, 5], seg[g, 6]


@jit
def _normal_or_any(dx: float, dy: float, dz: float, ex: float, ey: float, ez: float) -> Any:
    """``(dx, dy, dz)`` normalised with its length; when it is ~0 (shapes' cores meet), a unit
    vector across the direction ``e`` (or z), length 0."""
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    if length > 1e-12:
        return dx / length, dy / length, dz / length, length
    # any unit vector perpendicular to e (e ~ 0: z)
    if abs(ex) < 0.9 * math.sqrt(ex * ex + ey * ey + ez * ez):
        cx, cy, cz = 0.0, ez, -ey  # e x (1, 0, 0)
    else:
        cx, cy, cz = -ez, 0.0, ex  # e x (0, 1, 0)
    n = math.sqrt(cx * cx + cy * cy + cz * cz)
    if n < 1e-12:
        return 0.0, 0.0, 1.0, 0.0
    return cx / n, cy / n, cz / n, 0.0


@jit
def _capsules(
    k: int,
    g1: int,
    g2: int,
    seg: np.ndarray,
    d: np.ndarray,
    n: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
) -> None:
    """Two capsules (or spheres): the closest points of their segments, minus the radii."""
    a1x, a1y, a1z, b1x, b1y, b1z, r1 = _segment_ends(g1, seg)
    a2x, a2y, a2z, b2x, b2y, b2z, r2 = _segment_ends(g2, seg)
    e1x, e1y, e1z = b1x - a1x, b1y - a1y, b1z - a1z
    e2x, e2y, e2z = b2x - a2x, b2y - a2y, b2z - a2z
    wx, wy, wz = a1x - a2x, a1y - a2y, a1z - a2z
    aa = e1x * e1x + e1y * e1y + e1z * e1z
    ee = e2x * e2x + e2y * e2y + e2z * e2z
    f = e2x * wx + e2y * wy + e2z * wz
    tiny = 1e-18
    if aa <= tiny and ee <= tiny:
        s, t = 0.0, 0.0
    elif aa <= tiny:
        s, t = 0.0, _clamp01(f / ee)
    else:
        c = e1x * wx + e1y * wy + e1z * wz
        if ee <= tiny:
            s, t = _clamp01(-c / aa), 0.0
        else:
            b = e1x * e2x + e1y * e2y + e1z * e2z
            den = aa * ee - b * b
            s = _clamp01((b * f - c * ee) / den) if den > 1e-12 * aa * ee else 0.0
            t = (b * s + f) / ee
            if t < 0.0:
                s, t = _clamp01(-c / aa), 0.0
            elif t > 1.0:
                s, t = _clamp01((b - c) / aa), 1.0
    c1x, c1y, c1z = a1x + s * e1x, a1y + s * e1y, a1z + s * e1z
    c2x, c2y, c2z = a2x + t * e2x, a2y + t * e2y, a2z + t * e2z
    ux, uy, uz = c1x - c2x, c1y - c2y, c1z - c2z
    length = math.sqrt(ux * ux + uy * uy + uz * uz)
    if length > 1e-12:
        ux, uy, uz = ux / length, uy / length, uz / length
    else:  # the segments meet: a normal across both (or across the one, or z)
        qx, qy, qz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        ux, uy, uz, norm = _normal_or_any(qx, qy, qz, e1x + e2x, e1y + e2y, e1z + e2z)
        if norm == 0.0:  # parallel (or points): across their common direction
            ux, uy, uz, _ = _normal_or_any(0.0, 0.0, 0.0, e1x + e2x, e1y + e2y, e1z + e2z)
        length = 0.0
    d[k] = length - r1 - r2
    n[k, 0], n[k, 1], n[k, 2] = ux, uy, uz
    p1[k, 0], p1[k, 1], p1[k, 2] = c1x - r1 * ux, c1y - r1 * uy, c1z - r1 * uz
    p2[k, 0], p2[k, 1], p2[k, 2] = c2x + r2 * ux, c2y + r2 * uy, c2z + r2 * uz


@jit
def _box_signed(x: float, y: float, z: float, hx: float, hy: float, hz: float) -> float:
    """Signed distance [m] of a point to a box centred at 0 with half sides ``h`` (box frame)."""
    qx, qy, qz = abs(x) - hx, abs(y) - hy, abs(z) - hz
    ox, oy, oz = max(qx, 0.0), max(qy, 0.0), max(qz, 0.0)
    return math.sqrt(ox * ox + oy * oy + oz * oz) + min(max(qx, max(qy, qz)), 0.0)


@jit
def _segment_box_t(
    ax: float,
    ay: float,
    az: float,
    ex: float,
    ey: float,
    ez: float,
    h: np.ndarray,
    breaks: np.ndarray,
) -> float:
    """The point ``a + t e`` (``t`` in [0, 1], box frame) of a segment closest to the box.

    Outside the box the squared distance is piecewise quadratic in ``t`` with a break where a
    coordinate crosses ±h: its exact minimum per piece. When the segment reaches the box, the
    deepest point: golden-section search on the (convex) signed distance. ``breaks``:
    scratch space for 8 values."""
    a = (ax, ay, az)
    e = (ex, ey, ez)
    breaks[0], breaks[1] = 0.0, 1.0
    m = 2
    for i in range(3):
        if e[i] != 0.0:
            for side in (-1.0, 1.0):
                t = (side * h[i] - a[i]) / e[i]
                if 0.0 < t < 1.0:
                    # insertion sort as they come (at most 8 values)
                    at = m
                    while at > 1 and breaks[at - 1] > t:
                        breaks[at] = breaks[at - 1]
                        at -= 1
                    breaks[at] = t
                    m += 1
    best_t, best = 0.0, np.inf
    for piece in range(m - 1):
        t0, t1 = breaks[piece], breaks[piece + 1]
        mid = 0.5 * (t0 + t1)
        num, den = 0.0, 0.0
        for i in range(3):
            x = a[i] + mid * e[i]
            if x > h[i]:
                num += (h[i] - a[i]) * e[i]
                den += e[i] * e[i]
            elif x < -h[i]:
                num += (-h[i] - a[i]) * e[i]
                den += e[i] * e[i]
        t = num / den if den > 0.0 else t0
        t = min(max(t, t0), t1)
        sq = 0.0
        for i in range(3):
            x = a[i] + t * e[i]
            o = max(abs(x) - h[i], 0.0)
            sq += o * o
        if sq < best:
            best_t, best = t, sq
    if best > 1e-24:
        return best_t
    # inside: the deepest point (the signed distance is convex along the segment)
    lo, hi = 0.0, 1.0
    ratio = 0.5 * (math.sqrt(5.0) - 1.0)
    u = hi - ratio * (hi - lo)
    v = lo + ratio * (hi - lo)
    fu = _box_signed(ax + u * ex, ay + u * ey, az + u * ez, h[0], h[1], h[2])
    fv = _box_signed(ax + v * ex, ay + v * ey, az + v * ez, h[0], h[1], h[2])
    for _ in range(GOLDEN_STEPS):
        if fu < fv:
            hi, v, fv = v, u, fu
            u = hi - ratio * (hi - lo)
            fu = _box_signed(ax + u * ex, ay + u * ey, az + u * ez, h[0], h[1], h[2])
        else:
            lo, u, fu = u, v, fv
            v = lo + ratio * (hi - lo)
            fv = _box_signed(ax + v * ex, ay + v * ey, az + v * ez, h[0], h[1], h[2])
    return 0.5 * (lo + hi)


@jit
def _store(
    k: int,
    distance: float,
    ux: float,
    uy: float,
    uz: float,
    cx: float,
    cy: float,
    cz: float,
    wx: float,
    wy: float,
    wz: float,
    flip: bool,
    d: np.ndarray,
    n: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
) -> None:
    """Pair ``k``'s result: ``u`` the unit normal from the other shape to the first, ``c``
    and ``w`` their witness points; ``flip``: the pair lists the other shape first."""
    d[k] = distance
    sign = -1.0 if flip else 1.0
    n[k, 0], n[k, 1], n[k, 2] = sign * ux, sign * uy, sign * uz
    first, second = (p2, p1) if flip else (p1, p2)
    first[k, 0], first[k, 1], first[k, 2] = cx, cy, cz
    second[k, 0], second[k, 1], second[k, 2] = wx, wy, wz


@jit
def _capsule_box(
    k: int,
    cap: int,
    box: int,
    flip: bool,
    world_rot: np.ndarray,
    world_pos: np.ndarray,
    size: np.ndarray,
    seg: np.ndarray,
    d: np.ndarray,
    n: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
    scratch: np.ndarray,
) -> None:
    """A capsule (or sphere) and a box; ``flip``: the box is shape 1. ``scratch``: 14 values."""
    a_x, a_y, a_z, b_x, b_y, b_z, r = _segment_ends(cap, seg)
    R = world_rot[box]
    c = world_pos[box]
    h = size[box]
    # the segment in the box frame: R^T (x - c)
    ax = R[0, 0] * (a_x - c[0]) + R[1, 0] * (a_y - c[1]) + R[2, 0] * (a_z - c[2])
    ay = R[0, 1] * (a_x - c[0]) + R[1, 1] * (a_y - c[1]) + R[2, 1] * (a_z - c[2])
    az = R[0, 2] * (a_x - c[0]) + R[1, 2] * (a_y - c[1]) + R[2, 2] * (a_z - c[2])
    bx = R[0, 0] * (b_x - c[0]) + R[1, 0] * (b_y - c[1]) + R[2, 0] * (b_z - c[2])
    by = R[0, 1] * (b_x - c[0]) + R[1, 1] * (b_y - c[1]) + R[2, 1] * (b_z - c[2])
    bz = R[0, 2] * (b_x - c[0]) + R[1, 2] * (b_y - c[1]) + R[2, 2] * (b_z - c[2])
    ex, ey, ez = bx - ax, by - ay, bz - az
    t = _segment_box_t(ax, ay, az, ex, ey, ez, h, scratch[:8])
    x = (ax + t * ex, ay + t * ey, az + t * ez)
    # the box's surface point and outward normal (box frame)
    y = scratch[8:11]
    m = scratch[11:14]
    m[:] = 0.0
    outside = False
    for i in range(3):
        y[i] = min(max(x[i], -h[i]), h[i])
        if y[i] != x[i]:
            outside = True
    if outside:
        mx, my, mz = x[0] - y[0], x[1] - y[1], x[2] - y[2]
        length = math.sqrt(mx * mx + my * my + mz * mz)
        m[0], m[1], m[2] = mx / length, my / length, mz / length
        signed = length
    else:  # inside: out through the nearest face
        face, depth = 0, h[0] - abs(x[0])
        for i in (1, 2):
            if h[i] - abs(x[i]) < depth:
                face, depth = i, h[i] - abs(x[i])
        sign = 1.0 if x[face] >= 0.0 else -1.0
        y[face] = sign * h[face]
        m[face] = sign
        signed = -depth
    # back to the world
    ux = R[0, 0] * m[0] + R[0, 1] * m[1] + R[0, 2] * m[2]
    uy = R[1, 0] * m[0] + R[1, 1] * m[1] + R[1, 2] * m[2]
    uz = R[2, 0] * m[0] + R[2, 1] * m[1] + R[2, 2] * m[2]
    wx = c[0] + R[0, 0] * y[0] + R[0, 1] * y[1] + R[0, 2] * y[2]
    wy = c[1] + R[1, 0] * y[0] + R[1, 1] * y[1] + R[1, 2] * y[2]
    wz = c[2] + R[2, 0] * y[0] + R[2, 1] * y[1] + R[2, 2] * y[2]
    # the capsule's witness: its segment point, the radius back along the normal
    sx, sy, sz = a_x + t * (b_x - a_x), a_y + t * (b_y - a_y), a_z + t * (b_z - a_z)
    cx, cy, cz = sx - r * ux, sy - r * uy, sz - r * uz
    _store(k, signed - r, ux, uy, uz, cx, cy, cz, wx, wy, wz, flip, d, n, p1, p2)


@jit
def _halfspace(
    k: int,
    shape: int,
    plane: int,
    flip: bool,
    kinds: np.ndarray,
    world_rot: np.ndarray,
    world_pos: np.ndarray,
    size: np.ndarray,
    seg: np.ndarray,
    d: np.ndarray,
    n: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
) -> None:
    """A capsule, sphere or box and a half-space ``{x: n·x ≤ off}`` (its frame: ``size`` holds
    ``n``, ``off``); ``flip``: the half-space is shape 1. The lowest point of the shape."""
    R = world_rot[plane]
    c = world_pos[plane]
    lx, ly, lz, off = size[plane, 0], size[plane, 1], size[plane, 2], size[plane, 3]
    ux = R[0, 0] * lx + R[0, 1] * ly + R[0, 2] * lz
    uy = R[1, 0] * lx + R[1, 1] * ly + R[1, 2] * lz
    uz = R[2, 0] * lx + R[2, 1] * ly + R[2, 2] * lz
    level = off + ux * c[0] + uy * c[1] + uz * c[2]
    if kinds[shape] == CAPSULE:
        a_x, a_y, a_z, b_x, b_y, b_z, r = _segment_ends(shape, seg)
        sa = ux * a_x + uy * a_y + uz * a_z
        sb = ux * b_x + uy * b_y + uz * b_z
        if abs(sa - sb) < 1e-12:
            px, py, pz, low = 0.5 * (a_x + b_x), 0.5 * (a_y + b_y), 0.5 * (a_z + b_z), sa
        elif sa < sb:
            px, py, pz, low = a_x, a_y, a_z, sa
        else:
            px, py, pz, low = b_x, b_y, b_z, sb
    else:  # box: its lowest corner (or the middle of its lowest face or edge)
        B = world_rot[shape]
        h = size[shape]
        px, py, pz = world_pos[shape, 0], world_pos[shape, 1], world_pos[shape, 2]
        for i in range(3):
            along = ux * B[0, i] + uy * B[1, i] + uz * B[2, i]
            if abs(along) > 1e-12:
                step = -h[i] if along > 0.0 else h[i]
                px, py, pz = px + step * B[0, i], py + step * B[1, i], pz + step * B[2, i]
        low = ux * px + uy * py + uz * pz
        r = 0.0
    gap = low - level
    cx, cy, cz = px - r * ux, py - r * uy, pz - r * uz
    wx, wy, wz = px - gap * ux, py - gap * uy, pz - gap * uz
    _store(k, gap - r, ux, uy, uz, cx, cy, cz, wx, wy, wz, flip, d, n, p1, p2)


# ------------------------------------------------------------------------------- Jacobian
@jit
def jacobian_rows(
    index: np.ndarray,
    support: np.ndarray,
    witness: np.ndarray,
    columns: np.ndarray,
    column_kind: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[r] = n^T (J_p1 − J_p2)`` of pair ``index[r]`` [m/rad, m/m]: over each column of
    its ``support`` mask (+1: moves shape 1 only, −1: shape 2 only, 0: both alike or none),
    a revolute joint moves a point ``p`` at ``axis × (p − origin)``, a prismatic one at
    ``axis`` (``columns``, ``witness``: see :func:`update`)."""
    nv = out.shape[1]
    for r in range(index.shape[0]):
        k = index[r]
        nx, ny, nz = witness[k, 0, 0], witness[k, 0, 1], witness[k, 0, 2]
        for v in range(nv):
            s = support[k, v]
            if s == 0.0:
                out[r, v] = 0.0
                continue
            ax, ay, az = columns[v, 0, 0], columns[v, 0, 1], columns[v, 0, 2]
            if column_kind[v] == PRISMATIC:
                out[r, v] = s * (nx * ax + ny * ay + nz * az)
                continue
            side = 1 if s > 0.0 else 2  # the witness point on the shape this joint moves
            rx = witness[k, side, 0] - columns[v, 1, 0]
            ry = witness[k, side, 1] - columns[v, 1, 1]
            rz = witness[k, side, 2] - columns[v, 1, 2]
            # n · (axis × r)
            out[r, v] = s * (
                nx * (ay * rz - az * ry) + ny * (az * rx - ax * rz) + nz * (ax * ry - ay * rx)
            )


# ---------------------------------------------------------------------------------- model
def _shape_row(geometry: Any) -> tuple[int, np.ndarray]:
    """Kind and ``size`` row (see :func:`update`) of a coal geometry."""
    size = np.zeros(4)
    if isinstance(geometry, coal.Capsule):
        size[:2] = geometry.radius, geometry.halfLength
        return CAPSULE, size
    if isinstance(geometry, coal.Sphere):
        size[0] = geometry.radius
        return CAPSULE, size
    if isinstance(geometry, coal.Box):
        size[:3] = geometry.halfSide
        return BOX, size
    if isinstance(geometry, coal.Halfspace):
        size[:3] = geometry.n
        size[3] = geometry.d
        return HALFSPACE, size
    raise Unsupported(f"no kernel for {type(geometry).__name__} shapes")


class CompiledPairs:
    """The kernels' view of a Pinocchio model and geometry model, and their work arrays.

    ``pairs``: (shape 1, shape 2) geometry indices per row. Raises :class:`Unsupported` for
    joints other than 1-dof revolute/prismatic ones or shapes other than capsules, spheres,
    boxes and half-spaces. Not thread-safe (one per :class:`CollisionDistances`).

    Arrays (few and packed: each array a compiled call takes costs ~0.07 µs to pass):
    ``joint_int`` (parent, kind, velocity index), ``joint_frame`` (placement rotation rows,
    translation, axis), ``joint_world`` (rotation rows, translation [m]), ``columns`` (axis,
    origin [m]) and ``column_kind`` by velocity index, ``shape_int`` (joint, kind),
    ``shape_frame`` and ``shape_world`` (rotation rows, translation [m]), ``size``,
    ``segments``, ``pairs`` (shape 1, shape 2, ``KERNEL``/``OTHER``)."""

    def __init__(self, model: pin.Model, geometry: pin.GeometryModel, pairs: np.ndarray):
        chain = JointChain(model)
        objects = geometry.geometryObjects
        ng = len(objects)
        self.shape_int = np.zeros((ng, 2), dtype=np.int64)
        self.shape_frame = np.zeros((ng, 4, 3))
        for g, obj in enumerate(objects):
            self.shape_int[g, 0] = obj.parentJoint
            self.shape_frame[g, :3] = obj.placement.rotation
            self.shape_frame[g, 3] = obj.placement.translation
        self.size = np.zeros((ng, 4))
        self._read_sizes(geometry)
        shapes = np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2)
        self.pairs = np.zeros((len(shapes), 3), dtype=np.int64)
        self.pairs[:, :2] = shapes
        boxes = (self.shape_int[:, 1][shapes] == BOX).all(axis=1)
        self.pairs[:, 2] = np.where(boxes, OTHER, KERNEL)
        #: Rows coal computes (box–box pairs).
        self.other = np.flatnonzero(boxes)
        # work arrays
        self.joint_int, self.joint_frame = chain.joint_int, chain.joint_frame
        self.joint_world, self.columns = chain.joint_world, chain.columns
        self.column_kind = chain.column_kind
        self.shape_world = np.zeros((ng, 4, 3))
        #: Per capsule or sphere: segment end points and radius [m] (see :func:`_place_shape`).
        self.segments = np.zeros((ng, 7))
        #: :func:`update`'s arguments after ``q`` (written in place, never replaced).
        self.model_arrays = (
            self.joint_int, self.joint_frame, self.joint_world, self.columns,
            self.column_kind, self.shape_int, self.shape_frame, self.shape_world, self.size,
            self.segments, self.pairs,
        )  # fmt: skip
        #: :func:`update_placed`'s arguments after the placed chain's two arrays.
        self.shape_arrays = self.model_arrays[3:4] + self.model_arrays[5:]
        #: Which pairs an update computes (off until :meth:`PairScreen.set`); box-box
        #: pairs, which coal computes, every time.
        always = np.zeros(len(shapes), dtype=np.bool_)
        always[self.other] = True
        self.screen = PairScreen(model, self.shape_int[:, 0], self._extents(), shapes, always)
        #: The chain :func:`update` places (its own).
        self.chain = chain
        #: The last other chain :meth:`accepts` checked (the same model's).
        self._accepted: JointChain | None = None

    def accepts(self, chain: JointChain) -> bool:
        """Whether ``chain`` is a chain of this model (its joints and columns are ours)."""
        if chain is self._accepted:
            return True
        own = self.chain
        same = (
            chain.joint_int.shape == own.joint_int.shape
            and np.array_equal(chain.joint_int, own.joint_int)
            and np.array_equal(chain.joint_frame, own.joint_frame)
            and np.array_equal(chain.column_kind, own.column_kind)
        )
        if same:
            self._accepted = chain
        return same

    @property
    def kinds(self) -> np.ndarray:
        """Kind of each shape (``CAPSULE``, ``BOX``, ``HALFSPACE``)."""
        return self.shape_int[:, 1]

    def refresh_sizes(self, geometry: pin.GeometryModel) -> None:
        """Read the shapes' sizes again (after a padding changed them); the screen's levers
        with them (every pair computed at the next update)."""
        self._read_sizes(geometry)
        self.screen.levers(self._extents())

    def _read_sizes(self, geometry: pin.GeometryModel) -> None:
        for g, obj in enumerate(geometry.geometryObjects):
            self.shape_int[g, 1], self.size[g] = _shape_row(obj.geometry)

    def _extents(self) -> np.ndarray:
        """Each shape's :func:`~controller.model.collision_screen.shape_extent` [m]."""
        return np.array(
            [
                shape_extent(int(kind), frame, size)
                for kind, frame, size in zip(
                    self.shape_int[:, 1], self.shape_frame, self.size, strict=True
                )
            ]
        )

    def update(self, q: np.ndarray, d: np.ndarray, witness: np.ndarray) -> None:
        """:func:`update` at ``q`` [rad, m] into ``d`` and ``witness``."""
        update(q, *self.model_arrays, d, witness, *self.screen.arrays)

    def update_on(
        self, q: np.ndarray, chain: JointChain, d: np.ndarray, witness: np.ndarray
    ) -> None:
        """:func:`update_placed` at ``q`` [rad, m] on ``chain``'s placements (a chain
        :meth:`accepts`, placed at ``q``)."""
        update_placed(
            q, chain.joint_world, chain.columns, *self.shape_arrays, d, witness,
            *self.screen.arrays,
        )  # fmt: skip

    def rows(
        self, index: np.ndarray, support: np.ndarray, witness: np.ndarray, out: np.ndarray
    ) -> None:
        """:func:`jacobian_rows` at the last :meth:`update`."""
        jacobian_rows(index, support, witness, self.columns, self.column_kind, out)
