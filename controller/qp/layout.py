"""The QP's structure for one configuration: its variables and its rows, in fixed buffers.

Variables: a frozen joint's velocity is fixed by the box (lb = ub: zero at rest, braking
while it still moves), so it is no variable. The QPs run over the free joints only, with the
frozen joints' share moved to the right-hand sides (``C v = C_f v_f + C_z v_z``).

Rows: each row constraint with rows this configuration gets a block of its ``max_rows`` rows
in one buffer over every joint. Blocks are ordered level 1 only, both levels, level 2 only,
so each level's rows are one contiguous slice. A constraint whose rows have coefficients on
frozen joints only (the differential drive's, with the base frozen) is checked instead of
solved: it holds, or the step fails as the infeasible QP would; at rest it needs no
evaluation when ``v = 0`` always satisfies it.

Laying out costs (~35 µs on SmartPal V, at every motion start): :class:`LayoutCache` keeps
the layouts of the last configurations and hands one back, its rows reset as new, when the
frozen mask and every constraint's ``max_rows`` and ``joints`` are the same again.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence

import numpy as np

from controller.qp.constraints.protocol import (
    INF,
    Constraint,
    CycleState,
    Level,
    Relaxation,
    RowBlock,
)
from controller.qp.solver import FEASIBILITY_TOL


class _Blocks:
    """Some constraints' rows stacked in one buffer over every joint, filled in place."""

    def __init__(self, constraints: list[Constraint], nv: int):
        self.constraints = constraints
        self.m = m = sum(c.max_rows for c in constraints)
        self.C = np.zeros((m, nv))
        self.lo = np.full(m, -INF)
        self.hi = np.full(m, INF)
        #: Per constraint: its rows, where they start, how many hold data now.
        self.blocks: list[tuple[Constraint, RowBlock, int]] = []
        a = 0
        for c in constraints:
            b = a + c.max_rows
            self.blocks.append((c, RowBlock(self.C[a:b], self.lo[a:b], self.hi[a:b]), a))
            a = b
        self._filled = [0] * len(constraints)

    def reset(self) -> None:
        """Every row free, as when made (zeros, infinite bounds, nothing reported)."""
        self.C.fill(0.0)
        self.lo.fill(-INF)
        self.hi.fill(INF)
        self._filled = [0] * len(self.constraints)

    def fill(self, cycle: CycleState, fixed: np.ndarray, v_fixed: np.ndarray | None) -> None:
        """Every constraint's rows; rows it did not report are left free; with the frozen
        joints moving (``v_fixed``), their share moved to the bounds."""
        filled = self._filled
        for i, (constraint, rows, _) in enumerate(self.blocks):
            k = constraint.compute_qp_inequalities(cycle, rows)
            if k < filled[i]:  # rows it no longer reports: 0·v in [-INF, INF]
                rows.C[k : filled[i]] = 0.0
                rows.lo[k : filled[i]] = -INF
                rows.hi[k : filled[i]] = INF
            filled[i] = k
        if v_fixed is not None:
            share = self.C[:, fixed].dot(v_fixed)
            self.lo -= share
            self.hi -= share


class Layout:
    """Variables (the free joints) and row buffers for one frozen mask and constraint set."""

    def __init__(self, frozen: np.ndarray, constraints: Sequence[Constraint], damping: float):
        nv = len(frozen)
        frozen = np.asarray(frozen, dtype=bool)
        free = np.flatnonzero(~frozen)
        self.n = n = len(free)
        #: Frozen joints, and the free ones: a slice when contiguous (views, not copies).
        self.fixed = np.flatnonzero(frozen)
        self.has_fixed = len(self.fixed) > 0
        contiguous = n > 0 and free[-1] - free[0] + 1 == n
        self.free: slice | np.ndarray = slice(free[0], free[-1] + 1) if contiguous else free
        #: The free joints as indices, always (for compiled code).
        self.free_index = free.astype(np.int64)
        #: λ, and λ·I over the free joints.
        self.damping_value = float(damping)
        self.damping = damping * np.eye(n)

        def only_frozen(c: Constraint) -> bool:
            return c.joints is not None and bool(frozen[c.joints].all())

        used = [c for c in constraints if c.max_rows]
        checked = [c for c in used if only_frozen(c)]
        solved = [c for c in used if not only_frozen(c)]
        first = [c for c in solved if c.levels == Level.FIRST]
        both = [c for c in solved if c.levels == Level.BOTH]
        second = [c for c in solved if c.levels == Level.SECOND]
        self.checked = _Blocks(checked, nv) if checked else None
        #: Checked rows need evaluating only while frozen joints move.
        self.checked_hold_at_rest = all(c.holds_at_rest for c in checked)
        self.solved = _Blocks(first + both + second, nv)
        self.m = self.solved.m
        self.m1 = sum(c.max_rows for c in first + both)
        start2 = sum(c.max_rows for c in first)
        self.m2 = self.m - start2
        # Over the free joints, row-major: each level's rows are one contiguous block.
        self._C_free = self.solved.C if n == nv else np.zeros((self.m, n))
        C, lo, hi = self._C_free, self.solved.lo, self.solved.hi
        #: The rows each level's QP gets (views of the buffers, made once).
        self.level1 = (C[: self.m1], lo[: self.m1], hi[: self.m1])
        self.level2 = (C[start2:], lo[start2:], hi[start2:])
        self._relax, self._relax_names = self._mask(first + both, Relaxation.HARD, invert=True)
        self._drop, self._drop_names = self._mask(first + both, Relaxation.NO_FURTHER_THEN_DROP)

    def reset(self) -> None:
        """The row buffers as a new layout has them (see :meth:`_Blocks.reset`): a layout
        used again holds nothing from its last use."""
        self.solved.reset()
        if self.checked is not None:
            self.checked.reset()
        if self._C_free is not self.solved.C:
            self._C_free.fill(0.0)

    @staticmethod
    def _mask(
        constraints: list[Constraint], policy: Relaxation, invert: bool = False
    ) -> tuple[np.ndarray, str]:
        """Rows of constraints with (``invert``: without) ``policy``, and their names."""
        picked = [(c.relaxation == policy) != invert for c in constraints]
        mask = np.repeat(picked, [c.max_rows for c in constraints]).astype(bool)
        names = dict.fromkeys(c.name for c, p in zip(constraints, picked, strict=True) if p)
        return mask, ", ".join(names)

    def check(self, cycle: CycleState, v_fixed: np.ndarray | None) -> bool:
        """Whether the checked rows hold with the frozen joints at ``v_fixed`` (None: rest)."""
        rows = self.checked
        if rows is None:
            return True
        rows.fill(cycle, self.fixed, v_fixed)
        tol = FEASIBILITY_TOL
        return not (np.count_nonzero(rows.lo > tol) or np.count_nonzero(rows.hi < -tol))

    def fill(self, cycle: CycleState, v_fixed: np.ndarray | None) -> None:
        """The solved rows of this cycle, over the free joints, into :attr:`level1` and
        :attr:`level2`."""
        rows = self.solved
        rows.fill(cycle, self.fixed, v_fixed)
        if self._C_free is not rows.C:
            free = self.free
            if isinstance(free, slice):
                self._C_free[...] = rows.C[:, free]
            else:
                np.take(rows.C, free, axis=1, out=self._C_free)

    def relax(self) -> str:
        """Widen the relaxable level-1 rows to "no further" (bands containing 0); what gave."""
        _, lo, hi = self.level1
        np.minimum(lo, 0.0, out=lo, where=self._relax)
        np.maximum(hi, 0.0, out=hi, where=self._relax)
        names = self._relax_names
        return f"{names} relaxed to 'no further' this cycle" if names else "retried cold"

    def drop(self) -> str:
        """Leave the droppable level-1 rows out (infinite bounds); what gave."""
        _, lo, hi = self.level1
        lo[self._drop] = -INF
        hi[self._drop] = INF
        names = self._drop_names
        return f"{names} not enforced this cycle (conflicting rows)" if names else "retried cold"


#: Layouts :class:`LayoutCache` keeps (a robot's motions use a handful of configurations).
LAYOUT_CACHE_SIZE = 16


def layout_key(frozen: np.ndarray, constraints: Sequence[Constraint]) -> Hashable:
    """What a layout is made from: the frozen mask and, per constraint (in registration
    order), its ``max_rows`` and ``joints``."""
    return (
        np.asarray(frozen, dtype=bool).tobytes(),
        tuple(
            (c.max_rows, None if c.joints is None else np.asarray(c.joints).tobytes())
            for c in constraints
        ),
    )


class LayoutCache:
    """The layouts of the last :data:`LAYOUT_CACHE_SIZE` configurations of one constraint
    list, by :func:`layout_key`: a motion start with a configuration seen before reuses its
    layout (reset, see :meth:`Layout.reset`) instead of laying the buffers out again.

    The constraints are told apart by their position: :meth:`clear` when the list changes.
    """

    def __init__(self, damping: float, size: int = LAYOUT_CACHE_SIZE):
        self.damping = damping
        self.size = size
        self._layouts: dict[Hashable, Layout] = {}
        #: Layouts handed back from the cache, and made anew (for tests and benchmarks).
        self.hits = 0
        self.misses = 0

    def __len__(self) -> int:
        return len(self._layouts)

    def get(self, frozen: np.ndarray, constraints: Sequence[Constraint]) -> Layout:
        """The layout of ``frozen`` and ``constraints`` (configured), rows reset."""
        key = layout_key(frozen, constraints)
        layout = self._layouts.pop(key, None)
        if layout is None:
            self.misses += 1
            layout = Layout(frozen, constraints, self.damping)
            if len(self._layouts) >= self.size:  # the least recently used goes
                del self._layouts[next(iter(self._layouts))]
        else:
            self.hits += 1
            layout.reset()
        self._layouts[key] = layout  # the most recently used last
        return layout

    def clear(self) -> None:
        self._layouts.clear()
