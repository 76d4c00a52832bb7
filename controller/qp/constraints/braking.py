"""The braking-distance formula every limit of the QP uses.

A bound ``d`` away [rad, m], approached at rate ``v`` with a deceleration ``a`` available
[rad/s², m/s²]: after this cycle (``dt`` [s]) the axis must still be able to stop before the
bound, ``v·dt + v²/(2·a) ≤ d``, i.e.::

    v ≤ √((a·dt)² + 2·a·d) − a·dt

By induction a bound is never crossed: decelerating at ``a`` always stays feasible. At or
beyond the bound (``d ≤ 0``: noise, a changed profile) the rate is 0: never further out,
moving back is allowed. :class:`~controller.qp.constraints.joint_box.JointBox` evaluates the
same expression for every joint at once from arrays prepared when its limits are set;
:func:`braking_speed` is the scalar form (axis ranges).
"""

from __future__ import annotations

import math

from controller.model import jit
from controller.qp.constraints.protocol import INF

#: Braking distances are planned at this share of the acceleration limit. A joint that brakes
#: alone could use all of it, but a null-space motion braking at one joint's limit must
#: brake in every joint at once without the control point drifting: the rest of a_max is the
#: headroom the other joints need for that.
BRAKING_SHARE = 0.5


def braking_speed(distance: float, accel: float, dt: float) -> float:
    """Largest rate [unit/s] toward a bound ``distance`` [unit] away that can still stop at
    ``accel`` [unit/s²] (0 at or beyond the bound; unbounded when ``accel`` is 0)."""
    if distance <= 0.0:
        return 0.0
    if accel <= 0.0:
        return INF
    a_dt = accel * dt
    return math.sqrt(a_dt * a_dt + 2.0 * accel * distance) - a_dt


#: :func:`braking_speed` for compiled code (the compiled axis rows, :mod:`.axes_kernel`, call
#: it); Python callers use the plain function.
compiled_braking_speed = jit.jit(braking_speed)
