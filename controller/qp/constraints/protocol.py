"""The constraint protocol of the whole-body QP: what a limit provides, and when it may give.

Every cycle the IK solves over the joint velocities ``v`` [rad/s, m/s]::

    lb ≤ v ≤ ub            one box constraint: the joint box (velocity, acceleration,
                           braking distance, frozen joints), :class:`BoxConstraint`
    lo ≤ C v ≤ hi          any number of row constraints, :class:`Constraint`

A row constraint fills its rows in buffers the IK preallocates (a :class:`RowBlock` of
``max_rows`` rows over every joint) and returns how many rows it wrote this cycle: the count
may change from cycle to cycle (collision pairs coming into range), the IK leaves the unused
rows free (``0·v`` in ``[-INF, INF]``), so the QP keeps its shape and its warm start.
Two-sided rows rather than Pink's and mink's ``G Δq ≤ h``: an equality or a band is one row,
not two, and the solver keeps it as one.

Each constraint says in which hierarchy level it applies (:class:`Level`) and what the IK
may do when the QP has no solution (:class:`Relaxation`), instead of the IK knowing rows by
their index. Adding a constraint is one class with the members of :class:`Constraint` and
one call, :meth:`controller.qp.ik.WholeBodyIK.add`.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import NamedTuple, Protocol

import numpy as np

from controller.model.kinematics import Kinematics
from controller.model.redundant_axes import RedundantAxis

#: Bounds beyond this magnitude are no bounds (the solvers take finite numbers best).
INF = 1e20


class Level(enum.Flag):
    """The hierarchy levels a constraint applies in (see :mod:`controller.qp.ik`)."""

    #: Level 1: the control points (and joint or vehicle targets of unit moves).
    FIRST = enum.auto()
    #: Level 2: the redundant axes, solved in the null space of level 1.
    SECOND = enum.auto()
    BOTH = FIRST | SECOND


class Relaxation(enum.Enum):
    """What the IK may do with a constraint's rows when the level-1 QP has no solution.

    The IK retries twice: first with every relaxable row widened to a band that contains 0
    (``lo ≤ 0 ≤ hi``: "no further" drift, "no further" out; v = 0 then satisfies it), then,
    if that fails too, without the droppable rows. A relaxation lasts one cycle and the
    step's message says which constraints gave.
    """

    #: Never relaxed: physics (a differential base cannot move sideways), the joint box.
    HARD = "hard"
    #: Widened to "no further" on the first retry and kept so (never dropped).
    NO_FURTHER = "no further"
    #: Widened on the first retry, left out on the second (held axes and axis ranges).
    NO_FURTHER_THEN_DROP = "no further, then dropped"


@dataclass
class ConstraintSetup:
    """What a motion configures for its whole duration (``WholeBodyIK.configure``).

    ``frozen``: joints held still (a mask over ``kin.joint_names``); ``allowed``: redundant
    axes a Cartesian move may use (False: held at its value when configured); ``ranges``:
    axis ranges [rad, m] (None: unlimited). Axes not named are allowed and unlimited.
    """

    frozen: np.ndarray
    allowed: Mapping[RedundantAxis, bool] = field(default_factory=dict)
    ranges: Mapping[RedundantAxis, tuple[float, float] | None] = field(default_factory=dict)


@dataclass(slots=True)
class CycleState:
    """What a row constraint may read this cycle; one object, updated in place by the IK.

    ``kin`` is at the measured state; ``q`` [rad, m] is the last commanded position and
    ``v_prev`` [rad/s, m/s] the last commanded velocity; ``lb``/``ub`` [rad/s, m/s] the
    cycle's joint box over every joint (None for callers without a box: plain bounds).
    """

    kin: Kinematics
    q: np.ndarray
    v_prev: np.ndarray
    lb: np.ndarray | None = None
    ub: np.ndarray | None = None


class RowBlock(NamedTuple):
    """A constraint's preallocated rows: ``lo ≤ C v ≤ hi``, ``max_rows`` rows over every joint.

    Views into the IK's buffers, made once per configuration. Rows of ``C`` keep what the
    constraint wrote last (zeros at first); ``lo`` and ``hi`` of every row it reports must be
    written on each call (the IK shifts and relaxes them in place).
    """

    C: np.ndarray  # (max_rows, nv) [row unit per joint unit]
    lo: np.ndarray  # (max_rows,) [unit of the row per s]
    hi: np.ndarray  # (max_rows,)


class ConstraintBase(Protocol):
    """What every constraint says about itself."""

    @property
    def name(self) -> str:
        """What the constraint is, for messages ("held axes and ranges")."""
        ...

    @property
    def levels(self) -> Level:
        """The hierarchy levels it applies in."""
        ...

    @property
    def relaxation(self) -> Relaxation:
        """What may give when the QP has no solution."""
        ...

    def configure(self, kin: Kinematics, setup: ConstraintSetup) -> None:
        """A new motion's configuration (``kin`` at the measured state); called by the IK
        only, before it lays out its buffers."""
        ...


class Constraint(ConstraintBase, Protocol):
    """Linear rows ``lo ≤ C v ≤ hi`` on the joint velocities, filled every cycle."""

    @property
    def max_rows(self) -> int:
        """Most rows the constraint can report until the next :meth:`configure` (0: none)."""
        ...

    @property
    def joints(self) -> np.ndarray | None:
        """Indices of the joints its rows can have coefficients on, after :meth:`configure`
        (None: any). When all are frozen its rows are checked instead of solved."""
        ...

    @property
    def holds_at_rest(self) -> bool:
        """True when ``v = 0`` always satisfies its rows (``lo ≤ 0 ≤ hi``): rows checked
        with their joints at rest then need no evaluation."""
        ...

    def compute_qp_inequalities(self, cycle: CycleState, rows: RowBlock) -> int:
        """Write this cycle's rows into the first rows of ``rows``; return their count
        (at most :attr:`max_rows`)."""
        ...


class BoxConstraint(ConstraintBase, Protocol):
    """Per-joint bounds ``lb ≤ v ≤ ub``; a frozen joint gets ``lb = ub`` (its velocity)."""

    def compute_qp_bounds(self, q: np.ndarray, v_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(lb, ub)`` [rad/s, m/s] for commanded position ``q`` [rad, m] and previous
        velocity ``v_prev`` [rad/s, m/s]; never ``lb > ub``."""
        ...
