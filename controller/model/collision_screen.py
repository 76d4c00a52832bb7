"""Which collision pairs a control cycle must compute: a bound on how far each pair can
have come since it was last computed.

Most checked pairs are far apart (on SmartPal V, 196 shape pairs, most of them tens of
centimetres beyond the influence distance of the collision rows). Their distances matter
only once they may be within it. :class:`PairScreen` keeps, per pair, a bound ``B`` on how
much its distance can have changed since it was last computed, and the cycle computes a
pair only when ``d_last − B`` might be within the distance the rows look at.

**The bound.** A joint ``j`` moved by ``Δq_j`` displaces a point of a link it moves by at
most ``|Δq_j|`` (prismatic) or ``ρ·|Δq_j|`` (revolute, ``ρ`` the point's distance from the
axis: the chord ``2ρ·sin(Δq/2)`` is shorter). ``ρ`` is bounded for every configuration by the
path from the joint's origin to the shape (:func:`pair_levers`): the joint placements'
translations along the way, each prismatic joint's largest travel, and the shape's own
extent from its joint (a capsule's farthest end plus its radius, a box's centre plus its
half diagonal). The distance between two shapes depends only on the joints between them in
the tree (moving a common ancestor moves both alike), so pair ``k`` gets the levers of the
joints that move one shape and not the other, and per cycle

    step_k = Σ_j lever_kj·|q_j − q_j,last|,      B_k += step_k

(a bound on the distance's change along the path the joints took, however they moved
together). Separated shapes displaced by at most ``B`` in total are at least ``d − B``
apart. A pair is left out of a cycle (*screened*) only when

    d_last − B_k − step_k·horizon ≥ within      and      B_k ≤ max_stale

with ``within`` the influence distance of the rows and ``horizon`` their look-ahead in cycles:
then its distance is beyond ``within`` and closing at most ``step_k`` per cycle, so the rows
would not take it either (their key ``d − closing·horizon`` is at least ``within``). Every
other pair is computed exactly (``B`` := 0). A lever that is unbounded (a prismatic joint
without limits on the path, a half-space) keeps the pair computed every cycle.

A screened pair's published distance is the upper bound ``d_last + B`` (at most
``2·max_stale`` above the truth, beyond ``within`` either way): a reader that takes the
change of the distance from one cycle to the next as its approach speed (the rows' look-ahead)
then never underestimates it when the pair is computed again; the screen also gives that
pair's step as a bound on its closing in that update (:attr:`PairScreen.cap`), so the rows do
not take the jump from the upper bound for a fast approach either (with a 250-cycle look-ahead,
a 2 cm overstatement would rank the pair before every pair truly close).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pinocchio as pin

from controller.model.jit import jit

#: Largest bound [m] on a screened pair's change before it is computed again: the
#: published distances of screened pairs are within twice this of the truth.
MAX_STALE = 0.02
#: Prismatic travel [m] beyond which a joint counts as unbounded.
UNBOUNDED = 1e6


def shape_extent(kind: int, frame: np.ndarray, size: np.ndarray) -> float:
    """Largest distance [m] of a shape's points from its joint's origin: ``frame`` its
    placement on the joint (rotation rows, translation), ``size`` as
    :mod:`controller.model.collision_kernel` holds it; ``kind`` 0 capsule or sphere, 1 box,
    anything else (a half-space) unbounded."""
    centre = frame[3]
    if kind == 0:
        axis = frame[:3, 2] * size[1]
        ends = max(np.linalg.norm(centre - axis), np.linalg.norm(centre + axis))
        return float(ends + size[0])
    if kind == 1:
        return float(np.linalg.norm(centre) + np.linalg.norm(size[:3]))
    return math.inf


def pair_levers(
    model: pin.Model,
    shape_joint: np.ndarray,
    extent: np.ndarray,
    pairs: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per pair of shapes (``pairs[k]`` = shape 1, shape 2), the velocity indices of the
    joints that move one shape and not the other and their levers [m/rad or 1] (see the
    module): ``(start, column, lever, exact)`` with pair ``k``'s entries at
    ``start[k]:start[k + 1]`` and ``exact[k]`` True when a lever is unbounded.
    ``shape_joint``: each shape's joint (0: the world), ``extent``: :func:`shape_extent`."""
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    travel = np.zeros(model.njoints)  # a prismatic joint's largest displacement [m]
    prismatic = np.zeros(model.njoints, dtype=bool)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.shortname().startswith("JointModelP"):
            prismatic[j] = True
            i = joint.idx_q
            reach = max(abs(lower[i]), abs(upper[i]))
            travel[j] = math.inf if not reach < UNBOUNDED else reach
    offset = np.array([np.linalg.norm(p.translation) for p in model.jointPlacements])

    def lever(j: int, shape: int) -> float:
        """Bound on the distance of the shape's points from joint ``j``'s axis (1 when
        ``j`` slides them)."""
        if prismatic[j]:
            return 1.0
        path = 0.0
        i = int(shape_joint[shape])
        while i != j:  # from the shape's joint up to j
            path += offset[i] + travel[i]
            i = model.parents[i]
        return path + float(extent[shape])

    start, columns, levers, exact = [0], [], [], []
    for g1, g2 in pairs.tolist():
        s1 = {j for j in model.supports[int(shape_joint[g1])] if j}
        s2 = {j for j in model.supports[int(shape_joint[g2])] if j}
        entries = [(j, g1) for j in sorted(s1 - s2)] + [(j, g2) for j in sorted(s2 - s1)]
        values = [lever(j, g) for j, g in entries]
        exact.append(not all(math.isfinite(v) for v in values))
        columns += [model.joints[j].idx_v for j, _ in entries]
        levers += values
        start.append(len(columns))
    return (
        np.array(start, dtype=np.int64),
        np.array(columns, dtype=np.int64),
        np.array(levers, dtype=float),
        np.array(exact, dtype=np.bool_),
    )


class PairScreen:
    """The screening state of one set of pairs (see the module). Off until :meth:`set`:
    every pair computed at every update. Not thread-safe.

    Packed in three arrays for the kernels (each array a compiled call takes costs ~0.1 µs
    to pass): :attr:`state` (floats: the joints of the last update, per pair the bound and
    the last exact distance, the settings, the levers), :attr:`index` (the pairs' entries:
    start, then the joints' velocity indices) and :attr:`flags` (per pair: always computed,
    computed by this update); :func:`unpack` gives the views back."""

    def __init__(
        self,
        model: pin.Model,
        shape_joint: np.ndarray,
        extent: np.ndarray,
        pairs: np.ndarray,
        always: np.ndarray | None = None,
    ):
        """``shape_joint``: each shape's joint (0: the world); ``extent``:
        :func:`shape_extent` per shape [m]; ``pairs``: (shape 1, shape 2) per pair;
        ``always``: pairs computed at every update all the same (a mask)."""
        self._model = model
        self._shape_joint = shape_joint
        self._pairs = pairs
        n, nv = len(pairs), model.nv
        self._always = np.zeros(n, dtype=np.bool_) if always is None else always.copy()
        start, column, lever, _ = pair_levers(model, shape_joint, extent, pairs)
        self.state = np.zeros(nv + 3 * n + 3 + len(lever))
        self.index = np.concatenate([start, column]).astype(np.int64)
        self.flags = np.zeros(2 * n, dtype=np.bool_)
        #: The kernels' arguments after ``q`` and ``d``.
        self.arrays = (self.state, self.index, self.flags)
        (
            self.q_last, self.bound, self.exact_distance, self.cap, self.settings, self.lever,
            self.start, self.column, self.exact, self.computed,
        ) = unpack(nv, n, *self.arrays)  # fmt: skip
        #: Per pair: a bound on its closing [m] in this update where the change of its
        #: published distance overstates it (back from the screen), else inf.
        self.cap[...] = math.inf
        #: ``within`` [m], ``horizon`` [cycles], ``max_stale`` [m] (``within`` = inf: off).
        self.settings[:] = math.inf, 0.0, MAX_STALE
        self.computed[...] = True
        self.levers(extent)

    def levers(self, extent: np.ndarray) -> None:
        """The levers for the shapes' ``extent`` [m] (again after a padding changed them);
        every pair is computed at the next update."""
        start, column, lever, unbounded = pair_levers(
            self._model, self._shape_joint, extent, self._pairs
        )
        assert np.array_equal(start, self.start) and np.array_equal(column, self.column)
        self.lever[...] = lever
        #: Per pair: computed at every update (an unbounded lever, or ``always``).
        self.exact[...] = unbounded | self._always
        self.bound[...] = math.inf

    def set(self, within: float, horizon: float, max_stale: float = MAX_STALE) -> None:
        """Screen pairs beyond ``within`` [m] with a look-ahead of ``horizon`` cycles; a
        screened pair's bound stays under ``max_stale`` [m]."""
        if not (math.isfinite(within) and horizon >= 0.0 and max_stale >= 0.0):
            raise ValueError(
                f"screening needs a finite distance and non-negative horizon and staleness, "
                f"got {within!r}, {horizon!r}, {max_stale!r}"
            )
        self.settings[:] = within, horizon, max_stale

    def off(self) -> None:
        """Compute every pair at every update."""
        self.settings[0] = math.inf

    @property
    def enabled(self) -> bool:
        return bool(math.isfinite(self.settings[0]))


@jit
def unpack(nv: int, n: int, state: np.ndarray, index: np.ndarray, flags: np.ndarray) -> Any:
    """Views of a :class:`PairScreen`'s packed arrays for ``nv`` joints and ``n`` pairs:
    ``q_last``, ``bound``, ``exact_distance``, ``cap``, ``settings``, ``lever``, ``start``,
    ``column``, ``exact``, ``computed``."""
    return (
        state[:nv], state[nv : nv + n], state[nv + n : nv + 2 * n],
        state[nv + 2 * n : nv + 3 * n], state[nv + 3 * n : nv + 3 * n + 3],
        state[nv + 3 * n + 3 :], index[: n + 1], index[n + 1 :], flags[:n], flags[n:],
    )  # fmt: skip


@jit
def screen(
    q: np.ndarray, d: np.ndarray, state: np.ndarray, index: np.ndarray, flags: np.ndarray
) -> None:
    """Decide which pairs this update computes (``computed``) from the joints' motion since
    the last one (``q`` [rad, m]; the last one's := ``q``); the bounds of the others grow by
    their step (see the module). ``d`` [m]: one value per pair (not read)."""
    q_last, bound, exact_distance, cap, settings, lever, start, column, exact, computed = unpack(
        q.shape[0], d.shape[0], state, index, flags
    )
    within, horizon, max_stale = settings[0], settings[1], settings[2]
    for k in range(bound.shape[0]):
        cap[k] = math.inf
        if exact[k]:
            bound[k] = 0.0
            computed[k] = True
            continue
        step = 0.0
        for e in range(start[k], start[k + 1]):
            j = column[e]
            step += lever[e] * abs(q[j] - q_last[j])
        b = bound[k] + step
        if b <= max_stale and exact_distance[k] - b - step * horizon >= within:
            bound[k] = b
            computed[k] = False
        else:
            if not computed[k]:  # back from the screen: it closed by at most its step
                cap[k] = step
            bound[k] = 0.0
            computed[k] = True
    for j in range(q.shape[0]):
        q_last[j] = q[j]


@jit
def publish(
    q: np.ndarray, d: np.ndarray, state: np.ndarray, index: np.ndarray, flags: np.ndarray
) -> None:
    """After the computed pairs' distances were written into ``d`` [m]: keep them as the
    last exact ones; a screened pair's ``d`` := its last exact distance plus its bound."""
    _, bound, exact_distance, _, _, _, _, _, _, computed = unpack(
        q.shape[0], d.shape[0], state, index, flags
    )
    for k in range(d.shape[0]):
        if computed[k]:
            exact_distance[k] = d[k]
        else:
            d[k] = exact_distance[k] + bound[k]
