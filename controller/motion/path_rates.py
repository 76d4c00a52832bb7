"""How fast a checked joint path may be run: limits on its path parameter's rate and
acceleration from the joints' speed and braking limits along the path (the reachability
check's samples, :class:`~controller.motion.reachability.ReachabilityChecker`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from controller.qp.constraints import BRAKING_SHARE


def parameter_limits(
    path_s: Sequence[float],
    path_q: Sequence[np.ndarray],
    v_max: np.ndarray,
    a_max: np.ndarray,
    share: float = 0.8,
) -> tuple[float, float]:
    """Limits on the path parameter's rate [1/s] and acceleration [1/s²] that keep every
    joint within ``share`` of its speed limit ``v_max`` and of its braking deceleration
    (BRAKING_SHARE × its acceleration limit ``a_max``) along the joint path ``path_q`` (at
    parameters ``path_s``), from the joint motion per unit of path (dq/ds) between samples.
    ``(inf, inf)`` for a still path."""
    if len(path_q) < 2:
        return math.inf, math.inf
    q = np.array(path_q)
    ds = np.diff(np.array(path_s))
    ok = ds > 1e-12
    if not ok.any():
        return math.inf, math.inf
    slope = np.max(np.abs(np.diff(q, axis=0)[ok] / ds[ok, None]), axis=0)  # per joint
    moving = slope > 1e-12
    if not moving.any():
        return math.inf, math.inf
    v = share * float(np.min(v_max[moving] / slope[moving]))
    a = share * BRAKING_SHARE * float(np.min(a_max[moving] / slope[moving]))
    return v, a


def braking_speed_limit(
    path_s: Sequence[float],
    path_q: Sequence[np.ndarray],
    limits: tuple[np.ndarray, np.ndarray, np.ndarray],
    watched: np.ndarray,
    margin: float,
    law: tuple[float, float, float],
) -> tuple[float, tuple[int, float, float] | None]:
    """Path rate [1/s] ≤ ``v`` at which no ``watched`` joint (a mask) on the joint path
    outruns the IK's braking bound toward its limit, and the worst joint ``(index, s,
    distance)`` (None when nothing binds). ``limits``: ``(q_min, q_max, a_max)`` per joint;
    ``law``: ``(v, a, share)``, the path rate [1/s], its acceleration [1/s²] and the share
    of the braking deceleration to plan with.

    A joint at distance ``d`` from the limit it moves toward, at ``dq/ds`` per unit of
    path, can go at most ``√(2·share·a_b·d)`` (a_b = BRAKING_SHARE × its acceleration
    limit): the live IK brakes it there whatever the path asks, the hand then leaves the
    line and the arm may fold into another configuration. Likewise a joint whose path
    bends (``d²q/ds²``) needs ``|d²q/ds²|·ṡ²`` of acceleration to follow it: at most
    ``share·a_b``. The time law's own ramps bound ṡ by ``√(2·a·min(s, 1 − s))`` near the
    ends, so only samples where that is higher constrain ``v``. Joints within ``margin``
    [rad or m] of the limit do not count there."""
    v, a, share = law
    if len(path_q) < 3:
        return v, None
    q = np.array(path_q)
    s = np.array(path_s)
    if np.any(np.diff(s) <= 0.0):
        return v, None
    q_min, q_max, a_max = limits
    slope = np.gradient(q, s, axis=0)
    dist = np.where(slope > 0.0, q_max - q, q - q_min)
    brake = share * BRAKING_SHARE * a_max
    speed = np.abs(slope)
    bend = np.abs(np.gradient(slope, s, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        cap = np.where(speed > 1e-9, np.sqrt(2.0 * brake * np.maximum(dist, 0.0)) / speed, np.inf)
        cap = np.minimum(cap, np.where(bend > 1e-9, np.sqrt(brake / bend), np.inf))
    ramp = np.sqrt(2.0 * a * np.minimum(s, 1.0 - s))[:, None]
    arm = watched[None, :] & (dist > margin)
    cap = np.where(arm & (cap < np.minimum(ramp, v)), cap, np.inf)
    k, j = np.unravel_index(int(np.argmin(cap)), cap.shape)
    if not math.isfinite(float(cap[k, j])):
        return v, None
    return float(cap[k, j]), (int(j), float(s[k]), float(dist[k, j]))
