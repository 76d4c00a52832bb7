"""Unit and pose conversions at the API edge: HgMatrix [mm] <-> SE3 [m], deg <-> rad.

Everything inside imotion is SI; the service converts with these functions and nowhere else.
Invalid input raises :class:`ArgumentError`, whose message names the argument and the problem
(the service returns it as the comment of a VALUE_ERR).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from controller.errors import ArgumentError

#: Tolerance on ``RᵀR = I`` (max abs entry) and ``det R = 1`` for an HgMatrix rotation block.
ORTHONORMAL_TOL = 1e-6

MM_PER_M = 1000.0


def finite_array(value: object, name: str, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """``value`` as a float array; rejects non-numbers, NaN/inf and (if given) a wrong shape."""
    try:
        raw = np.asarray(value)
    except ValueError:  # ragged nesting
        raw = np.asarray(None)
    if raw.dtype.kind not in "iuf":  # strings, booleans, None, ragged lists
        raise ArgumentError(f"{name}: expected numbers, got {value!r}")
    arr = raw.astype(float)
    if shape is not None and arr.shape != shape:
        raise ArgumentError(f"{name}: expected shape {shape}, got {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr.ravel()))
    if bad.size:
        raise ArgumentError(
            f"{name}: element {int(bad[0])} is {arr.ravel()[bad[0]]} (must be finite)"
        )
    return arr


def hg_to_se3(hg: object, name: str = "HgMatrix") -> pin.SE3:
    """An HgMatrix ``[[R | p]]`` (3 x 4, row-major, ``p`` in [mm]) as an SE3 in [m].

    The rotation block must be orthonormal with determinant +1 within
    :data:`ORTHONORMAL_TOL`; it is then projected onto the nearest rotation so that rounding
    in the caller's numbers does not accumulate.
    """
    m = finite_array(hg, name, (3, 4))
    rot = m[:, :3]
    err = float(np.abs(rot.T @ rot - np.eye(3)).max())
    if err > ORTHONORMAL_TOL:
        raise ArgumentError(f"{name}: rotation block is not orthonormal (|RᵀR - I| = {err:.3g})")
    det = float(np.linalg.det(rot))
    if abs(det - 1.0) > ORTHONORMAL_TOL:
        raise ArgumentError(f"{name}: rotation block has determinant {det:.6g}, must be +1")
    u, _, vt = np.linalg.svd(rot)
    return pin.SE3(u @ vt, m[:, 3] / MM_PER_M)


def se3_to_hg(pose: pin.SE3) -> np.ndarray:
    """An SE3 in [m] as an HgMatrix (3 x 4 array, ``p`` in [mm])."""
    out = np.empty((3, 4))
    out[:, :3] = pose.rotation
    out[:, 3] = pose.translation * MM_PER_M
    return out


def deg_to_rad(values: float | Sequence[float] | np.ndarray, name: str = "value") -> np.ndarray:
    """Degrees to radians, rejecting NaN/inf."""
    return np.radians(finite_array(values, name))


def rad_to_deg(values: float | Sequence[float] | np.ndarray) -> np.ndarray:
    return np.degrees(np.asarray(values, dtype=float))


def mm_to_m(values: float | Sequence[float] | np.ndarray, name: str = "value") -> np.ndarray:
    """Millimetres to metres, rejecting NaN/inf."""
    return finite_array(values, name) / MM_PER_M


def m_to_mm(values: float | Sequence[float] | np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=float) * MM_PER_M


def offset_to_se3(xyz: Sequence[float], rpy_deg: Sequence[float]) -> pin.SE3:
    """A profile offset (translation [m], roll-pitch-yaw [deg]) as an SE3."""
    r, p, y = (math.radians(a) for a in rpy_deg)
    return pin.SE3(pin.rpy.rpyToMatrix(r, p, y), np.asarray(xyz, dtype=float))
