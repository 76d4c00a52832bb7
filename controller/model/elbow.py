"""Elbow (swivel) angle of a 7-axis arm and its gradient.

Definition
----------
Let ``s``, ``e``, ``w`` be the shoulder, elbow and wrist points and ``u = (w - s)/|w - s|`` the
shoulder→wrist direction. The elbow angle is the angle, right-handed about ``u``, from a
*reference vector* ``v(u)`` to the elbow's offset from the shoulder→wrist line::

    φ = atan2((u × v)·(e - s), v·(e - s))

The reference vector lives in the arm base frame (the link that carries the arm's first
joint), so the angle depends on the arm joints only, not on the waist or the vehicle. It is
the profile's ``down`` direction ``t`` carried from the profile's ``forward`` direction ``f``
to ``u`` by the shortest rotation (parallel transport along the great circle)::

    v(u) = t - (u·t) / (1 + f·u) · (f + u)

So: with the wrist straight along ``forward`` from the shoulder, φ = 0 when the elbow points
``down``; for any other wrist direction, the reference plane is the one that ``forward``/
``down`` plane becomes when tipped over to contain ``u``. (SmartPal V: forward = +x, down = -z;
arm hanging down → φ = 0 with the elbow pointing backward; arm held sideways → φ = 0 with the
elbow below the shoulder-wrist line.)

Degenerate cases
----------------
* A fixed reference axis (the usual "vertical plane" definition) fails continuously whenever
  ``u`` is parallel to it, which for a vertical axis is the arm hanging straight down, a common
  posture. No tangent field on the sphere is continuous everywhere, so some direction must be
  singular; this definition puts the single singular direction at ``u = -forward`` (wrist
  straight behind the shoulder for the humanoids, straight below the mount for PA10), outside
  the reachable workspace. Everywhere else ``v`` is smooth. At the pole itself the reference
  falls back to ``-down``.
* With the elbow on the shoulder-wrist line (arm fully stretched) the angle is undefined:
  ``atan2(0, 0) = 0`` is returned and the gradient is bounded by clamping the elbow's distance
  from the line at :data:`MIN_OFFSET` [m]. :func:`swivel` reports that distance so callers can
  down-weight the elbow task near full stretch.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from controller.model.jit import jit
from controller.model.joint_chain import REVOLUTE, compose

#: Distance [m] of the elbow from the shoulder-wrist line below which the gradient is clamped.
MIN_OFFSET = 1e-6
#: ``1 + f·u`` below which ``u`` counts as the singular direction ``-forward``.
POLE_EPS = 1e-12


class Swivel(NamedTuple):
    """Elbow angle [rad] with its gradient w.r.t. the three points [rad/m] (a named tuple:
    built every cycle per arm, several times cheaper than a frozen dataclass)."""

    angle: float
    grad_shoulder: np.ndarray
    grad_elbow: np.ndarray
    grad_wrist: np.ndarray
    #: Distance of the elbow from the shoulder-wrist line [m].
    offset: float


def reference_vector(u: np.ndarray, forward: np.ndarray, down: np.ndarray) -> np.ndarray:
    """Reference vector for shoulder→wrist direction ``u`` (unit); unit and orthogonal to ``u``."""
    one_c = 1.0 + float(forward @ u)
    if one_c < POLE_EPS:
        return -down
    return down - (float(u @ down) / one_c) * (forward + u)


Vec = tuple[float, ...]


def _dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def swivel(
    s: np.ndarray, e: np.ndarray, w: np.ndarray, forward: np.ndarray, down: np.ndarray
) -> Swivel:
    """Elbow angle of points ``s``, ``e``, ``w`` and its gradients (all in one frame).

    ``forward`` and ``down`` must be unit and perpendicular (the profile loader ensures it).
    Runs on Python floats: this is on the control loop's hot path and 3-vectors are too small
    for numpy to pay off.

    Gradient: with x = v·a, y = (u×v)·a, a = e − s, φ = atan2(y, x):
    ∂φ/∂a = (x·b − y·v)/r², and through u = (w − s)/|w − s| via v(u) and b = u × v(u):
    aᵀ∂v/∂u = −(a·(f+u))·∂g/∂u − g·a and aᵀ∂b/∂u = v×a + (a×u)ᵀ∂v/∂u, where
    g = (u·t)/(1 + f·u) and ∂g/∂u = t/(1 + f·u) − (u·t)·f/(1 + f·u)².
    """
    sx, sy, sz = s.tolist()
    ex, ey, ez = e.tolist()
    wx, wy, wz = w.tolist()
    f = tuple(forward.tolist())
    t = tuple(down.tolist())
    dx, dy, dz = wx - sx, wy - sy, wz - sz
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    u = (dx / length, dy / length, dz / length)
    a = (ex - sx, ey - sy, ez - sz)
    one_c = 1.0 + _dot(f, u)
    pole = one_c < POLE_EPS
    ut = _dot(u, t)
    if pole:
        v = (-t[0], -t[1], -t[2])
        g = 0.0
    else:
        g = ut / one_c
        v = (t[0] - g * (f[0] + u[0]), t[1] - g * (f[1] + u[1]), t[2] - g * (f[2] + u[2]))
    b = _cross(u, v)
    x = _dot(v, a)
    y = _dot(b, a)
    angle = math.atan2(y, x)
    r2 = x * x + y * y
    den = max(r2, MIN_OFFSET * MIN_OFFSET)
    grad_a = ((x * b[0] - y * v[0]) / den, (x * b[1] - y * v[1]) / den, (x * b[2] - y * v[2]) / den)

    va = _cross(v, a)
    if pole:
        a_dv: Vec = (0.0, 0.0, 0.0)
        au_dv: Vec = (0.0, 0.0, 0.0)
    else:
        k1, k2 = 1.0 / one_c, ut / (one_c * one_c)
        dg = (t[0] * k1 - f[0] * k2, t[1] * k1 - f[1] * k2, t[2] * k1 - f[2] * k2)
        fu = (f[0] + u[0], f[1] + u[1], f[2] + u[2])
        au = _cross(a, u)
        c_a, c_au = _dot(a, fu), _dot(au, fu)
        a_dv = tuple(-c_a * dg[i] - g * a[i] for i in range(3))
        au_dv = tuple(-c_au * dg[i] - g * au[i] for i in range(3))
    a_db = (va[0] + au_dv[0], va[1] + au_dv[1], va[2] + au_dv[2])
    dphi_du = tuple((x * a_db[i] - y * a_dv[i]) / den for i in range(3))
    along = _dot(dphi_du, u)
    grad_d = tuple((dphi_du[i] - along * u[i]) / length for i in range(3))
    grad_e = np.array(grad_a)
    grad_w = np.array(grad_d)
    return Swivel(angle, -grad_e - grad_w, grad_e, grad_w, math.sqrt(r2))


@jit
def elbow_kernel(
    points: np.ndarray,
    base: np.ndarray,
    directions: np.ndarray,
    joint_columns: np.ndarray,
    column_kind: np.ndarray,
    columns: np.ndarray,
    masks: np.ndarray,
    row: np.ndarray,
    values: np.ndarray,
) -> None:
    """:func:`swivel` and the angle's Jacobian row in one compiled call.

    ``points``: shoulder, elbow, wrist (3 x 3, world [m]); ``directions``: forward, down (unit,
    in the arm base frame, whose world rotation is ``base``); ``joint_columns`` and
    ``column_kind``: every velocity column's world axis and a point of it [m], and its kind
    (:func:`~controller.model.joint_chain.forward`'s ``columns``); ``columns``: the arm's
    velocity columns, ``masks`` (3 x len(columns)): 1 where a column moves the shoulder,
    elbow, wrist point. Writes ``row[columns]`` [rad per unit of q] (a revolute column turns
    a point ``p`` at ``a × (p − o)``, a prismatic one moves it at ``a``, so ``g·ṗ`` is
    ``g·(a × (p − o))`` or ``g·a``) and ``values`` = (angle [rad], offset [m]). Same
    arithmetic as :func:`swivel` (tests compare them)."""
    sx, sy, sz = points[0, 0], points[0, 1], points[0, 2]
    fx, fy, fz = base @ directions[0]
    tx, ty, tz = base @ directions[1]
    dx, dy, dz = points[2, 0] - sx, points[2, 1] - sy, points[2, 2] - sz
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    ux, uy, uz = dx / length, dy / length, dz / length
    ax, ay, az = points[1, 0] - sx, points[1, 1] - sy, points[1, 2] - sz
    one_c = 1.0 + fx * ux + fy * uy + fz * uz
    pole = one_c < POLE_EPS
    ut = ux * tx + uy * ty + uz * tz
    if pole:
        vx, vy, vz, g = -tx, -ty, -tz, 0.0
    else:
        g = ut / one_c
        vx, vy, vz = tx - g * (fx + ux), ty - g * (fy + uy), tz - g * (fz + uz)
    bx, by, bz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx  # u × v
    x = vx * ax + vy * ay + vz * az
    y = bx * ax + by * ay + bz * az
    r2 = x * x + y * y
    den = max(r2, MIN_OFFSET * MIN_OFFSET)
    gex, gey, gez = (x * bx - y * vx) / den, (x * by - y * vy) / den, (x * bz - y * vz) / den
    vax, vay, vaz = vy * az - vz * ay, vz * ax - vx * az, vx * ay - vy * ax  # v × a
    if pole:
        adx = ady = adz = 0.0
        aux = auy = auz = 0.0
    else:
        k1, k2 = 1.0 / one_c, ut / (one_c * one_c)
        dgx, dgy, dgz = tx * k1 - fx * k2, ty * k1 - fy * k2, tz * k1 - fz * k2
        pux, puy, puz = fx + ux, fy + uy, fz + uz
        cux, cuy, cuz = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux  # a × u
        c_a = ax * pux + ay * puy + az * puz
        c_au = cux * pux + cuy * puy + cuz * puz
        adx, ady, adz = -c_a * dgx - g * ax, -c_a * dgy - g * ay, -c_a * dgz - g * az
        aux, auy, auz = -c_au * dgx - g * cux, -c_au * dgy - g * cuy, -c_au * dgz - g * cuz
    dbx, dby, dbz = vax + aux, vay + auy, vaz + auz
    px, py, pz = (x * dbx - y * adx) / den, (x * dby - y * ady) / den, (x * dbz - y * adz) / den
    along = px * ux + py * uy + pz * uz
    gwx, gwy, gwz = (
        (px - along * ux) / length,
        (py - along * uy) / length,
        (pz - along * uz) / length,
    )
    values[0] = math.atan2(y, x)
    values[1] = math.sqrt(r2)
    grads = ((-gex - gwx, -gey - gwy, -gez - gwz), (gex, gey, gez), (gwx, gwy, gwz))
    for c in range(columns.shape[0]):
        col = columns[c]
        ax, ay, az = joint_columns[col, 0, 0], joint_columns[col, 0, 1], joint_columns[col, 0, 2]
        revolute = column_kind[col] == REVOLUTE
        total = 0.0
        for i in range(3):
            if masks[i, c] == 0.0:
                continue
            gx, gy, gz = grads[i]
            if revolute:  # g · (a × (p − o))
                dx = points[i, 0] - joint_columns[col, 1, 0]
                dy = points[i, 1] - joint_columns[col, 1, 1]
                dz = points[i, 2] - joint_columns[col, 1, 2]
                total += gx * (ay * dz - az * dy) + gy * (az * dx - ax * dz)
                total += gz * (ax * dy - ay * dx)
            else:  # g · a
                total += gx * ax + gy * ay + gz * az
        row[col] = total


@jit
def elbows_at(
    rows: np.ndarray,
    values: np.ndarray,
    joint_world: np.ndarray,
    frame_joint: np.ndarray,
    frame_local: np.ndarray,
    directions: np.ndarray,
    joint_columns: np.ndarray,
    column_kind: np.ndarray,
    arm_columns: np.ndarray,
    counts: np.ndarray,
    masks: np.ndarray,
) -> None:
    """Every arm's elbow from the joints' world placements ``joint_world`` and velocity
    columns ``joint_columns``, ``column_kind`` (after
    :func:`~controller.model.joint_chain.forward`): per arm ``i`` its base rotation and
    shoulder, elbow and wrist points from ``frame_joint[i]`` (the joints carrying the arm
    base, shoulder, elbow and wrist frames) and ``frame_local[i]`` (those frames' placements
    on their joints, 4 x 4 x 3), and :func:`elbow_kernel` into ``rows[i]`` and
    ``values[i]``. ``arm_columns[i, :counts[i]]`` and ``masks[i, :, :counts[i]]`` are that
    call's ``columns`` and ``masks``, ``directions[i]`` its forward and down directions."""
    placement = np.empty((4, 3))
    base = np.empty((3, 3))
    points = np.empty((3, 3))
    for i in range(frame_joint.shape[0]):
        compose(joint_world[frame_joint[i, 0]], frame_local[i, 0], placement)
        base[:, :] = placement[:3]
        for k in range(3):
            compose(joint_world[frame_joint[i, k + 1]], frame_local[i, k + 1], placement)
            points[k, :] = placement[3]
        n = counts[i]
        cols, arm_masks = arm_columns[i, :n], masks[i, :, :n]
        elbow_kernel(
            points, base, directions[i], joint_columns, column_kind, cols, arm_masks, rows[i],
            values[i],
        )  # fmt: skip
