"""controller/qp/layout.py: the layout cache hands back a configuration's layout as new."""

from __future__ import annotations

import numpy as np

from controller.qp.constraints import ConstraintSetup, CycleState, Level, Relaxation, RowBlock
from controller.qp.constraints.protocol import INF
from controller.qp.layout import Layout, LayoutCache


class Rows:
    """``max_rows`` rows of ones on the joints it is given (or all)."""

    name = "rows"
    levels = Level.BOTH
    relaxation = Relaxation.HARD
    holds_at_rest = True

    def __init__(self, max_rows: int, joints: np.ndarray | None = None):
        self.max_rows = max_rows
        self.joints = joints

    def configure(self, kin: object, setup: ConstraintSetup) -> None:
        pass

    def compute_qp_inequalities(self, cycle: CycleState, rows: RowBlock) -> int:
        rows.C[: self.max_rows] = 1.0
        rows.lo[: self.max_rows] = -1.0
        rows.hi[: self.max_rows] = 1.0
        return self.max_rows


def _fill(layout: Layout) -> None:
    nv = len(layout.damping) + len(layout.fixed)
    layout.fill(CycleState(None, np.zeros(nv), np.zeros(nv)), None)  # type: ignore[arg-type]


def test_the_same_configuration_gets_its_layout_back_reset_as_new():
    cache = LayoutCache(1e-9)
    frozen = np.array([True, False, False, False])
    constraints = [Rows(2), Rows(1, np.array([0]))]
    layout = cache.get(frozen, constraints)
    _fill(layout)
    assert layout.solved.C.any()
    again = cache.get(frozen.copy(), constraints)
    assert again is layout and (cache.hits, cache.misses) == (1, 1)
    assert not layout.solved.C.any() and not layout.level1[0].any()
    assert np.all(layout.solved.lo == -INF) and np.all(layout.solved.hi == INF)
    assert layout.solved._filled == [0]  # the checked constraint (frozen joint 0) is apart
    assert layout.checked is not None and not layout.checked.C.any()


def test_another_mask_or_row_count_or_joint_set_gets_another_layout():
    cache = LayoutCache(1e-9)
    frozen = np.array([True, False, False])
    rows = Rows(2, np.array([1]))
    first = cache.get(frozen, [rows])
    assert cache.get(np.array([False, False, True]), [rows]) is not first
    rows.max_rows = 3  # configured anew with more rows
    third = cache.get(frozen, [rows])
    assert third is not first and third.m == 3
    rows.joints = np.array([2])
    assert cache.get(frozen, [rows]) is not third
    assert cache.misses == 4 and cache.hits == 0


def test_the_least_recently_used_layout_goes_first():
    cache = LayoutCache(1e-9, size=2)
    rows = [Rows(1)]
    masks = [np.array(m, dtype=bool) for m in ([1, 0], [0, 1], [0, 0])]
    a = cache.get(masks[0], rows)
    cache.get(masks[1], rows)
    assert cache.get(masks[0], rows) is a  # used again: the most recent now
    cache.get(masks[2], rows)  # the third: masks[1] goes
    assert len(cache) == 2 and cache.get(masks[0], rows) is a
    cache.get(masks[1], rows)
    assert cache.misses == 4
    cache.clear()
    assert len(cache) == 0
