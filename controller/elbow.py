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

from dataclasses import dataclass

import numpy as np

#: Distance [m] of the elbow from the shoulder-wrist line below which the gradient is clamped.
MIN_OFFSET = 1e-6
#: ``1 + f·u`` below which ``u`` counts as the singular direction ``-forward``.
POLE_EPS = 1e-12


def skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass(frozen=True)
class Swivel:
    """Elbow angle [rad] with its gradient w.r.t. the three points [rad/m]."""

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


def swivel(
    s: np.ndarray, e: np.ndarray, w: np.ndarray, forward: np.ndarray, down: np.ndarray
) -> Swivel:
    """Elbow angle of points ``s``, ``e``, ``w`` and its gradients (all in one frame).

    ``forward`` and ``down`` must be unit and perpendicular (the profile loader ensures it).
    """
    d = w - s
    length = float(np.linalg.norm(d))
    u = d / length
    a = e - s
    one_c = 1.0 + float(forward @ u)
    pole = one_c < POLE_EPS
    v = reference_vector(u, forward, down)
    b = np.cross(u, v)
    x = float(v @ a)
    y = float(b @ a)
    angle = float(np.arctan2(y, x))
    r2 = x * x + y * y
    denom = max(r2, MIN_OFFSET * MIN_OFFSET)

    grad_a = (x * b - y * v) / denom
    if pole:
        dv_du = np.zeros((3, 3))
    else:
        dg_du = down / one_c - float(u @ down) * forward / (one_c * one_c)
        g = float(u @ down) / one_c
        dv_du = -np.outer(forward + u, dg_du) - g * np.eye(3)
    db_du = -skew(v) + skew(u) @ dv_du
    dphi_du = (x * (a @ db_du) - y * (a @ dv_du)) / denom
    du_dd = (np.eye(3) - np.outer(u, u)) / length
    grad_d = dphi_du @ du_dd
    return Swivel(angle, -grad_a - grad_d, grad_a, grad_d, float(np.sqrt(r2)))
